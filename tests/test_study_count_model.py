"""benchmarks/study_count_model.py and count_bounds.py: the logistic fit against a float64
Newton (IRLS) loop in NumPy, the ROC AUC against hand-worked cases, the labels (the longest
track on each true walker; the distinct matching) and the distinct bound on hand-built clips."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np


BENCH = Path(__file__).resolve().parents[1] / "benchmarks"
sys.path.insert(0, str(BENCH))
import count_bounds as cb  # noqa: E402
import study_count_model as scm  # noqa: E402


def _newton(x: np.ndarray, y: np.ndarray, l2: float) -> np.ndarray:
    """Minimiser of mean log loss + l2 |w|^2 (intercept free) on standardised x by Newton."""
    mu, sd = x.mean(axis=0), x.std(axis=0)
    xs = np.c_[(x - mu) / sd, np.ones(len(x))]
    w = np.zeros(xs.shape[1])
    pen = np.r_[np.full(x.shape[1], 2 * l2), 0.0]
    for _ in range(50):
        p = 1 / (1 + np.exp(-xs @ w))
        g = xs.T @ (p - y) / len(y) + pen * w
        h = (xs * (p * (1 - p))[:, None]).T @ xs / len(y) + np.diag(pen)
        w -= np.linalg.solve(h, g)
    return w


def test_logistic_fit_matches_newton():
    rng = np.random.default_rng(3)
    x = rng.normal(size=(400, 3)) * [1.0, 2.0, 0.5] + [0.0, 1.0, -2.0]
    z = x @ [1.5, -0.7, 2.0] + 0.3
    y = (rng.uniform(size=400) < 1 / (1 + np.exp(-z))).astype(float)
    for l2 in (0.0, 0.05):
        _, _, w = scm.fit_logistic(x, y, l2)
        np.testing.assert_allclose(w, _newton(x, y, l2), rtol=1e-6, atol=1e-7)


def test_judged_verdict_keeps_the_verdicts():
    """--judged-verdict: a judged track's p is its verdict, an unjudged track's the model's."""
    k = {n: i for i, n in enumerate(scm.FEATURES)}
    x = np.zeros((4, len(scm.FEATURES)))
    x[0, k["pedestrian"]] = 1.0  # judged Pedestrian
    x[1, k["no_peak"]] = 1.0  # judged Non-pedestrian (no peak)
    x[2, k["non_pedestrian_other"]] = 1.0  # judged Non-pedestrian (another reason)
    x[:, k["log_seconds"]] = [1.0, 2.0, 0.5, -1.0]  # row 3: unjudged
    np.testing.assert_array_equal(scm.unjudged(x), [False, False, False, True])
    n = len(scm.FEATURES)
    w = np.r_[np.zeros(n), 0.7]  # p = sigmoid(0.7) for every row
    w[k["log_seconds"]] = 0.0
    model = (np.zeros(n), np.ones(n), w)
    plain = scm.predict(model, x)
    kept = scm.predict(model, x, judged_verdict=True)
    np.testing.assert_allclose(plain, 1 / (1 + np.exp(-0.7)), rtol=1e-12)
    np.testing.assert_allclose(kept, [1.0, 0.0, 0.0, 1 / (1 + np.exp(-0.7))], rtol=1e-12)


def test_auc_by_hand():
    # positives 0.35, 0.8 against negatives 0.1, 0.4: 3 of 4 pairs ordered
    assert scm.auc(np.array([0.1, 0.4, 0.35, 0.8]), np.array([0, 0, 1, 1])) == 0.75
    assert scm.auc(np.array([0.5, 0.5]), np.array([1, 0])) == 0.5  # a tie counts half
    assert np.isnan(scm.auc(np.array([0.5]), np.array([1])))


def _box(frame, tid, u):
    return frame, tid, u - 10.0, 50.0, 20.0, 60.0


