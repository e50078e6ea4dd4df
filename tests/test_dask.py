"""The Dask path (`stream.distributed.classify_dask`) against the single process
(`stream.classify.classify_source`): a LocalCluster of 2 worker processes gives the same verdicts
file, a worker's `BadInput` comes back as the same message, an interrupted run resumes from its
parts, and the config reaches the workers bit for bit as JSON.

Time goes to compiling (tens of seconds a process on a loaded machine, the kernels themselves
take well under a second here), so the single-process reference runs on one of the workers,
filling the workers' shared compilation cache, and the Dask runs load what they can from it; the
test process compiles nothing."""

import json
import os

import jax
import numpy as np
import pyarrow.parquet as pq
import pytest

from rhythmjax.io import BadInput, write_table
from rhythmjax.model.params import Config, config_from_dict, config_to_dict
from rhythmjax.sim.bulk import write_bulk_tracks


distributed = pytest.importorskip("distributed")
import dask  # noqa: E402

from rhythmjax.stream import distributed as dist  # noqa: E402
from rhythmjax.stream.classify import classify_source  # noqa: E402
from rhythmjax.stream.cluster import LOCAL_WORKER_CONFIG, local_cluster  # noqa: E402


ORDER = ["track_id", "frame", "t", "u", "v", "width_px", "intensity", "label", "x", "y"]
N_TRACKS = 220
ROWS = 5000  # rows per partition: the file below (about 18 500 rows) is cut into 4
CHUNK = 8  # tracks per chunk in both paths: every chunk 8 rows, so the partitions meet no shape
# the reference did not compile, and the workers load them all from the cache
KEYS = ("n_tracks", "verdicts", "reasons", "labels")


@pytest.fixture(scope="module")
def client():
    """The LocalCluster `--dask` starts (`stream.cluster.local_cluster`: 2 worker processes, one
    thread each), shared by the tests of this module; it takes about 5 s to start. The test
    process's own MALLOC_TRIM_THRESHOLD_ is left out while it starts: a LocalCluster started
    earlier in this process without `local_cluster` (Dask's Nanny) sets it here."""
    with pytest.MonkeyPatch.context() as mp:
        mp.delenv("MALLOC_TRIM_THRESHOLD_", raising=False)
        with local_cluster(2) as cluster, distributed.Client(cluster) as c:
            mp.undo()
            yield c


@pytest.fixture(scope="module")
def tracks_file(tmp_path_factory):
    """A labelled tracks file of 220 tracks (walkers, bicycles, dogs, cars, short walkers)."""
    path = tmp_path_factory.mktemp("dask") / "tracks.parquet"
    write_bulk_tracks(path, N_TRACKS, seed=5)
    return str(path)


@pytest.fixture(scope="module")
def cache_dir(tmp_path_factory):
    """The workers' shared compilation cache (the test's own folder)."""
    return str(tmp_path_factory.mktemp("xla"))


def single_process(wire: str, path: str, out: str, cache_dir: str) -> dict:
    """`classify_source` in the worker process this runs on, its cache set first."""
    dist.worker_setup(cache_dir)
    summary = classify_source(dist.config_from_wire(wire), path, out, chunk=CHUNK, log=None)
    return {k: summary[k] for k in KEYS}


@pytest.fixture(scope="module")
def reference(client, tracks_file, cache_dir, tmp_path_factory):
    """The single-process path's verdicts file and summary (run on one worker, see above)."""
    out = str(tmp_path_factory.mktemp("one") / "one.parquet")
    wire = dist.config_wire(Config())
    summary = client.submit(single_process, wire, tracks_file, out, cache_dir, pure=False)
    result = summary.result()
    return pq.read_table(out), result


def test_config_reaches_the_workers_bit_for_bit():
    cfg = Config()
    again = config_from_dict(json.loads(json.dumps(config_to_dict(cfg))))
    differ = [bool(np.any(np.asarray(a) != np.asarray(b))) for a, b in
              zip(jax.tree_util.tree_leaves(cfg), jax.tree_util.tree_leaves(again))]
    assert any(differ)  # why the leaves travel too: the dict alone is a bit off (log q)
    wire = dist.config_wire(cfg)
    json.loads(wire)  # plain JSON
    back = dist.config_from_wire(wire)
    assert dist.config_from_wire(wire) is back  # built once per process
    assert jax.tree_util.tree_structure(back) == jax.tree_util.tree_structure(cfg)
    for a, b in zip(jax.tree_util.tree_leaves(cfg), jax.tree_util.tree_leaves(back)):
        assert np.asarray(a).dtype == np.asarray(b).dtype
        assert np.array_equal(np.asarray(a), np.asarray(b))


def worker_settings() -> dict:
    """The allocator variables and the profiler setting of the worker process this runs on."""
    return {"environ": {k: v for k, v in os.environ.items() if k.startswith("MALLOC_")},
            "profile": dask.config.get("distributed.worker.profile.enabled")}


