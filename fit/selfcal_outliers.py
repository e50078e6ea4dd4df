"""Foot points self-calibration (`fit.selfcal`) leaves out: each track's outliers in the image.

The tracks file holds a foot point on some rows the tracker's gates did not accept (the `predict`
rows keep the gated-out detection, so that `rhythmjax classify` can gate again); its optional
`state` column says which (`fit.selfcal_rows` can leave them all out, `--observed-only`), a
hand-made or converted file may not. One such foot point far from its walker (on the dev clips, the
sliver of a head 27 px above the horizon, 98 px above the walker's feet) pins the fit's horizon
hinge and enters every cue. The rule here needs no camera: per track, each image coordinate u(t) and
v(t) (px) is fitted by a polynomial of degree `DEGREE` in time by iteratively reweighted least
squares with Tukey's biweight (c = 4.685 spreads, `IRLS_STEPS` steps from the least-squares fit);
the spread is 1.4826 x the MAD of the residuals, at least `SIGMA_FLOOR_PX`. A row whose residual in
u or in v exceeds `K_SIGMA` spreads is dropped (its foot point, width and top row are made missing;
its intensity, the rhythm signal, is kept). A walker's path on the ground is a line walked at a
constant pace, which the camera maps to a smooth curve in the image; a quadratic in time follows it
over the few seconds of a track, and the biweight gives no weight to a far outlier. Tracks with
fewer than `MIN_POINTS` measured rows are left as they are.

The constants were set a priori (a 5-spread cut, the usual biweight constant, a 1 px floor: the
tracker's foot points are whole or half pixels) and checked on the development seeds 0-5 (a
fraction of rows dropped is reported by `dropped_rows`; docs/selfcal.md gives it).
"""

from __future__ import annotations

import dataclasses

import numpy as np


DEGREE = 2  # polynomial degree in time of u(t) and v(t)
K_SIGMA = 5.0  # a row beyond this many robust spreads in u or v is dropped
SIGMA_FLOOR_PX = 1.0  # px, the spread is never below this
TUKEY_C = 4.685  # the biweight's constant, in spreads
IRLS_STEPS = 10  # reweighting steps from the least-squares fit
MIN_POINTS = 8  # fewer measured rows in a track (or a window): nothing dropped
WINDOW_S = 4.0  # s, longer tracks are fitted in windows of this length (module doc)


def _robust_spread(r: np.ndarray) -> float:
    """1.4826 x the median absolute residual (px), at least `SIGMA_FLOOR_PX`."""
    return max(1.4826 * float(np.median(np.abs(r))), SIGMA_FLOOR_PX)


def _biweight_fit(A: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, float]:
    """(residuals px, robust spread px) of Tukey's biweight fit of `y` (n,) on the columns of
    `A` (n, p), by `IRLS_STEPS` reweighting steps from least squares."""
    w = np.ones(len(y))
    for _ in range(IRLS_STEPS + 1):
        sw = np.sqrt(w)
        coef = np.linalg.lstsq(A * sw[:, None], y * sw, rcond=None)[0]
        r = y - A @ coef
        s = _robust_spread(r[w > 0])
        w_next = np.clip(1.0 - (r / (TUKEY_C * s)) ** 2, 0.0, None) ** 2
        if np.count_nonzero(w_next) <= A.shape[1]:  # too few points left: stop here
            break
        w = w_next
    return r, s


def track_outliers(t: np.ndarray, y: np.ndarray, *, degree: int = DEGREE,
                   k_sigma: float = K_SIGMA, window_s: float = WINDOW_S) -> np.ndarray:
    """Outlier mask (n,) of one track's measured values `y` (n, d) px at times `t` (n,) s,
    sorted by time: True where a column's residual from its biweight polynomial fit exceeds
    `k_sigma` robust spreads (module doc). A track longer than `window_s` is fitted in windows
    of that length, one every half window (the last ending at the track's end), and each row is
    judged by the window whose centre is nearest to it. Nothing is dropped with fewer than
    `MIN_POINTS` rows (in the track or in a window)."""
    t = np.asarray(t, np.float64)
    y = np.asarray(y, np.float64).reshape(len(t), -1)
    out = np.zeros(len(t), bool)
    if len(t) < max(MIN_POINTS, degree + 2):
        return out
    t0, t1 = float(t.min()), float(t.max())
    if t1 - t0 <= window_s:
        starts = np.array([t0])
        width = max(t1 - t0, 1e-9)
    else:
        starts = np.r_[np.arange(t0, t1 - window_s, 0.5 * window_s), t1 - window_s]
        width = window_s
    nearest = np.argmin(np.abs(t[:, None] - (starts + 0.5 * width)[None, :]), 1)
    for k, s0 in enumerate(starts):
        inside = (t >= s0 - 1e-9) & (t <= s0 + width + 1e-9)
        judged = nearest == k
        if np.count_nonzero(inside) < max(MIN_POINTS, degree + 2) or not judged.any():
            continue
        A = np.vander((t[inside] - s0) / width * 2.0 - 1.0, degree + 1)
        for j in range(y.shape[1]):
            r, s = _biweight_fit(A, y[inside, j])
            bad = np.zeros(len(t), bool)
            bad[np.flatnonzero(inside)] = np.abs(r) > k_sigma * s
            out |= bad & judged
    return out


def outlier_rows(batch, *, degree: int = DEGREE, k_sigma: float = K_SIGMA) -> np.ndarray:
    """(B, T) mask of the measured foot points of a `rhythmjax.io.TrackBatch` that the rule
    (module doc) drops."""
    z = np.asarray(batch.z, np.float64)
    ok = np.asarray(batch.present) & np.all(np.isfinite(z), -1)
    t = np.asarray(batch.t, np.float64)
    out = np.zeros(ok.shape, bool)
    for b in range(ok.shape[0]):
        idx = np.flatnonzero(ok[b])
        out[b, idx] = track_outliers(t[b, idx], z[b, idx], degree=degree, k_sigma=k_sigma)
    return out


def without_outliers(batch, *, degree: int = DEGREE, k_sigma: float = K_SIGMA):
    """(the batch with the dropped rows' foot point, width and head (v_top, u_top) made missing,
    the (B, T) mask of dropped rows). The intensity is kept: the gait peak does not use the
    foot point."""
    drop = outlier_rows(batch, degree=degree, k_sigma=k_sigma)
    if not drop.any():
        return batch, drop
    z = np.where(drop[..., None], np.nan, batch.z).astype(np.asarray(batch.z).dtype)
    width = np.where(drop, np.nan, batch.width).astype(np.asarray(batch.width).dtype)
    nan = lambda a: None if a is None else np.where(drop, np.nan, a).astype(  # noqa: E731
        np.asarray(a).dtype)
    return dataclasses.replace(batch, z=z, width=width, v_top=nan(batch.v_top),
                               u_top=nan(getattr(batch, "u_top", None))), drop


def dropped_rows(batch, used=None) -> tuple[int, int]:
    """(rows dropped, measured rows) of the rule over the batch's tracks (or the `used` mask)."""
    z = np.asarray(batch.z, np.float64)
    ok = np.asarray(batch.present) & np.all(np.isfinite(z), -1)
    drop = outlier_rows(batch)
    if used is not None:
        ok, drop = ok[used], drop[used]
    return int(drop.sum()), int(ok.sum())
