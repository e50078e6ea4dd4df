"""evaluation.motscore against hand-computed CLEAR-MOT / IDF1 cases and an independent NumPy
brute-force implementation of the same definitions on random small sequences."""

from __future__ import annotations

import itertools
import warnings

import numpy as np
import pytest


pytest.importorskip("motmetrics")

from rhythmjax.evaluation.motscore import _quiet_motmetrics, iou_matrix, score_mot  # noqa: E402


def table(rows):
    """rows: (frame, id, left, top, w, h) -> MOT column dict."""
    a = np.asarray(rows, np.float64).reshape(-1, 6)
    return {"frame": a[:, 0].astype(np.int64), "id": a[:, 1].astype(np.int64), "bb_left": a[:, 2],
            "bb_top": a[:, 3], "bb_width": a[:, 4], "bb_height": a[:, 5]}


A, B = (0.0, 0.0, 10.0, 20.0), (50.0, 0.0, 10.0, 20.0)


def test_iou_hand_values():
    a = np.array([[0, 0, 10, 10], [0, 0, 2, 2]], float)
    b = np.array([[5, 0, 10, 10], [20, 20, 1, 1], [0, 0, 10, 10]], float)
    want = np.array([[50 / 150, 0, 1], [0, 0, 4 / 100]])
    np.testing.assert_allclose(iou_matrix(a, b), want, rtol=0, atol=1e-15)
    assert iou_matrix(np.zeros((0, 4)), b).shape == (0, 3)
    assert iou_matrix(np.array([[0, 0, 0, 0.0]]), np.array([[0, 0, 0, 0.0]]))[0, 0] == 0.0


def test_perfect_tracker():
    truth = table([(f, i, *(A if i == 1 else B)) for f in range(5) for i in (1, 2)])
    hyp = table([(f, 7 + i, *(A if i == 1 else B)) for f in range(5) for i in (1, 2)])
    s = score_mot(truth, hyp)
    assert (s.mota, s.idf1, s.precision, s.recall, s.id_switches) == (1.0, 1.0, 1.0, 1.0, 0)
    assert (s.mostly_tracked, s.mostly_lost, s.count, s.count_error) == (2, 0, 2, 0)
    assert s.motp == 0.0 and s.n_truth_boxes == 10 and s.motmetrics_version


def test_one_switch_new_id():
    # truth 1 in 6 frames; hypothesis 10 covers frames 0-2 and a new id 30 frames 3-5:
    # one ID switch, MOTA = 1 - 1/6; IDF1 = 2 * 3 / (6 + 6).
    truth = table([(f, 1, *A) for f in range(6)])
    hyp = table([(f, 10 if f < 3 else 30, *A) for f in range(6)])
    s = score_mot(truth, hyp)
    assert s.id_switches == 1
    assert s.mota == pytest.approx(1 - 1 / 6, abs=1e-12)
    assert s.idf1 == pytest.approx(0.5, abs=1e-12)
    assert (s.count, s.count_error, s.count_rel_error) == (2, 1, 1.0)


def test_swap_of_two_tracks():
    # two truths, hypotheses exchange their ids at frame 3: both truths switch (2 IDSW),
    # MOTA = 1 - 2/12; IDF1 = 2 * (3 + 3) / 24.
    rows = []
    for f in range(6):
        rows += [(f, 10 if f < 3 else 20, *A), (f, 20 if f < 3 else 10, *B)]
    truth = table([(f, i, *(A if i == 1 else B)) for f in range(6) for i in (1, 2)])
    s = score_mot(truth, table(rows))
    assert s.id_switches == 2
    assert s.mota == pytest.approx(1 - 2 / 12, abs=1e-12)
    assert s.idf1 == pytest.approx(0.5, abs=1e-12)