def test_local_cluster_workers_keep_glibc_default_malloc(client):
    # Dask's Nanny would start the workers with MALLOC_TRIM_THRESHOLD_=65536, which turns off
    # glibc's dynamic mmap threshold (10 times the page faults, 60 % more CPU here), and
    # sample their stacks every 10 ms for a dashboard this cluster does not have
    got = client.run(worker_settings)
    assert len(got) == 2
    for settings in got.values():
        assert "MALLOC_TRIM_THRESHOLD_" not in settings["environ"]
        assert settings["environ"].get("MALLOC_ARENA_MAX") == "1"
        assert settings["profile"] is False
    # the Dask config is set only while the cluster starts, not left in the client process
    for key, value in LOCAL_WORKER_CONFIG.items():
        assert dask.config.get(key, default="unset") != value


def test_same_verdicts_as_one_process(client, tracks_file, cache_dir, reference, tmp_path):
    table, summary = reference
    out = tmp_path / "dask.parquet"
    got = dist.classify_dask(Config(), tracks_file, out, scheduler=client, chunk=CHUNK,
                             rows_per_partition=ROWS, progress=False, cache_dir=cache_dir,
                             log=None)
    assert got["partitions"] >= 3 and got["workers"] == 2 and got["workers_used"] >= 1
    assert table.num_rows == got["n_tracks"] == N_TRACKS
    assert pq.read_table(out).equals(table)  # every column, bit for bit, in the input's order
    assert {k: got[k] for k in KEYS} == summary
    assert not (tmp_path / ".dask.parquet.parts").exists()  # parts gone after the assembly
    mem = dist.classify_dask(Config(), tracks_file, None, scheduler=client, chunk=CHUNK,
                             rows_per_partition=ROWS, progress=False, cache_dir=cache_dir,
                             log=None)
    assert list(mem["verdicts_table"]["verdict"]) == table.column("verdict").to_pylist()


def test_bad_input_on_a_worker_is_the_same_message(client, tracks_file, cache_dir, reference,
                                                   tmp_path):
    cols = {k: np.asarray(v) for k, v in pq.read_table(tracks_file).to_pydict().items()}
    cols["width_px"] = cols["width_px"].astype(float)
    bad_row = 6000  # in the second partition; the one in the last comes later in the file
    cols["width_px"][[bad_row, len(cols["frame"]) - 40]] = -3.0
    bad = tmp_path / "bad.parquet"
    write_table(bad, cols, ORDER)
    with pytest.raises(BadInput) as one:  # the whole file is one block: no kernel runs here
        classify_source(Config(), bad, tmp_path / "one.parquet", chunk=CHUNK, log=None)
    with pytest.raises(BadInput) as many:
        dist.classify_dask(Config(), bad, tmp_path / "many.parquet", scheduler=client,
                           chunk=CHUNK, rows_per_partition=ROWS, progress=False,
                           cache_dir=cache_dir, log=None)
    assert str(many.value) == str(one.value)  # the first in file order, as on one process
    assert f"row {bad_row + 1}" in str(many.value) and "width_px" in str(many.value)
    assert not (tmp_path / ".many.parquet.parts").exists()  # as the single process: no parts


def test_interrupted_run_resumes(client, tracks_file, cache_dir, reference, tmp_path,
                                 monkeypatch):
    out, said = tmp_path / "v.parquet", []
    real_add = dist.Done.add

    def add_then_stop(self, first_file, partition, res):
        if self.parts is not None and len(self.parts.done) == 2:
            raise KeyboardInterrupt
        real_add(self, first_file, partition, res)

    kw = dict(scheduler=client, chunk=CHUNK, rows_per_partition=ROWS, progress=False,
              cache_dir=cache_dir, log=said.append)
    monkeypatch.setattr(dist.Done, "add", add_then_stop)
    with pytest.raises(KeyboardInterrupt):
        dist.classify_dask(Config(), tracks_file, out, **kw)
    assert not out.exists() and "2 part(s) done kept" in said[-1]
    monkeypatch.setattr(dist.Done, "add", real_add)
    got = dist.classify_dask(Config(), tracks_file, out, **kw)
    assert got["resumed_parts"] == 2 and "resuming" in said[-1]
    assert pq.read_table(out).equals(reference[0])
    assert {k: got[k] for k in KEYS} == reference[1]


def test_unreachable_scheduler_is_bad_input(tracks_file, tmp_path, monkeypatch):
    monkeypatch.setattr(dist, "CONNECT_TIMEOUT_S", 1)
    with pytest.raises(BadInput, match="cannot reach a Dask scheduler"):
        dist.classify_dask(Config(), tracks_file, tmp_path / "v.parquet",
                           scheduler="tcp://127.0.0.1:9", progress=False, log=None)
    assert not (tmp_path / ".v.parquet.parts").exists()
