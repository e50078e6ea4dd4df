"""SORT-style baseline tracker (Bewley, Ge, Ott, Ramos & Upcroft, "Simple Online and Realtime
Tracking", ICIP 2016), the standard the multi-pedestrian paper is measured against (issue 4).

Per track, an image-plane constant-velocity Kalman filter on the box state
x = (u, v, s, r, du, dv, ds): centre (u, v) px, area s px^2, aspect ratio r = w / h (constant),
and the per-frame rates of u, v, s. Time unit: one frame (dt = 1). Measurement z = (u, v, s, r).

    predict:  x <- F x,  P <- F P F^T + Q          (F: u += du, v += dv, s += ds)
    update:   K = P H^T (H P H^T + R)^-1,  x <- x + K (z - H x),  P <- (I - K H) P

Noise (diagonal; the magnitudes Bewley et al. use): R = diag(1, 1, 10, 10), P0 = diag(10, 10,
10, 10, 1e4, 1e4, 1e4), Q = diag(1, 1, 1, 1, 1e-2, 1e-2, 1e-4). A predicted area that would go
non-positive has its rate zeroed first.

Each frame: predict every track; IoU between predicted boxes and detections; optimal assignment
maximising the summed IoU (Hungarian: `scipy.optimize.linear_sum_assignment` when SciPy is
installed, else the exact O(n^3) shortest-augmenting-path solver `assign` below); pairs with IoU
< iou_threshold (0.3) are rejected. Unmatched detections start tracks; a track unmatched for more
than `max_age` frames is deleted; a track is reported in a frame only when it was matched there
and has `min_hits` consecutive matches (or the sequence is still within its first `min_hits`
frames), as in the paper. Detections: any per-frame boxes, here the blob boxes of
`count.CountResult.detections` or `blob_detections` (BackgroundModel + find_blobs), so the
baseline sees exactly what the paper's method sees. NumPy float64 throughout.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np

from .motscore import iou_matrix


try:  # SciPy ships with statsmodels (a test extra); the fallback below is exact too
    from scipy.optimize import linear_sum_assignment as _scipy_lsa
except ImportError:  # pragma: no cover - depends on the environment
    _scipy_lsa = None

ASSIGNMENT_SOLVER = "scipy.optimize.linear_sum_assignment" if _scipy_lsa else "rhythmjax.assign"

F_CV = np.eye(7)
F_CV[0, 4] = F_CV[1, 5] = F_CV[2, 6] = 1.0
H_BOX = np.eye(4, 7)
R_BOX = np.diag([1.0, 1.0, 10.0, 10.0])
P0_BOX = np.diag([10.0, 10.0, 10.0, 10.0, 1e4, 1e4, 1e4])
Q_BOX = np.diag([1.0, 1.0, 1.0, 1.0, 1e-2, 1e-2, 1e-4])


def box_to_z(box: np.ndarray) -> np.ndarray:
    """(left, top, w, h) px -> (u, v, s, r): centre px, area px^2, aspect w / h."""
    x, y, w, h = (float(q) for q in box)
    return np.array([x + w / 2, y + h / 2, w * h, w / h])


def z_to_box(z: np.ndarray) -> np.ndarray:
    """(u, v, s, r, ...) -> (left, top, w, h) px; w = sqrt(s r), h = s / w (0 if s <= 0)."""
    s, r = max(float(z[2]), 0.0), max(float(z[3]), 1e-9)
    w = np.sqrt(s * r)
    h = s / w if w > 0 else 0.0
    return np.array([z[0] - w / 2, z[1] - h / 2, w, h])


def kf_predict(x: np.ndarray, P: np.ndarray, F: np.ndarray = F_CV,
               Q: np.ndarray = Q_BOX) -> tuple[np.ndarray, np.ndarray]:
    """Kalman time update x = F x, P = F P F^T + Q (no clamping; see `Track.predict`)."""
    return F @ x, F @ P @ F.T + Q


def kf_update(x: np.ndarray, P: np.ndarray, z: np.ndarray, H: np.ndarray = H_BOX,
              R: np.ndarray = R_BOX) -> tuple[np.ndarray, np.ndarray]:
    """Kalman measurement update with gain K = P H^T S^-1, S = H P H^T + R; covariance in the
    (I - K H) P form, symmetrised."""
    S = H @ P @ H.T + R
    K = np.linalg.solve(S, H @ P).T  # S symmetric: (S^-1 H P)^T = P H^T S^-1
    x = x + K @ (z - H @ x)
    P = (np.eye(P.shape[0]) - K @ H) @ P
    return x, 0.5 * (P + P.T)


def assign(cost: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Exact minimum-cost assignment of a dense (n, m) cost matrix (shortest augmenting paths
    with potentials, O(n^2 m) for n <= m; transposed otherwise): rows, cols of min(n, m) pairs,
    rows increasing (the same contract as scipy's linear_sum_assignment)."""
    c = np.asarray(cost, np.float64)
    if c.ndim != 2 or not np.isfinite(c).all():
        raise ValueError("cost must be a finite 2-D matrix")
    if c.shape[0] > c.shape[1]:
        cols, rows = assign(c.T)
        order = np.argsort(rows)
        return rows[order], cols[order]
    n, m = c.shape
    u, v = np.zeros(n + 1), np.zeros(m + 1)
    p = np.zeros(m + 1, np.int64)  # p[j]: row (1-based) matched to column j; 0 = free
    way = np.zeros(m + 1, np.int64)
    for i in range(1, n + 1):
        p[0], j0 = i, 0
        minv, used = np.full(m + 1, np.inf), np.zeros(m + 1, bool)
        while p[j0] != 0:
            used[j0] = True
            i0, delta, j1 = p[j0], np.inf, -1
            for j in range(1, m + 1):
                if not used[j]:
                    cur = c[i0 - 1, j - 1] - u[i0] - v[j]
                    if cur < minv[j]:
                        minv[j], way[j] = cur, j0
                    if minv[j] < delta:
                        delta, j1 = minv[j], j
            for j in range(m + 1):
                if used[j]:
                    u[p[j]] += delta
                    v[j] -= delta
                else:
                    minv[j] -= delta
            j0 = j1
        while j0:
            j1 = way[j0]
            p[j0] = p[j1]
            j0 = j1
    cols = np.flatnonzero(p[1:]) + 1
    rows = p[cols] - 1
    order = np.argsort(rows)
    return rows[order].astype(np.int64), (cols[order] - 1).astype(np.int64)


