"""evaluate.score on hand-made truth and tracks: a track that switches objects after its verdict
is credited to the object it looked at while deciding (with windows) or to the object it is
assigned to (without)."""

from types import SimpleNamespace

import numpy as np

from rhythmjax.sim.evaluate import match_tracks, score, window_objects


N = 100


def _obj(name, kind, u0, du):
    k = np.arange(N, dtype=float)
    return SimpleNamespace(track_id=name, kind=kind, pace_hz=2.0, step_length_m=0.7,
                           u=u0 + du * k, v=np.full(N, 300.0), visible=np.ones(N, bool),
                           width_px=np.full(N, 40.0))


def _tracks(parts):
    """parts: (track_id, frames, u) triples; v on the objects' row."""
    cols = {"track_id": [], "frame": [], "u": [], "v": []}
    for t, frames, u in parts:
        cols["track_id"] += [t] * len(frames)
        cols["frame"] += list(frames)
        cols["u"] += list(u)
        cols["v"] += [300.0] * len(frames)
    return {k: np.asarray(v) for k, v in cols.items()}


def _verdicts(rows):
    keys = ("track_id", "verdict", "pace_hz", "stride_m", "n_samples")
    return {k: np.asarray([r[i] for r in rows], dtype=object if k == "verdict" else None)
            for i, k in enumerate(keys)}


WALKER, BIKE = _obj("ped000", "pedestrian", 100.0, 2.0), _obj("bic001", "bicycle", 160.0, 0.0)


def test_a_switch_after_the_verdict_is_credited_to_the_object_looked_at():
    """Track 1 follows the walker (2 px a frame) for frames 0-39, then the (parked) bicycle
    for 40-99, 2 px off it: over the whole track its median distance is 2 px to the bicycle and
    36 px to the walker (beyond the 15 px limit), so it is assigned to the bicycle. Its verdict
    (Pedestrian) came from the window of frames 0-63, where the median distance to the walker
    is 0 (40 of 64 frames on it). Track 2 is the walker's own late track, unclassified."""
    k = np.arange(N)
    u1 = np.where(k < 40, WALKER.u, BIKE.u + 2.0)
    tracks = _tracks([(1, k, u1), (2, k[70:], WALKER.u[70:] + 1.0)])
    verdicts = _verdicts([(1, "pedestrian", 2.0, 0.7, 100), (2, "unclassified", np.nan,
                                                                np.nan, 30)])
    assert match_tracks(tracks, [WALKER, BIKE]) == {1: BIKE, 2: WALKER}
    by_track = {r["object"]: r["verdict"] for r in
                score(tracks, verdicts, [WALKER, BIKE])["objects"]}
    assert by_track == {"ped000": "unclassified", "bic001": "pedestrian"}
    windows = {1: (0, 63)}
    assert window_objects(tracks, [WALKER, BIKE], windows) == {1: WALKER}
    res = score(tracks, verdicts, [WALKER, BIKE], windows=windows)
    assert {r["object"]: r["verdict"] for r in res["objects"]} == {
        "ped000": "pedestrian", "bic001": "unclassified"}
    assert res["walker_pedestrian_rate"] == 1.0 and res["walker_pedestrian_rate_judged"] == 1.0


def test_window_on_two_objects_half_each_goes_to_the_nearer_and_far_ones_to_none():
    """A window whose frames are mostly 30 px away from everything (beyond the 15 px limit)
    judges no object; an object seen in fewer than half of the window's frames is not its."""
    k = np.arange(N)
    far = _tracks([(1, k, WALKER.u + 30.0)])
    assert window_objects(far, [WALKER, BIKE], {1: (0, 63)}) == {}
    brief = SimpleNamespace(**{**vars(BIKE), "visible": k < 20})
    on_bike = _tracks([(1, k, BIKE.u)])
    assert window_objects(on_bike, [brief], {1: (0, 63)}) == {}
    assert window_objects(on_bike, [brief], {1: (0, 30)}) == {1: brief}


def test_classifiable_walkers_are_counted_apart():
    """Two walkers, one judged Pedestrian by its track, one missed; the missed one has too few
    clean frames to be classifiable: 1 of 2 walkers judged Pedestrian, 1 of 1 classifiable."""
    other = _obj("ped002", "pedestrian", 400.0, -1.0)
    k = np.arange(N)
    tracks = _tracks([(1, k, WALKER.u)])
    verdicts = _verdicts([(1, "pedestrian", 2.0, 0.7, 100)])
    clean = {"ped000": (100, True), "ped002": (40, False), "bic001": (70, True)}
    res = score(tracks, verdicts, [WALKER, other, BIKE], classifiable=clean)
    rows = {r["object"]: (r["verdict"], r["clean_frames"], r["classifiable"])
            for r in res["objects"]}
    assert rows == {"ped000": ("pedestrian", 100, True), "ped002": ("missed", 40, False),
                    "bic001": ("missed", 70, True)}
    assert (res["walkers"], res["walkers_pedestrian"]) == (2, 1)
    assert (res["walkers_classifiable"], res["classifiable_pedestrian"]) == (1, 1)
    assert res["walker_pedestrian_rate"] == 0.5
    assert res["walker_pedestrian_rate_classifiable"] == 1.0
    plain = score(tracks, verdicts, [WALKER, other, BIKE])  # without: every walker counts
    assert "classifiable" not in plain["objects"][0]
    assert plain["walkers_classifiable"] == 2 and plain["classifiable_pedestrian"] == 1
