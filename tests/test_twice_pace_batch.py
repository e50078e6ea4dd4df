"""Rule 37 in the batch classifier (`track.twice.batch_second_look`, `model.batch.
classify_tracks(second_look=...)`, count's `verdicts.twice_pace_heights`): each window the batch
classifies is judged at half its strongest peak exactly as the tracker's `judge_at_half` judges
the same window from the same rows, on the batch path, the long-track path and count's
`judge_tracks`; and rule 37's reading of rows whose moving region reached the image's first row
(`twice_height`, count's `top_at_edge`: the height up to that row, a lower bound). Walking model
of Table 1 (pace [1.501, 2.599] Hz, step [0.45, 0.99] m)."""

import numpy as np
import pytest

from rhythmjax.count.judge import judge_tracks
from rhythmjax.io.files import Tracks, read_tracks, to_batch, write_table
from rhythmjax.model.batch import classify_tracks
from rhythmjax.model.camera_np import project_3d, upright_size
from rhythmjax.model.params import config_from_dict
from rhythmjax.model.status import Reason, Verdict
from rhythmjax.track.options import SizeOptions
from rhythmjax.track.rows import TrackRow
from rhythmjax.track.twice import (
    batch_second_look,
    judge_at_half,
    reads_twice,
    tall_enough,
    twice_height,
)


CFG = config_from_dict({"thresholds": {"range_max_m": 40.0}})  # the paper's, range to 40 m: a
# walker's head is inside the image from 15 m on
ON = SizeOptions(twice_pace_heights=0.75, twice_pace_edge=False)  # 0.75 walker heights (the
# a priori value these tests were written at; the default is the fitted 0.57), edge rows unread
EDGE = SizeOptions(twice_pace_heights=0.75)  # ... and read (rule 37b; the default)
FPS = 15.0


