"""Streaming classification of stored tracks: files read by record batches, whole tracks
classified chunk by chunk while the next is prepared, verdicts written as resumable parts
(`stream.classify`); the Dask path maps `classify_partition` over `io.stream.Partition`s
(`stream.distributed`). Layer: above `count`, below `sim` and `cli`."""