def _lsa(cost: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    if _scipy_lsa is not None:
        r, c = _scipy_lsa(cost)
        return np.asarray(r, np.int64), np.asarray(c, np.int64)
    return assign(cost)


class Track:
    """One SORT track: Kalman state, id, hits / hit streak / frames since the last update."""

    def __init__(self, box: np.ndarray, track_id: int) -> None:
        self.x = np.zeros(7)
        self.x[:4] = box_to_z(box)
        self.P = P0_BOX.copy()
        self.id = track_id
        self.hits, self.hit_streak, self.time_since_update, self.age = 1, 1, 0, 0

    def predict(self) -> np.ndarray:
        if self.x[2] + self.x[6] <= 0:
            self.x[6] = 0.0
        self.x, self.P = kf_predict(self.x, self.P)
        self.age += 1
        if self.time_since_update > 0:
            self.hit_streak = 0
        self.time_since_update += 1
        return z_to_box(self.x)

    def update(self, box: np.ndarray) -> None:
        self.x, self.P = kf_update(self.x, self.P, box_to_z(box))
        self.time_since_update = 0
        self.hits += 1
        self.hit_streak += 1

    @property
    def box(self) -> np.ndarray:
        return z_to_box(self.x)


class SortTracker:
    """Online SORT (see the module doc). `step(boxes)` takes one frame's (n, 4) boxes (left, top,
    w, h px) and returns the reported tracks as (ids (k,), boxes (k, 4))."""

    def __init__(self, *, max_age: int = 1, min_hits: int = 3, iou_threshold: float = 0.3,
                 first_id: int = 1) -> None:
        if max_age < 0 or min_hits < 0 or not 0.0 <= iou_threshold <= 1.0:
            raise ValueError(f"need max_age >= 0, min_hits >= 0, 0 <= iou_threshold <= 1; got "
                             f"{max_age}, {min_hits}, {iou_threshold}")
        self.max_age, self.min_hits, self.iou_threshold = max_age, min_hits, iou_threshold
        self.tracks: list[Track] = []
        self.frame_count = 0
        self._next_id = first_id

    def step(self, boxes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        dets = np.asarray(boxes, np.float64).reshape(-1, 4)
        dets = dets[(dets[:, 2] > 0) & (dets[:, 3] > 0)]
        self.frame_count += 1
        pred = np.array([t.predict() for t in self.tracks]).reshape(-1, 4)
        ok = np.isfinite(pred).all(axis=1)
        self.tracks = [t for t, k in zip(self.tracks, ok) if k]
        pred = pred[ok]
        iou = iou_matrix(dets, pred)
        matched_d, matched_t = set(), set()
        if iou.size:
            rows, cols = _lsa(-iou)
            for d, t in zip(rows.tolist(), cols.tolist()):
                if iou[d, t] >= self.iou_threshold:
                    self.tracks[t].update(dets[d])
                    matched_d.add(d)
                    matched_t.add(t)
        for d in range(dets.shape[0]):
            if d not in matched_d:
                self.tracks.append(Track(dets[d], self._next_id))
                self._next_id += 1
        ids, out = [], []
        for t in self.tracks:
            if t.time_since_update == 0 and (t.hit_streak >= self.min_hits
                                             or self.frame_count <= self.min_hits):
                ids.append(t.id)
                out.append(t.box)
        self.tracks = [t for t in self.tracks if t.time_since_update <= self.max_age]
        return np.asarray(ids, np.int64), np.asarray(out, np.float64).reshape(-1, 4)


def sort_track(detections: Mapping[str, Any], *, frames: Iterable[int] | None = None,
               max_age: int = 1, min_hits: int = 3,
               iou_threshold: float = 0.3) -> dict[str, np.ndarray]:
    """Run SORT over per-frame detections (columns frame, bb_left, bb_top, bb_width, bb_height;
    extra columns ignored). ``frames``: every frame to step through, in order (default: all
    integers from the first to the last detection frame, so empty frames age the tracks).
    Returns MOT columns frame, id, bb_left, bb_top, bb_width, bb_height, conf (= 1)."""
    need = ("frame", "bb_left", "bb_top", "bb_width", "bb_height")
    missing = [c for c in need if c not in detections]
    if missing:
        raise ValueError(f"detections: missing column(s) {missing}; need {list(need)}")
    fr = np.asarray(detections["frame"]).astype(np.int64).reshape(-1)
    box = np.stack([np.asarray(detections[c], np.float64).reshape(-1) for c in need[1:]], axis=1)
    bad = np.flatnonzero(~np.isfinite(box).all(axis=1))
    if bad.size:
        raise ValueError(f"detections: row {bad[0]} (frame {fr[bad[0]]}) has a non-finite box")
    if frames is None:
        frames = range(int(fr.min()), int(fr.max()) + 1) if fr.size else range(0)
    trk = SortTracker(max_age=max_age, min_hits=min_hits, iou_threshold=iou_threshold)
    order = np.argsort(fr, kind="stable")
    fr, box = fr[order], box[order]
    cols: dict[str, list] = {k: [] for k in ("frame", "id", "box")}
    for f in frames:
        lo, hi = np.searchsorted(fr, f, "left"), np.searchsorted(fr, f, "right")
        ids, boxes = trk.step(box[lo:hi])
        cols["frame"] += [int(f)] * len(ids)
        cols["id"] += ids.tolist()
        cols["box"] += list(boxes)
    b = np.asarray(cols["box"], np.float64).reshape(-1, 4)
    return {"frame": np.asarray(cols["frame"], np.int64), "id": np.asarray(cols["id"], np.int64),
            "bb_left": b[:, 0], "bb_top": b[:, 1], "bb_width": b[:, 2], "bb_height": b[:, 3],
            "conf": np.ones(len(b))}


def blob_detections(frames: Iterable[tuple[int, float, np.ndarray | None]], *,
                    alpha: float = 0.05, threshold: float = 20.0, open_px: int = 1,
                    close_px: int = 2, min_area: int = 30) -> dict[str, np.ndarray]:
    """Per-frame blob boxes from `blobs.BackgroundModel` + `blobs.find_blobs` on frames as
    yielded by `video.VideoSource` (index, t, gray uint8 or None = skipped): columns frame (the
    given index), bb_left, bb_top, bb_width, bb_height, area. The first decodable frame only
    initialises the background (no detections)."""
    from ..vision.blobs import BackgroundModel, find_blobs

    model = None
    rows: list[tuple[int, int, int, int, int, int]] = []
    for k, _t, gray in frames:
        if gray is None:
            continue
        if model is None:
            model = BackgroundModel(gray, alpha=float(alpha), threshold=float(threshold),
                                    open_px=int(open_px), close_px=int(close_px))
            continue
        blobs, _ = find_blobs(model.apply(gray), min_area=min_area)
        rows += [(int(k), b.box[0], b.box[1], b.width, b.height, b.area) for b in blobs]
    a = np.asarray(rows, np.float64).reshape(-1, 6)
    return {"frame": a[:, 0].astype(np.int64), "bb_left": a[:, 1], "bb_top": a[:, 2],
            "bb_width": a[:, 3], "bb_height": a[:, 4], "area": a[:, 5].astype(np.int64)}


__all__ = ["ASSIGNMENT_SOLVER", "SortTracker", "Track", "assign", "blob_detections", "box_to_z",
           "kf_predict", "kf_update", "sort_track", "z_to_box"]