def _object(top_m: float, n: int = 128, pace: float = 4.0, speed: float = 1.3, seed: int = 0,
            y0: float = 22.0):
    """n rows of an object `top_m` m tall going away from `y0` m at `speed` m/s in front of the
    paper's camera: foot point, width of a walker at the feet, top row (NaN where above the
    image's first row, top_at_edge 1 there), and I(k) a sine at `pace` Hz (amplitude 5) plus
    noise of 1.0. From 22 m on a walker's head is inside the image; below 15 m it is not."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / FPS
    y = y0 + speed * t
    u, v = project_3d(CFG.camera, 0 * y, y, 0 * y)
    _, v_top = project_3d(CFG.camera, 0 * y, y, top_m + 0 * y)
    v_top = np.asarray(v_top, np.float64)
    edge = v_top < 0
    w, _, _ = upright_size(CFG.camera, u, v, float(CFG.width.mean), 1.7)
    sig = 20.0 + 5.0 * np.sin(2 * np.pi * pace * t) + rng.normal(0, 1.0, n)
    return {"t": t, "u": np.asarray(u), "v": np.asarray(v),
            "v_top": np.where(edge, np.nan, v_top), "top_at_edge": edge.astype(np.float64),
            "width_px": np.asarray(w), "intensity": sig, "y": y}


def _tracks(objects: list[dict]) -> dict:
    """A counting run's tracks table (`counting.tracks_table`'s columns `judge_tracks` reads)
    of `objects`, ids 1.."""
    cols = {k: np.concatenate([o[k] for o in objects])
            for k in ("t", "u", "v", "v_top", "top_at_edge", "width_px", "intensity")}
    cols["track_id"] = np.concatenate([np.full(len(o["t"]), i + 1) for i, o in enumerate(objects)])
    cols["frame"] = np.concatenate([np.arange(len(o["t"])) for o in objects])
    return cols


def _batch(objects: list[dict]):
    tr = _tracks(objects)
    tracks = Tracks(path="<test>", track_id=tr["track_id"].astype(str).astype(object),
                    frame=tr["frame"], t=tr["t"], u=tr["u"], v=tr["v"],
                    width_px=tr["width_px"], intensity=tr["intensity"],
                    line=np.arange(len(tr["t"])), fps=FPS, v_top=tr["v_top"],
                    top_at_edge=tr["top_at_edge"])
    return to_batch(tracks, max_gap_frames=15, min_len=CFG.thresholds.n)


def _out(f1=4.0, p1=40.0, ratio=0.8, speed=1.4, reason=Reason.NO_MODEL_MATCH):
    return {"verdict": np.asarray(int(Verdict.NON_PEDESTRIAN)), "reason": np.asarray(int(reason)),
            "pace_hz": np.asarray(f1, np.float32), "stride_m": np.asarray(speed / f1, np.float32),
            "ratio": np.asarray(ratio, np.float32), "speed_mps": np.asarray(speed, np.float32),
            "peak_freq": np.asarray([f1, 1.0], np.float32),
            "peak_power": np.asarray([p1, 5.0], np.float32),
            "peak_mask": np.asarray([True, True])}


def _rows(obj: dict, start: int, n: int) -> list[TrackRow]:
    return [TrackRow(k, float(obj["t"][k]), float(obj["u"][k]), float(obj["v"][k]),
                     float(obj["width_px"][k]), float(obj["intensity"][k]), 0.0,
                     float(obj["y"][k]), 2, float(obj["v_top"][k]), top_at_edge=bool(
                         obj["top_at_edge"][k]))
            for k in range(start, start + n)]


def test_the_batch_look_judges_each_window_as_the_tracker_does():
    """Nine windows (outcomes of every kind rule 37 reads, on a walker's rows and a dog's) in
    one call: each window's verdict, reason, pace and stride equal `judge_at_half`'s on the
    same rows (the tracker's), and the refused ones are left as they are."""
    walker, dog = _object(1.7), _object(0.6)
    cases = [(_out(), walker, 0), (_out(), dog, 0), (_out(f1=6.0), walker, 32),
             (_out(speed=2.3), walker, 0), (_out(p1=9.0), walker, 0),
             (_out(ratio=0.05), walker, 0), (_out(reason=Reason.BELOW_THRESHOLD), walker, 0),
             (_out(f1=2.0), walker, 0), (_out(f1=3.6, speed=1.2), walker, 64)]
    res = {k: np.stack([c[0][k] for c in cases]) for k in cases[0][0]}
    z = np.stack([np.stack([o["u"], o["v"]], -1) for o in (walker, dog)])
    batch = type("B", (), {"z": z, "v_top": np.stack([walker["v_top"], dog["v_top"]])})()
    look = batch_second_look(CFG, batch, ON)
    track = np.asarray([0 if c[1] is walker else 1 for c in cases])
    start = np.asarray([c[2] for c in cases])
    got = look(res, track, start)
    n = CFG.thresholds.n
    for w, (out, obj, k) in enumerate(cases):
        want = judge_at_half(out, CFG, _rows(obj, k, n), CFG.camera, 1.7, ON)
        for key in ("verdict", "reason", "pace_hz", "stride_m"):
            assert float(got[key][w]) == pytest.approx(float(want[key]), rel=1e-6), (w, key)
    assert [int(v) for v in got["verdict"]] == [Verdict.PEDESTRIAN, Verdict.NON_PEDESTRIAN] + \
        [Verdict.NON_PEDESTRIAN] * 6 + [Verdict.PEDESTRIAN]
    assert float(got["pace_hz"][8]) == pytest.approx(1.8) and \
        float(got["stride_m"][8]) == pytest.approx(2 * 1.2 / 3.6)
    assert reads_twice(res, CFG).tolist() == [True, True] + [False] * 6 + [True]


def test_the_look_is_none_when_off_or_without_top_rows():
    batch = _batch([_object(1.7)])
    assert batch_second_look(CFG, batch, SizeOptions(twice_pace_heights=0.0)) is None
    batch.v_top = None
    assert batch_second_look(CFG, batch, ON) is None


@pytest.mark.parametrize("segment_rows", [4096, 64])
def test_classify_tracks_judges_a_walker_at_twice_its_pace(segment_rows):
    """A walker read at 4.0 Hz over 128 rows at 1.3 m/s (two bursts a step) and a 0.6 m dog
    with the same signal: without the look both are Non-pedestrian (no-model-match); with it
    the walker is Pedestrian at 2.0 +- 0.05 Hz, stride 2 v / f1, the dog stays refused. The
    same on the batch path and on the long-track path (segment_rows 64: tracks of 128 rows go
    one by one through `long_tracks`)."""
    batch = _batch([_object(1.7), _object(0.6, seed=1)])
    off = classify_tracks(CFG, batch, progress=False, segment_rows=segment_rows)
    assert list(off["verdict"]) == ["non-pedestrian"] * 2
    assert list(off["reason"]) == ["no-model-match"] * 2
    look = batch_second_look(CFG, batch, ON)
    on = classify_tracks(CFG, batch, progress=False, segment_rows=segment_rows,
                         second_look=look)
    assert list(on["verdict"]) == ["pedestrian", "non-pedestrian"]
    assert on["reason"][0] == "matched-twice"
    assert float(on["pace_hz"][0]) == pytest.approx(2.0, abs=0.05)
    assert float(on["stride_m"][0]) == pytest.approx(
        2 * float(on["speed_mps"][0]) / float(on["peak_freq"][0][0]), rel=1e-5)


def test_classify_tracks_hands_the_look_each_window_once_with_its_rows():
    """The look sees every window the classifier judges, with the rows of the batch it is made
    of: a walker of 160 rows at its pace (2.0 Hz, Pedestrian at window 0) and one read at twice
    it (windows 0, 1, 2 and 3 start at rows 0, 32, 64 and 96; none says Pedestrian)."""
    batch = _batch([_object(1.7, n=160, pace=2.0), _object(1.7, n=160, seed=1)])
    seen = []

    def record(res, track, start, twice=True):
        seen.extend(zip(track.tolist(), start.tolist()))
        return res

    classify_tracks(CFG, batch, progress=False, second_look=record)
    assert sorted(seen) == [(0, 0), (1, 0), (1, 32), (1, 64), (1, 96)]


def test_judge_tracks_reads_the_top_rows():
    """count's `judge_tracks` with `twice_pace_heights` 0.75 (count's default) takes the tracks'
    v_top: the walker at twice its pace is Pedestrian (matched-twice), with 0 it is not."""
    tracks = _tracks([_object(1.7)])
    assert judge_tracks(CFG, tracks, twice_pace_heights=0.0)["reason"][0] == "no-model-match"
    on = judge_tracks(CFG, tracks)
    assert on["verdict"][0] == "pedestrian" and on["reason"][0] == "matched-twice"
    del tracks["v_top"]
    assert judge_tracks(CFG, tracks, twice_pace_heights=0.75)["reason"][0] == "no-model-match"


def test_a_row_at_the_image_edge_reads_the_height_up_to_the_first_row():
    """Rows at 10 m whose region reached row 0 (v_top NaN): each reads the height H whose top
    projects to row 0, against H found by bisection on the forward projection (3) of
    (0, 10 m, H) (within 0.1 mm): about 1.47 m, tall enough for 0.75 walker heights (1.275 m)
    and not for 0.9 (1.53 m); without the edge flag no row is read."""
    y = np.full(12, 10.0)
    u, v = project_3d(CFG.camera, 0 * y, y, 0 * y)
    nan, edge = np.full(12, np.nan), np.ones(12)
    height, n = twice_height(CFG.camera, u, v, nan, edge, 1.7, 0.1)
    lo, hi = 0.0, 5.0  # the top's row falls as H grows: bisect for row 0
    for _ in range(60):
        mid = (lo + hi) / 2
        lo, hi = (mid, hi) if float(project_3d(CFG.camera, 0.0, 10.0, mid)[1]) > 0 else (lo, mid)
    assert n == 12 and height == pytest.approx(lo, abs=1e-4)
    assert tall_enough(height, n, 1.7, ON)
    assert not tall_enough(height, n, 1.7, SizeOptions(twice_pace_heights=0.9))
    assert twice_height(CFG.camera, u, v, nan, None, 1.7, 0.1)[1] == 0
    assert twice_height(CFG.camera, u, v, nan, 0 * edge, 1.7, 0.1)[1] == 0
    # rows read at their height are not read again as edge rows; the median over both kinds
    _, v_top = project_3d(CFG.camera, 0 * y, y + 20, 0.6 + 0 * y)
    u2, v2 = project_3d(CFG.camera, 0 * y, y + 20, 0 * y)
    both = twice_height(CFG.camera, np.r_[u, u2], np.r_[v, v2], np.r_[nan, v_top],
                        np.r_[edge, edge], 1.7, 0.1)
    assert both[1] == 24 and both[0] == pytest.approx((height + 0.6) / 2, abs=1e-3)


def test_a_near_walker_at_twice_its_pace_is_judged_from_its_edge_rows():
    """A walker from 4 m to 12.5 m (its head above the view on every row: no v_top) read at
    4.0 Hz: Non-pedestrian without the edge rows, Pedestrian (matched-twice, 2.0 Hz) with them,
    by `judge_at_half` on its first window's rows and by count's `judge_tracks`; a tracks file
    with the column gives the batch the same rows."""
    near = _object(1.7, y0=4.0, speed=1.0)
    assert np.all(near["top_at_edge"] == 1)
    rows = _rows(near, 0, CFG.thresholds.n)
    assert int(judge_at_half(_out(), CFG, rows, CFG.camera, 1.7, EDGE)["reason"]) == \
        Reason.MATCHED_TWICE
    plain = [r._replace(top_at_edge=False) for r in rows]
    for opt, these in ((EDGE, plain), (ON, rows)):  # no edge row, or not read
        assert int(judge_at_half(_out(), CFG, these, CFG.camera, 1.7, opt)["reason"]) == \
            Reason.NO_MODEL_MATCH
    tracks = _tracks([near])
    off = judge_tracks(CFG, tracks, twice_pace_edge=False)
    on = judge_tracks(CFG, tracks)  # count's defaults: 0.57 walker heights, edge rows read
    assert off["reason"][0] == "no-model-match"
    assert on["verdict"][0] == "pedestrian" and on["reason"][0] == "matched-twice"
    assert float(on["pace_hz"][0]) == pytest.approx(2.0, abs=0.05)


def test_the_tracks_format_carries_top_at_edge(tmp_path):
    tr = _tracks([_object(1.7, y0=4.0, speed=1.0, n=80)])
    path = tmp_path / "tracks.csv"
    write_table(str(path), tr, ["track_id", "frame", "t", "u", "v", "width_px", "intensity",
                                "v_top", "top_at_edge"])
    back = read_tracks(str(path), fps=FPS)
    assert np.array_equal(back.top_at_edge, tr["top_at_edge"])
    batch = to_batch(back, max_gap_frames=15, min_len=64)
    assert np.array_equal(batch.top_at_edge[0, :80], tr["top_at_edge"])


def test_a_negative_or_nan_height_is_refused_by_count_options():
    from rhythmjax.count.options import CountOptions
    from rhythmjax.track.options import with_changes

    for bad in (-0.5, float("nan")):
        with pytest.raises(ValueError, match="twice_pace_heights"):
            with_changes(CountOptions(), {"verdicts.twice_pace_heights": bad})


def test_without_twice_the_looks_leave_rule_37_out():
    """Rule 50b's windows moved across are looked at with `twice` False: rule 37 reads none of
    them (the walker read at twice its pace stays refused), rule 26 still refuses a window too
    low for a walker (a 0.6 m dog judged Pedestrian): the batch looks and the tracker's."""
    from rhythmjax.model.camera_np import camera_tuple
    from rhythmjax.track.looks import tracker_look
    from rhythmjax.track.size import batch_size_look
    from rhythmjax.track.twice import second_look

    walker, dog = _object(1.7), _object(0.6)
    dog_ped = {**_out(f1=2.0), "verdict": np.asarray(int(Verdict.PEDESTRIAN))}
    res = {k: np.stack([_out()[k], dog_ped[k]]) for k in dog_ped}
    z = np.stack([np.stack([o["u"], o["v"]], -1) for o in (walker, dog)])
    batch = type("B", (), {"z": z, "v_top": np.stack([walker["v_top"], dog["v_top"]])})()
    track, start = np.asarray([0, 1]), np.asarray([0, 0])
    size = SizeOptions(twice_pace_heights=0.75, twice_pace_edge=False, min_height_heights=0.5)
    twice = batch_second_look(CFG, batch, size)
    assert twice(res, track, start, twice=False) is res
    both = batch_size_look(CFG, batch, size, then=twice)
    P, NP = int(Verdict.PEDESTRIAN), int(Verdict.NON_PEDESTRIAN)
    assert [int(v) for v in both(res, track, start)["verdict"]] == [P, NP]
    got = both(res, track, start, twice=False)
    assert [int(v) for v in got["verdict"]] == [NP, NP]
    assert [int(r) for r in got["reason"]] == [int(Reason.NO_MODEL_MATCH), int(Reason.TOO_LOW)]
    camera, n = camera_tuple(CFG.camera), CFG.thresholds.n
    one = {k: v[0] for k, v in res.items()}
    plain = second_look(CFG, camera, size)
    assert int(plain(one, _rows(walker, 0, n))["verdict"]) == P
    assert plain(one, _rows(walker, 0, n), twice=False) is one
    look = tracker_look(CFG, camera, size)
    assert int(look(one, _rows(walker, 0, n))["verdict"]) == P
    assert int(look(one, _rows(walker, 0, n), twice=False)["verdict"]) == NP
    low = look(dog_ped, _rows(dog, 0, n), twice=False)
    assert (int(low["verdict"]), int(low["reason"])) == (NP, int(Reason.TOO_LOW))