def test_labels_longest_track_per_walker():
    # walker 1 followed by tracks 1 (8 frames) and 2 (4 frames); track 3 on a bicycle (id 2);
    # track 4 on nothing
    truth_rows = [_box(f, 1, 100.0) for f in range(1, 13)] + \
        [_box(f, 2, 300.0) for f in range(1, 13)]
    hyp_rows = [_box(f, 1, 100.0) for f in range(1, 9)] + \
        [_box(f, 2, 101.0) for f in range(9, 13)] + \
        [_box(f, 3, 300.0) for f in range(1, 13)] + [_box(f, 4, 450.0) for f in range(1, 6)]
    cols = ("frame", "id", "bb_left", "bb_top", "bb_width", "bb_height")
    truth = {c: np.asarray([r[k] for r in truth_rows], float) for k, c in enumerate(cols)}
    mot = {c: np.asarray([r[k] for r in hyp_rows], float) for k, c in enumerate(cols)}
    truth["id"], mot["id"] = truth["id"].astype(int), mot["id"].astype(int)
    truth["frame"], mot["frame"] = truth["frame"].astype(int), mot["frame"].astype(int)
    row = {"truth": truth, "mot": mot, "offset": 0, "kinds": {1: "pedestrian", 2: "bicycle"},
           "tracks": {"track_id": mot["id"]}}
    lab, other = scm.track_labels(row, [1, 2, 3, 4])
    np.testing.assert_array_equal(lab, [1, 0, 0, 0])
    np.testing.assert_array_equal(other, [False, False, True, False])


def test_long_runs():
    assert scm.long_runs([1] * 5 + [2] * 2 + [1] * 6 + [3] * 5) == [1, 3]  # blip of 2 dropped
    assert scm.long_runs([1, 2] * 6) == []
    assert scm.long_runs([4] * 4, min_len=4) == [4]


def test_unowned_report_switching_track(tmp_path):
    # walkers 1 and 2 side by side (boxes 20 px wide, 15 px apart); one track on walker 1 for 5
    # frames, then on walker 2 for 7: it is walker 2's, walker 1 owns no track
    truth_rows = [_box(f, 1, 100.0) for f in range(1, 13)] + \
        [_box(f, 2, 115.0) for f in range(1, 13)]
    hyp_rows = [_box(f, 1, 100.0 if f <= 5 else 115.0) for f in range(1, 13)]
    cols = ("frame", "id", "bb_left", "bb_top", "bb_width", "bb_height")
    truth = {c: np.asarray([r[k] for r in truth_rows], float) for k, c in enumerate(cols)}
    mot = {c: np.asarray([r[k] for r in hyp_rows], float) for k, c in enumerate(cols)}
    for d in (truth, mot):
        d["id"], d["frame"] = d["id"].astype(int), d["frame"].astype(int)
    row = {"clip": "c", "truth": truth, "mot": mot, "offset": 0,
           "kinds": {1: "pedestrian", 2: "pedestrian"}}
    path = tmp_path / "run.pkl"
    path.write_bytes(__import__("pickle").dumps([row]))
    out = scm.unowned_report(str(path))
    assert out[0] == "run.pkl: 1 walkers own no track"
    assert out[1].split() == ["1", "in", "a", "track's", "box", "in", ">=", "1/4", "of", "its",
                              "frames,", "the", "track", "another", "walker's"]
    assert out[2] == "  tracks on them: 1 one switch"
    # the switching track can stand for either walker: one distinct walker of two
    assert cb.distinct_walkers(row, [1]) == 1
    # a second track on walker 2 in frames 1-5: both tracks are walker 2's by majority, yet
    # they stand for two distinct walkers (track 1 for walker 1)
    extra = [_box(f, 2, 115.0) for f in range(1, 6)]
    for k, c in enumerate(cols):
        mot[c] = np.r_[mot[c], np.asarray([r[k] for r in extra], mot[c].dtype)]
    lab, _ = scm.track_labels({**row, "tracks": {"track_id": mot["id"]}}, [1, 2])
    assert lab.sum() == 1
    assert cb.distinct_walkers(row, [1, 2]) == 2
    np.testing.assert_array_equal(cb.distinct_labels(row, [1, 2]), [1, 1])
    np.testing.assert_array_equal(cb.distinct_labels(row, [2]), [1])