def test_misses_false_positives_and_threshold():
    truth = table([(f, 1, *A) for f in range(4)])
    hyp = table([(f, 5, *A) for f in (0, 1, 3)] + [(3, 6, 200, 200, 10, 20)])
    s = score_mot(truth, hyp)
    assert (s.misses, s.false_positives, s.id_switches) == (1, 1, 0)
    assert s.mota == pytest.approx(0.5, abs=1e-12)
    assert s.precision == pytest.approx(0.75) and s.recall == pytest.approx(0.75)
    # IoU exactly 0.5 pairs at the default threshold and not above it
    half = table([(0, 9, 0, 0, 10, 40)])
    t1 = table([(0, 1, *A)])
    assert score_mot(t1, half).mota == 1.0
    assert score_mot(t1, half, iou_threshold=0.51).mota == -1.0
    # frame offset: 1-based hypotheses against 0-based truth
    hyp1 = table([(f + 1, 5, *A) for f in range(4)])
    assert score_mot(truth, hyp1, frame_offset=-1).mota == 1.0
    # walking ids only
    assert score_mot(truth, hyp, walking_ids=[5]).count_error == 0
    s2 = score_mot(truth, hyp, walking_ids=[5, 6], truth_walking_ids=[1, 3, 4])
    assert (s2.count, s2.count_error, s2.count_rel_error) == (2, -1, -1 / 3)


def test_bad_input_names_the_problem():
    t = table([(0, 1, *A), (0, 1, *B)])
    with pytest.raises(ValueError, match="truth: id 1 appears twice in frame 0"):
        score_mot(t, table([(0, 1, *A)]))
    h = table([(0, 1, *A)])
    h["bb_width"] = np.array([np.nan])
    with pytest.raises(ValueError, match="hypotheses: column 'bb_width' row 0"):
        score_mot(table([(0, 1, *A)]), h)
    with pytest.raises(ValueError, match="missing column"):
        score_mot({"frame": [0]}, h)
    with pytest.raises(ValueError, match="iou_threshold"):
        score_mot(table([(0, 1, *A)]), table([(0, 1, *A)]), iou_threshold=0.0)


def test_only_motmetrics_warnings_are_silenced():
    with pytest.warns(DeprecationWarning, match="mine"), _quiet_motmetrics():
        warnings.warn("mine", DeprecationWarning, stacklevel=1)
    with pytest.warns(UserWarning, match="other"), _quiet_motmetrics():
        warnings.warn("other", UserWarning, stacklevel=1)


# ------------------------------------------------------------------------------------------
# independent reference: CLEAR MOT with exact brute-force matching, IDF1 by brute force


def _best_matching(pairs: dict[tuple[int, int], float]):
    """Max-cardinality, then min-cost matching over the valid (i, j) pairs, by enumeration."""
    best = ((0, 0.0), [])
    items = sorted(pairs)

    def rec(k, used_i, used_j, chosen, cost):
        nonlocal best
        key = (len(chosen), -cost)
        if key > best[0]:
            best = (key, list(chosen))
        for m in range(k, len(items)):
            i, j = items[m]
            if i not in used_i and j not in used_j:
                chosen.append((i, j))
                rec(m + 1, used_i | {i}, used_j | {j}, chosen, cost + pairs[(i, j)])
                chosen.pop()

    rec(0, frozenset(), frozenset(), [], 0.0)
    return best[1]


