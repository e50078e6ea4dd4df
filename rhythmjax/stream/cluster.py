"""The LocalCluster that `--dask` starts (`stream.distributed.connect`): worker processes with
glibc's default memory allocation and no statistical profiler.

Dask's Nanny starts each worker process with `MALLOC_TRIM_THRESHOLD_=65536` (the Dask config
`distributed.nanny.pre-spawn-environ`), so that freed memory goes back to the OS at once. Setting
it turns off glibc's dynamic mmap threshold: every allocation over 128 KiB (a NumPy array of the
kernels' chunks, a record batch) is then a fresh `mmap` whose pages the kernel zeroes on first
touch, and is unmapped again when freed. The classifier allocates such arrays all the time: on
the 100 000-track file a process under that setting took 4.5 M page faults instead of 0.4 M and
23 s of CPU instead of 14 s (docs/distributed.md, "Measured"). The workers of the LocalCluster
started here are therefore spawned without it, as the single process runs. A value the user's
own environment sets is kept (Dask gives it precedence). Only these worker processes are
affected: the config is set for the cluster's start, where the Nanny reads it, and restored.

The workers also get `MALLOC_ARENA_MAX=1`: one malloc arena instead of one per thread that
allocates (the Dask thread, XLA's threads), so fewer fresh pages; at 1e6 tracks, with the
partitions of 2^20 rows, the workers' system time fell from 13-17 s to 9-11 s and the run's wall
time from 1.23-1.26 to 1.09-1.16 times the single process's (docs/distributed.md, "Measured").

Each Dask worker also samples its threads' Python stacks every 10 ms for the dashboard's
profile (`distributed.worker.profile`), taking the GIL from the task each time. This cluster
has no dashboard, so nothing would ever show those samples: its workers run without them.
"""

from __future__ import annotations

import contextlib
import logging
from collections.abc import Iterator


# Dask config for the LocalCluster's start (module doc): None drops the variable from those the
# Nanny sets before it spawns a worker; the Nanny hands its config on to the worker process
LOCAL_WORKER_CONFIG = {"distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None,
                       "distributed.nanny.pre-spawn-environ.MALLOC_ARENA_MAX": "1",
                       "distributed.worker.profile.enabled": False}


@contextlib.contextmanager
def local_cluster(n_workers: int = 2) -> Iterator:
    """A `dask.distributed.LocalCluster` of `n_workers` processes with one thread each, no
    dashboard, quiet logs, its workers spawned with `LOCAL_WORKER_CONFIG` (module doc). Closed
    on exit. Needs dask.distributed."""
    import dask
    from dask.distributed import LocalCluster

    with dask.config.set(LOCAL_WORKER_CONFIG):
        cluster = LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=True,
                               dashboard_address=None, silence_logs=logging.ERROR)
    with cluster:
        yield cluster
