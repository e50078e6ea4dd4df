"""Unjudged tracks explained by another counted track (`count.explain`, (E1)-(E2)): hand-built
tracks on the ground plane, the gates' edges worked by hand, and the rule against a plain-Python
reference on random tracks."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from rhythmjax.count import count_walkers, counted, walker_ids
from rhythmjax.count.explain import explain_tracks, measured_points
from rhythmjax.count.options import CountOptions, ExplainOptions


FPS = 10.0
W = 0.5  # body width, m
ON = dataclasses.replace(ExplainOptions(), enabled=True, duplicate_widths=1.0,
                         duplicate_fraction=0.5, continue_widths=2.0, speed_mps=0.5,
                         max_gap_s=5.0, precedes=True)


def walk(f0, f1, x0, y0, vx=1.4, vy=0.0):
    """(frames, ground points m) of a walker at (x0, y0) m in frame f0 moving (vx, vy) m/s."""
    f = np.arange(f0, f1 + 1)
    t = (f - f0) / FPS
    return f, np.stack([x0 + vx * t, y0 + vy * t], 1)


def run(tracks, verdicts, cnt=None, opt=ON):
    cnt = [v != "non-pedestrian" for v in verdicts] if cnt is None else cnt
    return explain_tracks(tracks, verdicts, cnt, FPS, opt, W)


def test_a_fragment_continuing_a_counted_track_is_not_counted():
    a = walk(0, 60, 0.0, 10.0)  # judged pedestrian, ends at x = 8.4 m, frame 60
    # B starts 1 s later 0.9 m further on: gate r0 + v g = 2 x 0.5 + 0.5 x 1 = 1.5 m
    b = walk(70, 85, 8.4 + 0.9, 10.0)
    by, how = run([a, b], ["pedestrian", "unclassified"])
    assert by.tolist() == [0, 1] and how.tolist() == ["", "continues"]
    # a fragment that ends 1 s before the counted track starts, the same distance back
    c = walk(0, 15, -0.9 - 1.4 * 1.5, 10.0)  # ends at x = -0.9 m, frame 15
    d = walk(25, 90, 0.0, 10.0)
    by, how = run([c, d], ["unclassified", "pedestrian"])
    assert by.tolist() == [2, 0] and how.tolist() == ["precedes", ""]
    # without `precedes` the fragment before is counted
    by, _ = run([c, d], ["unclassified", "pedestrian"],
                opt=dataclasses.replace(ON, precedes=False))
    assert by.tolist() == [0, 0]


def test_a_distinct_walker_is_counted():
    a = walk(0, 60, 0.0, 10.0)
    far = walk(10, 40, 0.0, 13.0)  # walks beside A 3 m away: six body widths
    late = walk(70, 85, 8.4 + 3.0, 10.0)  # starts 1 s after A's end, 3 m on (gate 1.5 m)
    long_after = walk(120, 140, 8.4 + 0.5, 10.0)  # 6 s after A's end (max_gap_s 5 s)
    by, how = run([a, far, late, long_after],
                  ["pedestrian", "unclassified", "unclassified", "unclassified"])
    assert by.tolist() == [0, 0, 0, 0] and set(how.tolist()) == {""}


def test_a_simultaneous_duplicate_is_not_counted():
    a = walk(0, 60, 0.0, 10.0)
    dup = walk(20, 40, 1.4 * 2.0 + 0.3, 10.0)  # on A's path 0.3 m ahead of it (< 0.5 m)
    by, how = run([a, dup], ["pedestrian", "unclassified"])
    assert by.tolist() == [0, 1] and how.tolist() == ["", "duplicate"]
    # (E1) needs at least half of its frames near: 0.6 m apart (> 1 W) in 11 of 21 frames
    f, p = dup
    p2 = p.copy()
    p2[:11, 1] += 0.6
    by, _ = run([a, (f, p2)], ["pedestrian", "unclassified"])
    assert by.tolist() == [0, 0]
    p2 = p.copy()
    p2[:10, 1] += 0.6  # 11 of 21 frames near: >= 0.5
    by, _ = run([a, (f, p2)], ["pedestrian", "unclassified"])
    assert by.tolist() == [0, 1]


def test_only_a_counted_stronger_track_explains():
    a = walk(0, 60, 0.0, 10.0)
    b = walk(70, 85, 8.4 + 0.9, 10.0)
    # A judged non-pedestrian (not counted): B is the walker's only count
    by, _ = run([a, b], ["non-pedestrian", "unclassified"])
    assert by.tolist() == [0, 0]
    # A too fast (unclassified, not counted)
    by, _ = run([a, b], ["unclassified", "unclassified"], cnt=[False, True])
    assert by.tolist() == [0, 0]
    # two unjudged fragments of one walker: the longer (A, 61 rows) stays counted
    by, how = run([a, b], ["unclassified", "unclassified"])
    assert by.tolist() == [0, 1]
    # a judged track is never explained, whatever is near it
    by, _ = run([a, walk(20, 40, 2.8, 10.0)], ["unclassified", "pedestrian"])
    assert by.tolist() == [0, 0]
    # of two equal unjudged duplicates the lower index stays
    e = walk(0, 30, 0.0, 10.0)
    by, how = run([e, e], ["unclassified", "unclassified"])
    assert by.tolist() == [0, 1] and how.tolist() == ["", "duplicate"]
    # off: nothing explained
    by, how = run([a, b], ["pedestrian", "unclassified"],
                  opt=dataclasses.replace(ON, enabled=False))
    assert by.tolist() == [0, 0] and how.tolist() == ["", ""]


def test_continuation_gate_edges_worked_by_hand():
    # gap 2 s: gate 2 x 0.5 + 0.5 x 2 = 2.0 m; 1.99 m explained, 2.01 m not
    a = walk(0, 30, 0.0, 10.0)  # ends at x = 4.2 m, frame 30
    for d, want in ((1.99, 2), (2.01, 0)):
        b = (np.arange(50, 60), np.tile([4.2, 10.0 + d], (10, 1)))
        by, _ = run([a, b], ["pedestrian", "unclassified"])
        assert by.tolist() == [0, want // 2], d
    # a gap of exactly 5 s is in, 5.1 s out; a gap of 0 (B starts at A's last frame) is out
    for f0, want in ((80, 1), (81, 0), (30, 0)):
        b = (np.arange(f0, f0 + 10), np.tile([4.2, 10.0], (10, 1)))
        by, how = run([a, b], ["pedestrian", "unclassified"],
                      opt=dataclasses.replace(ON, duplicate_widths=0.0))
        assert by.tolist() == [0, want], f0


def test_measured_points_keeps_measured_finite_rows_in_frame_order():
    tracks = {"track_id": np.asarray([1, 1, 1, 2, 1, 2]),
              "frame": np.asarray([3, 1, 2, 5, 4, 6]),
              "state": np.asarray(["observe", "observe", "predict", "observe", "observe",
                                   "observe"], dtype=object),
              "x_est": np.asarray([3.0, 1.0, 2.0, 5.0, np.nan, 6.0]),
              "y_est": np.asarray([30.0, 10.0, 20.0, 50.0, 40.0, 60.0])}
    (f1, p1), (f2, p2), (f3, p3) = measured_points(tracks, [1, 2, 7])
    assert f1.tolist() == [1, 3] and p1.tolist() == [[1.0, 10.0], [3.0, 30.0]]
    assert f2.tolist() == [5, 6] and p2.tolist() == [[5.0, 50.0], [6.0, 60.0]]
    assert f3.size == 0 and p3.shape == (0, 2)


def reference(tracks, verdicts, cnt, opt, fps, w):
    """Plain-Python (E1)-(E2): dicts and loops, no NumPy set operations."""
    n = [len(f) for f, _ in tracks]
    out = [(0, "")] * len(tracks)
    for b, (fb, pb) in enumerate(tracks):
        if verdicts[b] != "unclassified" or not cnt[b] or not n[b]:
            continue
        strong = [a for a in range(len(tracks)) if a != b and n[a] and cnt[a] and
                  (verdicts[a] != "unclassified" or n[a] > n[b] or (n[a] == n[b] and a < b))]
        found = None
        for a in strong:
            pos = {int(f): (float(x), float(y)) for f, (x, y) in zip(*tracks[a])}
            near = 0
            for f, (x, y) in zip(fb, pb):
                q = pos.get(int(f))
                if q is not None and math.hypot(q[0] - x, q[1] - y) <= opt.duplicate_widths * w:
                    near += 1
            if near >= opt.duplicate_fraction * n[b]:
                found = (a + 1, "duplicate")
                break
        if found is None:
            best = (math.inf, 0, "")
            for a in strong:
                fa, pa = tracks[a]
                pairs = [(fa[-1], pa[-1], fb[0], pb[0], "continues")]
                if opt.precedes:
                    pairs.append((fb[-1], pb[-1], fa[0], pa[0], "precedes"))
                for fe, pe, fs, ps, kind in pairs:
                    g = (fs - fe) / fps
                    d = math.hypot(ps[0] - pe[0], ps[1] - pe[1])
                    if 0 < g <= opt.max_gap_s and d <= opt.continue_widths * w + opt.speed_mps * g:
                        best = min(best, (d, a + 1, kind))
            found = best[1:]
        out[b] = found
    return out


def random_tracks(rng):
    """12 tracks with measurement gaps, near one another, random verdicts and counted flags,
    and 3 unjudged copies of parts of them with 0.3 m noise."""
    tracks, verdicts, cnt = [], [], []
    for _ in range(12):
        f0 = int(rng.integers(0, 80))
        f = np.sort(rng.choice(np.arange(f0, f0 + 40), int(rng.integers(1, 30)), replace=False))
        x0, y0 = rng.uniform(0, 2, 2)
        v = rng.normal(0, 0.6, 2)
        p = np.stack([x0 + v[0] * (f - f0) / FPS, y0 + v[1] * (f - f0) / FPS], 1)
        tracks.append((f, p + rng.normal(0, 0.2, p.shape)))
        verdicts.append(str(rng.choice(["pedestrian", "unclassified", "unclassified",
                                        "non-pedestrian"])))
        cnt.append(verdicts[-1] != "non-pedestrian" and bool(rng.random() > 0.15))
    for k in rng.choice(12, 3, replace=False):  # three near copies of a part of a track
        f, p = tracks[k]
        keep = np.sort(rng.choice(len(f), max(1, len(f) // 2), replace=False))
        tracks.append((f[keep], p[keep] + rng.normal(0, 0.3, (len(keep), 2))))
        verdicts.append("unclassified")
        cnt.append(True)
    return tracks, verdicts, cnt


def test_rule_matches_plain_python_reference():
    kinds = []
    for seed in range(8):
        tracks, verdicts, cnt = random_tracks(np.random.default_rng(seed))
        for opt in (ON, dataclasses.replace(ON, precedes=False, duplicate_widths=2.0),
                    dataclasses.replace(ON, duplicate_fraction=0.2, speed_mps=1.5)):
            by, how = explain_tracks(tracks, verdicts, cnt, FPS, opt, W)
            ref = reference(tracks, verdicts, cnt, opt, FPS, W)
            assert list(zip(by.tolist(), how.tolist())) == ref, seed
            kinds += how.tolist()
    # the random sets exercise every branch of the rule
    assert {k: kinds.count(k) > 0 for k in ("duplicate", "continues", "precedes")} == \
        {"duplicate": True, "continues": True, "precedes": True}


def test_counted_and_counts_leave_explained_tracks_out():
    v = ["pedestrian", "unclassified", "unclassified", "non-pedestrian", "unclassified"]
    verdicts = {"track_id": np.arange(1, 6), "verdict": np.asarray(v, dtype=object),
                "too_fast": np.asarray([False, False, True, False, False]),
                "explained_by": np.asarray([0, 1, 0, 0, 0])}
    assert counted(verdicts).tolist() == [True, False, False, False, True]
    assert walker_ids(verdicts) == [1, 5]
    c = count_walkers(v, verdicts["too_fast"], verdicts["explained_by"] != 0)
    assert (c["walkers"], c["explained"], c["too_fast"], c["unjudged_plausible"]) == (2, 1, 1, 1)
    assert c["walkers"] == c["pedestrians"] + c["unjudged_plausible"]
    assert (c["walkers_low"], c["walkers_high"]) == (1, 4)
    # a too-fast track is counted as too fast, not also as explained
    c = count_walkers(v, verdicts["too_fast"], [False, True, True, False, False])
    assert (c["too_fast"], c["explained"], c["walkers"]) == (1, 1, 2)
    assert CountOptions().explain.enabled is False