def reference_scores(truth, hyp, thr=0.5):
    frames = sorted(set(truth["frame"]) | set(hyp["frame"]))
    last: dict[int, int] = {}
    fn = fp = sw = n_obj = n_hyp = 0
    matched_frames: dict[int, int] = {}
    idtp: dict[tuple[int, int], int] = {}
    for f in frames:
        ko, kh = np.flatnonzero(truth["frame"] == f), np.flatnonzero(hyp["frame"] == f)
        oid, hid = truth["id"][ko], hyp["id"][kh]
        ob = np.stack([truth[c][ko] for c in ("bb_left", "bb_top", "bb_width", "bb_height")], 1)
        hb = np.stack([hyp[c][kh] for c in ("bb_left", "bb_top", "bb_width", "bb_height")], 1)
        iou = np.zeros((len(ko), len(kh)))
        for i in range(len(ko)):  # plain loop IoU, independent of iou_matrix
            for j in range(len(kh)):
                x0, y0 = max(ob[i, 0], hb[j, 0]), max(ob[i, 1], hb[j, 1])
                x1 = min(ob[i, 0] + ob[i, 2], hb[j, 0] + hb[j, 2])
                y1 = min(ob[i, 1] + ob[i, 3], hb[j, 1] + hb[j, 3])
                inter = max(0.0, x1 - x0) * max(0.0, y1 - y0)
                iou[i, j] = inter / (ob[i, 2] * ob[i, 3] + hb[j, 2] * hb[j, 3] - inter)
        valid = iou >= thr
        for i, j in zip(*np.nonzero(valid)):
            idtp[(oid[i], hid[j])] = idtp.get((oid[i], hid[j]), 0) + 1
        n_obj, n_hyp = n_obj + len(ko), n_hyp + len(kh)
        done_i, done_j = set(), set()
        for i in range(len(ko)):  # 1. keep last correspondences that are still valid
            js = [j for j in range(len(kh)) if last.get(oid[i]) == hid[j] and valid[i, j]]
            if js:
                done_i.add(i)
                done_j.add(js[0])
        pairs = {(i, j): 1.0 - iou[i, j] for i, j in zip(*np.nonzero(valid))
                 if i not in done_i and j not in done_j}
        for i, j in _best_matching(pairs):  # 2. optimal matching of the rest
            if oid[i] in last and last[oid[i]] != hid[j]:
                sw += 1
            last[oid[i]] = hid[j]
            done_i.add(i)
            done_j.add(j)
        for i in done_i:
            matched_frames[oid[i]] = matched_frames.get(oid[i], 0) + 1
        fn += len(ko) - len(done_i)
        fp += len(kh) - len(done_j)
    o_ids, h_ids = sorted(set(truth["id"])), sorted(set(hyp["id"]))
    best_tp = 0
    for perm in itertools.permutations(range(max(len(o_ids), len(h_ids)))):
        tp = sum(idtp.get((o_ids[a], h_ids[b]), 0) for a, b in enumerate(perm)
                 if a < len(o_ids) and b < len(h_ids))
        best_tp = max(best_tp, tp)
    life = {o: int(np.sum(truth["id"] == o)) for o in o_ids}
    ratio = {o: matched_frames.get(o, 0) / life[o] for o in o_ids}
    return {"fn": fn, "fp": fp, "sw": sw, "mota": 1 - (fn + fp + sw) / n_obj,
            "idf1": 2 * best_tp / (n_obj + n_hyp),
            "mt": sum(r >= 0.8 for r in ratio.values()), "ml": sum(r < 0.2 for r in ratio.values())}


def random_case(rng):
    """A few ids moving on a line with jitter; hypotheses = truths with noise, drops, swaps."""
    n_o, n_h, n_f = int(rng.integers(1, 4)), int(rng.integers(1, 4)), int(rng.integers(3, 8))
    t_rows, h_rows = [], []
    for f in range(n_f):
        for o in range(n_o):
            if rng.random() < 0.85:
                t_rows.append((f, o + 1, 12.0 * o + f + rng.uniform(0, 3), rng.uniform(0, 3),
                               10 + rng.uniform(0, 2), 20 + rng.uniform(0, 2)))
        ids = rng.permutation(n_h) if rng.random() < 0.4 else np.arange(n_h)
        for k in range(n_h):
            if rng.random() < 0.8:
                h_rows.append((f, 100 + int(ids[k]), 12.0 * k + f + rng.uniform(-2.5, 2.5),
                               rng.uniform(-2, 2), 10 + rng.uniform(-2, 2),
                               20 + rng.uniform(-2, 2)))
    return table(t_rows), table(h_rows)


def test_agrees_with_bruteforce_reference():
    rng = np.random.default_rng(20240)
    checked = 0
    for _ in range(60):
        truth, hyp = random_case(rng)
        if truth["frame"].size == 0 or hyp["frame"].size == 0:
            continue
        ref = reference_scores(truth, hyp)
        s = score_mot(truth, hyp)
        got = (s.misses, s.false_positives, s.id_switches, s.mostly_tracked, s.mostly_lost)
        assert got == (ref["fn"], ref["fp"], ref["sw"], ref["mt"], ref["ml"])
        assert s.mota == pytest.approx(ref["mota"], abs=1e-12)
        assert s.idf1 == pytest.approx(ref["idf1"], abs=1e-12)
        checked += 1
    assert checked >= 50
