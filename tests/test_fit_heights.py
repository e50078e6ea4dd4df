"""`fit.heights`: rule 26's threshold fitted from labelled heights, against hand-worked cases
and a pairwise loop for the ROC AUC."""

from __future__ import annotations

import numpy as np
import pytest

from fit.heights import balanced_accuracy, fit_height_threshold, roc_auc, track_heights
from rhythmjax.model.camera_np import project_3d
from rhythmjax.model.params import Config


def test_roc_auc_against_a_pairwise_loop_with_ties():
    rng = np.random.default_rng(0)
    score = np.round(rng.normal(size=60), 1)  # rounded: many ties
    positive = rng.random(60) < 0.4
    want = np.mean([1.0 if p > n else 0.5 if p == n else 0.0
                    for p in score[positive] for n in score[~positive]])
    assert roc_auc(score, positive) == pytest.approx(want, abs=1e-12)
    assert np.isnan(roc_auc(score, np.zeros(60, bool)))


def test_balanced_accuracy_hand_worked():
    """Walkers 0.9, 0.45; lower objects 0.4, 0.5. At 0.45: TPR 2/2, TNR 1/2 -> 0.75; at 0.46:
    TPR 1/2, TNR 1/2 -> 0.5; at 0.41: the same as 0.45; at 0.51: TPR 1/2, TNR 2/2 -> 0.75."""
    h = np.asarray([0.9, 0.45, 0.4, 0.5])
    pos = np.asarray([True, True, False, False])
    np.testing.assert_allclose(balanced_accuracy(h, pos, [0.45, 0.46, 0.41, 0.51]),
                               [0.75, 0.5, 0.75, 0.75])


def test_the_fit_takes_the_plateau_point_nearest_the_start_and_reports_held_out():
    """Training: walkers 0.62-1.0, dogs 0.3-0.4: every threshold in (0.40, 0.62] separates them
    (the plateau 0.41-0.62 on the 0.01 grid); from the start 0.5 the fit stays at 0.5, from 0.7
    it takes 0.62 (at 0.7 itself the walker at 0.62 is lost: TPR 2/3). Held out: a dog at 0.55
    is kept at 0.5 (TNR 2/3) and refused at 0.62."""
    h = np.asarray([0.62, 0.8, 1.0, 0.3, 0.35, 0.4, 0.9, 0.7, 0.2, 0.3, 0.55, 1.2])
    labels = np.asarray(["pedestrian"] * 3 + ["dog"] * 3 + ["pedestrian"] * 2 + ["dog"] * 3
                        + ["bicycle"], dtype=object)
    test = np.arange(12) >= 6
    r = fit_height_threshold(h, labels, test)
    assert r.threshold == 0.5 and r.plateau == (0.41, 0.62)
    assert r.ba["train"] == 1.0 and r.ba["test"] == pytest.approx(0.5 * (1 + 2 / 3))
    assert r.auc == {"train": 1.0, "test": 1.0}
    assert r.counts["test"] == {"walkers": 2, "lower": 3}  # the bicycle left out
    r = fit_height_threshold(h, labels, test, start=0.7)
    assert r.threshold == 0.62 and r.ba["test"] == 1.0
    assert r.ba["train_at_start"] == pytest.approx(0.5 * (2 / 3 + 1))  # 0.62 refused at 0.7
    with pytest.raises(ValueError, match="walkers and lower objects"):
        fit_height_threshold(h, np.asarray(["pedestrian"] * 12, dtype=object), test)


def test_track_heights_reads_the_projected_heights():
    """Two tracks of known height in front of the paper's camera (from 22 m: a walker's head
    inside the image), top rows by the forward projection (3): 1.7 m and 0.6 m read 1.0 and
    0.6 / 1.7 walker heights; a track of 5 rows has no height (fewer than 10 rows)."""
    cam = Config().camera
    cols = {k: [] for k in ("track_id", "u", "v", "v_top")}
    for tid, top, n in ((1, 1.7, 30), (2, 0.6, 30), (3, 1.7, 5)):
        y = np.linspace(22.0, 26.0, n)
        u, v = project_3d(cam, 0 * y, y, 0 * y)
        _, vt = project_3d(cam, 0 * y, y, top + 0 * y)
        for k, x in (("track_id", np.full(n, tid)), ("u", u), ("v", v), ("v_top", vt)):
            cols[k].append(np.asarray(x, np.float64))
    cols = {k: np.concatenate(v) for k, v in cols.items()}
    ids, h = track_heights(cam, cols, 1.7, 0.1)
    assert ids.tolist() == [1, 2, 3]
    np.testing.assert_allclose(h[:2], [1.0, 0.6 / 1.7], rtol=1e-6)
    assert np.isnan(h[2])


def test_track_heights_with_the_edge_rows_as_rule_37_reads_them():
    """A 1.7 m walker at 3-5 m, its head above the image on every row (v_top NaN, top_at_edge
    1): rule 26's height has no row; rule 37's is the median of the lower bounds, each the
    height whose top projects to row 0 (found here by bisection on the forward projection)."""
    cam = Config().camera
    y = np.linspace(3.0, 5.0, 20)
    u, v = (np.asarray(a, np.float64) for a in project_3d(cam, 0 * y, y, 0 * y))
    assert (np.asarray(project_3d(cam, 0 * y, y, 1.7 + 0 * y)[1]) < 0).all()
    cols = {"track_id": np.ones(20, int), "u": u, "v": v, "v_top": np.full(20, np.nan),
            "top_at_edge": np.ones(20)}
    assert np.isnan(track_heights(cam, cols, 1.7, 0.1)[1][0])
    bounds = []
    for yk in y:
        lo, hi = 0.0, 1.7
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if float(project_3d(cam, 0.0, yk, mid)[1]) > 0 else (lo, mid)
        bounds.append(0.5 * (lo + hi))
    h = track_heights(cam, cols, 1.7, 0.1, edge=True)[1][0]
    assert h == pytest.approx(np.median(bounds) / 1.7, rel=1e-6)
