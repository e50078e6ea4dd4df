"""Walking model, width model and thresholds of the rhythm classifier from labelled tracks.

Label handling: a track labelled ``pedestrian`` is a positive; every other label (bicycle, dog,
car, other) is the negative class; unlabelled tracks ("") are left out.

1. Features, once: the batched EKF with the paper's gates (10)-(11) and the rhythm windows of
   `rhythmjax.model.rhythm`, keeping every window's spectral peaks and ground speed (`features`).
   Which window decides a track depends on the thresholds (matching stops at the first window
   that says Pedestrian), so all windows are kept; at the config's thresholds `decide`
   reproduces `rhythm.classify_batch` exactly (tested).
2. Walking model (14): pace F (Hz) and stride T (m) of the best peak passing (13) and a wide
   (`K_EST` sigma) walking gate, over the training walkers with a usable spectrum; re-centred on
   the estimate until it stops moving. Mean and standard deviation (ddof 1) with standard
   errors s/sqrt(n) and s/sqrt(2(n-1)).
3. Width model (10): ground width (m) of every measurement of the training walkers, by the
   inverse perspective at the foot point; standard error of the mean clustered by track.
4. Thresholds: P_thr (13), R_thr (15) and k_sigma3 (14) maximise the balanced accuracy
   0.5 (TPR + TNR) over the training tracks, a whole grid in one vmapped call of (13)-(15) on the
   stored peaks (no EKF re-run). k_sigma1 and k_sigma2 are gates inside the EKF (10)-(11): they
   change the features themselves and are kept. Ties go to the grid point nearest the start.
   Tracks left unclassified (too short, bad signal) do not depend on these thresholds and are
   not scored. Balanced accuracy is reported on the training and on a held-out split.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from rhythmjax.model import mem
from rhythmjax.model.batch import padded_chunks
from rhythmjax.model.camera import ground_width
from rhythmjax.model.params import Config, Thresholds, WalkingModel, WidthModel
from rhythmjax.model.rhythm import RhythmResult, match, track_windows
from rhythmjax.model.status import Reason, Verdict


POSITIVE = "pedestrian"
K_EST = 4.0  # walking gate (sigma) used to pick each walker's peak for the estimate
MIN_WALKERS = 10  # training walkers with a usable spectrum needed for the Gaussians
GRID = {"p_thr": np.geomspace(1.0, 100.0, 13), "r_thr": np.linspace(0.0, 0.6, 13),
        "k_sigma3": np.arange(1.0, 5.01, 0.5)}


class Features(eqx.Module):
    """Per track (B) and rhythm window (J): peaks (K slots), ground speed (m/s), and whether the
    window was classifiable (complete, good signal)."""

    peak_freq: jax.Array  # (B, J, K) Hz
    peak_power: jax.Array  # (B, J, K) x white level
    peak_mask: jax.Array  # (B, J, K)
    speed: jax.Array  # (B, J) m/s, NaN where the window is not usable
    usable: jax.Array  # (B, J) bool
    reason0: jax.Array  # (B,) Reason of the first window when it is not classifiable


def _windows(cfg: Config, z, width, intensity, dt, present) -> tuple[RhythmResult, jax.Array]:
    """`rhythm.classify_track` up to its per-window results (axis J), unpicked, and the reason
    of the first window (too-short / no-measurements when it is incomplete)."""
    every, _, first_reason, _ = track_windows(cfg, z, width, intensity, dt, present)
    return every, first_reason


@eqx.filter_jit
def _features_chunk(cfg: Config, z, width, intensity, dt, present) -> Features:
    w, reason0 = jax.vmap(_windows, in_axes=(None, 0, 0, 0, 0, 0))(cfg, z, width, intensity, dt,
                                                                   present)
    usable = w.verdict != Verdict.UNCLASSIFIED
    return Features(w.peak_freq, w.peak_power, w.peak_mask, w.speed_mps, usable, reason0)


def features(cfg: Config, batch, *, chunk: int = 256) -> Features:
    """`Features` of every track of a `rhythmjax.io.TrackBatch` (padded to >= N frames), in
    fixed-shape chunks so one compilation serves them all."""
    if batch.z.shape[1] < cfg.thresholds.n:
        raise ValueError(f"tracks must be padded to at least N = {cfg.thresholds.n} frames")
    parts = []
    for s, e, arrays in padded_chunks(cfg, batch, chunk):
        parts.append(jax.tree.map(lambda x, e=e, s=s: np.asarray(x)[: e - s],
                                  _features_chunk(cfg, *arrays)))
    return jax.tree.map(lambda *xs: jnp.asarray(np.concatenate(xs)), *parts)


def decide(walking: WalkingModel, thr: Thresholds, f: Features):
    """(13)-(15) on every window, then the window pick of `rhythm.classify_track`: the first
    window that says Pedestrian, else the first. Returns per-track verdict, reason, pace F (Hz),
    stride T (m), ratio R of the picked window (jit/vmap-able; cheap)."""
    one = lambda fr, pw, mk, sp: match(mem.Peaks(fr, pw, mk), sp, walking, thr)
    v, r, pace, stride, ratio = jax.vmap(jax.vmap(one))(f.peak_freq, f.peak_power, f.peak_mask,
                                                       f.speed)
    matched = f.usable & (v == Verdict.PEDESTRIAN)
    anym = jnp.any(matched, axis=1)
    pick = jnp.where(anym, jnp.argmax(matched, axis=1), 0)
    take = lambda a: jnp.take_along_axis(a, pick[:, None], axis=1)[:, 0]
    ok = f.usable[:, 0] | anym
    nan = jnp.asarray(jnp.nan, pace.dtype)
    verdict = jnp.where(anym, Verdict.PEDESTRIAN,
                        jnp.where(ok, Verdict.NON_PEDESTRIAN, Verdict.UNCLASSIFIED))
    reason = jnp.where(ok, take(r), f.reason0)
    return (verdict.astype(jnp.int32), reason.astype(jnp.int32), jnp.where(ok, take(pace), nan),
            jnp.where(ok, take(stride), nan), jnp.where(ok, take(ratio), nan))


def with_thresholds(thr: Thresholds, p_thr, r_thr, k_sigma3) -> Thresholds:
    """`thr` with (13)-(15)'s thresholds replaced (values may be tracers)."""
    return eqx.tree_at(lambda t: (t.p_thr, t.r_thr, t.k_sigma3), thr,
                       tuple(jnp.asarray(x, thr.p_thr.dtype) for x in (p_thr, r_thr, k_sigma3)))


@eqx.filter_jit
def grid_verdicts(walking: WalkingModel, thr: Thresholds, f: Features, p_thr, r_thr, k_sigma3):
    """Verdicts (G, B) for G threshold triples (arrays of shape (G,)), one vmapped call."""
    run = lambda p, r, k: decide(walking, with_thresholds(thr, p, r, k), f)[0]
    return jax.vmap(run)(p_thr, r_thr, k_sigma3)


def balanced_accuracy(verdict: np.ndarray, positive: np.ndarray, use: np.ndarray):
    """0.5 (TPR + TNR) over the tracks `use` that were judged; verdict (..., B) codes. NaN where
    a class has no judged track. Returns (ba, tpr, tnr)."""
    judged = use & (verdict != Verdict.UNCLASSIFIED)
    said = verdict == Verdict.PEDESTRIAN
    npos, nneg = np.sum(judged & positive, -1), np.sum(judged & ~positive, -1)
    with np.errstate(invalid="ignore", divide="ignore"):
        tpr = np.sum(judged & positive & said, -1) / npos
        tnr = np.sum(judged & ~positive & ~said, -1) / nneg
    return 0.5 * (tpr + tnr), tpr, tnr


def gaussian(x: np.ndarray) -> dict[str, float]:
    """Mean and standard deviation (ddof 1) with their standard errors (normal theory)."""
    x = np.asarray(x, np.float64)
    n = x.size
    s = float(np.std(x, ddof=1))
    return {"mean": float(np.mean(x)), "std": s, "se_mean": s / math.sqrt(n),
            "se_std": s / math.sqrt(2 * (n - 1)), "n": n}


def width_gaussian(width_m: np.ndarray) -> dict[str, float]:
    """Pooled mean and std (ddof 1) of ground widths (B, T) (NaN = none); the SE of the mean is
    clustered by track (rows), the SE of the std uses the number of tracks."""
    ok = np.isfinite(width_m)
    rows = np.any(ok, axis=1)
    w, ok = width_m[rows], ok[rows]
    vals = w[ok]
    m, s, nt = float(np.mean(vals)), float(np.std(vals, ddof=1)), int(rows.sum())
    resid = np.where(ok, w - m, 0.0).sum(axis=1)
    se_m = float(np.sqrt(np.sum(resid**2)) / vals.size)
    return {"mean": m, "std": s, "se_mean": se_m, "se_std": s / math.sqrt(2 * max(nt - 1, 1)),
            "n": nt}


def ground_widths(cfg: Config, batch) -> np.ndarray:
    """Ground width (m) of every measurement (B, T) by the inverse perspective of (10); NaN
    where no measurement or no ground point."""
    z = jnp.asarray(batch.z)
    wid, ok = ground_width(cfg.camera, jnp.asarray(batch.width), z[..., 0], z[..., 1])
    wid = np.asarray(wid, np.float64)
    good = np.asarray(ok) & batch.present & np.isfinite(wid) & (wid > 0)
    return np.where(good, wid, np.nan)


def split(labels: np.ndarray, test_fraction: float, seed: int) -> np.ndarray:
    """Boolean test mask, stratified by class: a random `test_fraction` of each class's tracks
    (at least one), drawn with `seed`."""
    rng = np.random.default_rng(seed)
    test = np.zeros(labels.size, bool)
    for cls in (labels == POSITIVE, (labels != POSITIVE) & (labels != "")):
        idx = np.flatnonzero(cls)
        k = min(max(1, round(test_fraction * idx.size)), idx.size - 1) if idx.size > 1 else 0
        test[rng.permutation(idx)[:k]] = True
    return test


@dataclass
class WalkingFit:
    """Result of `fit_walking`: the new config, estimates with standard errors (`estimates`:
    name -> mean/std/se_mean/se_std/n, units Hz, m, m), balanced accuracies, the chosen
    thresholds, the grid (axes and balanced accuracy (P, R, K)) and per-track features."""

    config: Config
    estimates: dict[str, dict[str, float]]
    thresholds: dict[str, float]
    start_thresholds: dict[str, float]
    ba: dict[str, float]  # train, test, test_start (config's model and thresholds), tpr/tnr
    counts: dict[str, int]
    grid: dict[str, np.ndarray]
    tracks: dict[str, np.ndarray]  # id, label, test, verdict, pace_hz, stride_m, ratio, ...
    iterations: int
    success: bool
    reasons: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)  # warnings that do not fail the fit

    @property
    def ill_determined(self) -> bool:
        return bool(self.reasons)

    @property
    def result(self) -> str:
        return "successful" if self.success else "walking model did not settle"

    def summary(self) -> str:
        e = self.estimates
        lines = [f"{'pace':6s} F ~ N({e['pace']['mean']:.4f} +- {e['pace']['se_mean']:.4f}, "
                 f"{e['pace']['std']:.4f} +- {e['pace']['se_std']:.4f}) Hz  "
                 f"[{e['pace']['n']} walkers]",
                 f"{'stride':6s} T ~ N({e['stride']['mean']:.4f} +- {e['stride']['se_mean']:.4f}, "
                 f"{e['stride']['std']:.4f} +- {e['stride']['se_std']:.4f}) m",
                 f"{'width':6s} w ~ N({e['width']['mean']:.4f} +- {e['width']['se_mean']:.4f}, "
                 f"{e['width']['std']:.4f} +- {e['width']['se_std']:.4f}) m  "
                 f"[{e['width']['n']} walkers]"]
        t, t0 = self.thresholds, self.start_thresholds
        lines.append("thresholds: " + ", ".join(f"{k} {t[k]:.4g} (was {t0[k]:.4g})" for k in t))
        b, c = self.ba, self.counts
        lines.append(f"balanced accuracy: train {b['train']:.3f} ({c['train']} tracks), held-out "
                     f"{b['test']:.3f} ({c['test']} tracks; TPR {b['test_tpr']:.3f}, TNR "
                     f"{b['test_tnr']:.3f}); held-out with the start config {b['test_start']:.3f}")
        lines.append(f"positive class 'pedestrian' ({c['positives']} tracks), negative: every "
                     f"other label ({c['negatives']}); unscored: {c['unclassified']} unclassified, "
                     f"{c['unlabelled']} unlabelled")
        lines.append(f"solver: {self.result} after {self.iterations} iterations")
        lines += [f"note: {n}" for n in self.notes]
        if self.reasons:
            lines.append("ILL-DETERMINED: " + "; ".join(self.reasons))
        return "\n".join(lines)

    def to_dict(self) -> dict:
        return {"estimates": self.estimates, "units": {"pace": "Hz", "stride": "m", "width": "m"},
                "thresholds": self.thresholds, "start_thresholds": self.start_thresholds,
                "balanced_accuracy": self.ba, "counts": self.counts, "result": self.result,
                "success": self.success, "num_steps": self.iterations,
                "ill_determined": self.ill_determined, "reasons": self.reasons,
                "notes": self.notes}


def _thr_dict(thr: Thresholds) -> dict[str, float]:
    return {k: float(getattr(thr, k)) for k in ("p_thr", "r_thr", "k_sigma3")}


def fit_walking(cfg: Config, batch, *, test_fraction: float = 0.3, seed: int = 0,
                grid: dict[str, np.ndarray] | None = None, max_iter: int = 20,
                feats: Features | None = None) -> WalkingFit:
    """Fit the walking and width models and (P_thr, R_thr, k_sigma3) from a labelled
    `TrackBatch` (labels required), on a stratified training split; see the module docstring.
    `feats` may pass precomputed `features(cfg, batch)`. Raises ValueError on unusable input."""
    if batch.labels is None:
        raise ValueError("no 'label' column: the walking fit needs labelled tracks")
    if not 0.0 < test_fraction < 1.0:
        raise ValueError(f"test fraction {test_fraction} must be in (0, 1): a held-out split is "
                         "always reported")
    labels = np.asarray(batch.labels, dtype=object)
    positive, labelled = labels == POSITIVE, labels != ""
    classes = sorted(set(labels[labelled]))
    if np.all(positive[labelled]) or not np.any(positive):
        raise ValueError(f"labelled tracks have one class only ({', '.join(classes) or 'none'}):"
                         " need 'pedestrian' and at least one other label")
    f = features(cfg, batch) if feats is None else feats
    thr0, walking0 = cfg.thresholds, cfg.walking
    test = split(labels, test_fraction, seed)
    train = labelled & ~test
    v0 = np.asarray(decide(walking0, thr0, f)[0])
    judged = v0 != Verdict.UNCLASSIFIED
    for name, m in (("training", train), ("held-out", labelled & test)):
        for cname, c in (("pedestrian", positive), ("other", ~positive)):
            if not np.any(m & c & judged):
                raise ValueError(f"too few usable tracks: no classifiable {cname} track in the "
                                 f"{name} split ({int(np.sum(labelled & judged))} classifiable "
                                 "labelled tracks in all)")
    # walking model: re-centre the wide gate on the estimate until it settles
    est_thr = with_thresholds(thr0, thr0.p_thr, 0.0, K_EST)
    walking, iterations, settled = walking0, 0, False
    while iterations < max_iter and not settled:
        iterations += 1
        _, reason, pace, stride, _ = (np.asarray(a) for a in decide(walking, est_thr, f))
        use = train & positive & np.isin(reason, (Reason.MATCHED, Reason.BELOW_THRESHOLD))
        if use.sum() < MIN_WALKERS:
            raise ValueError(f"too few usable tracks: {int(use.sum())} training walkers with a "
                             f"spectral peak matching walking (need {MIN_WALKERS})")
        gp, gs = gaussian(pace[use]), gaussian(stride[use])
        new = WalkingModel(gp["mean"], gp["std"], gs["mean"], gs["std"])
        old = np.array([float(x) for x in jax.tree.leaves(walking)])
        nxt = np.array([float(x) for x in jax.tree.leaves(new)])
        walking = new
        settled = bool(np.all(np.abs(nxt - old) <= 1e-4 * np.abs(old)))
    gw = width_gaussian(ground_widths(cfg, batch)[train & positive])
    # thresholds: the whole grid in one vmapped call
    axes = {k: np.asarray(v, np.float64) for k, v in (grid or GRID).items()}
    mesh = np.meshgrid(axes["p_thr"], axes["r_thr"], axes["k_sigma3"], indexing="ij")
    G = [jnp.asarray(m.ravel(), thr0.p_thr.dtype) for m in mesh]
    verdicts = np.asarray(grid_verdicts(walking, thr0, f, *G))
    shape = mesh[0].shape
    ba_tr = balanced_accuracy(verdicts, positive, train)[0].reshape(shape)
    ba_te = balanced_accuracy(verdicts, positive, labelled & test)[0].reshape(shape)
    best = np.nanmax(ba_tr)
    ties = np.argwhere(ba_tr >= best - 1e-12)
    start = [np.argmin(np.abs(np.log(axes["p_thr"]) - math.log(max(float(thr0.p_thr), 1e-9)))),
             np.argmin(np.abs(axes["r_thr"] - float(thr0.r_thr))),
             np.argmin(np.abs(axes["k_sigma3"] - float(thr0.k_sigma3)))]
    i, j, k = ties[np.argmin(np.sum((ties - np.asarray(start)) ** 2, axis=1))]
    chosen = {"p_thr": float(axes["p_thr"][i]), "r_thr": float(axes["r_thr"][j]),
              "k_sigma3": float(axes["k_sigma3"][k])}
    thr = dataclasses.replace(thr0, **chosen)
    vt, rt, pt, st, qt = (np.asarray(a) for a in decide(walking, thr, f))
    b_tr = balanced_accuracy(vt, positive, train)
    b_te = balanced_accuracy(vt, positive, labelled & test)
    b_0 = balanced_accuracy(v0, positive, labelled & test)
    speed = np.asarray(f.speed)[:, 0]
    new_cfg = dataclasses.replace(cfg, walking=walking, thresholds=thr,
                                  width=WidthModel(gw["mean"], gw["std"],
                                                  cfg.width.height))
    notes = _edge_notes(axes, ba_tr, (i, j, k))
    reasons = [] if settled else [f"walking model still moving after {max_iter} iterations"]
    for name, g in (("pace", gp), ("stride", gs), ("width", gw)):
        if not (math.isfinite(g["std"]) and g["std"] > 0):
            reasons.append(f"{name} spread is zero or undefined")
    return WalkingFit(
        config=new_cfg, estimates={"pace": gp, "stride": gs, "width": gw}, thresholds=chosen,
        start_thresholds=_thr_dict(thr0),
        ba={"train": float(b_tr[0]), "test": float(b_te[0]), "test_tpr": float(b_te[1]),
            "test_tnr": float(b_te[2]), "train_tpr": float(b_tr[1]), "train_tnr": float(b_tr[2]),
            "test_start": float(b_0[0])},
        counts={"tracks": len(labels), "train": int(np.sum(train & (vt != 0))),
                "test": int(np.sum(labelled & test & (vt != 0))),
                "positives": int(np.sum(positive & (vt != 0))),
                "negatives": int(np.sum(labelled & ~positive & (vt != 0))),
                "unclassified": int(np.sum(labelled & (vt == 0))),
                "unlabelled": int(np.sum(~labelled))},
        grid={**axes, "ba_train": ba_tr, "ba_test": ba_te},
        tracks={"track_id": np.asarray(batch.ids, dtype=object), "label": labels, "test": test,
                "verdict": vt, "reason": rt, "pace_hz": pt, "stride_m": st, "ratio": qt,
                "speed_mps": speed, "used_for_walking": use},
        iterations=iterations, success=settled, reasons=reasons, notes=notes)


def _edge_notes(axes: dict, ba: np.ndarray, idx: tuple) -> list[str]:
    """A note for each chosen threshold on the first or last point of its grid axis where the
    balanced accuracy there beats the next point inwards: the optimum may lie beyond the grid."""
    notes = []
    for ax, (name, values) in enumerate(axes.items()):
        pos = int(idx[ax])
        if values.size < 2 or pos not in (0, values.size - 1):
            continue
        inner = list(idx)
        inner[ax] = 1 if pos == 0 else values.size - 2
        if ba[tuple(idx)] > ba[tuple(inner)]:
            side = "lower" if pos == 0 else "upper"
            notes.append(f"{name} {values[pos]:.4g} is at the {side} edge of its grid: the "
                         "optimum may lie beyond it")
    return notes


def make_labelled(**kw):
    """`rhythmjax.sim.tracks.make_tracks(**kw)` with its projections jitted: it calls them op by
    op per track, which dominates its run time; the numbers agree to float rounding."""
    import rhythmjax.sim.tracks as st

    saved = st.project, st.image_width
    st.project, st.image_width = jax.jit(saved[0]), jax.jit(saved[1])
    try:
        return st.make_tracks(**kw)
    finally:
        st.project, st.image_width = saved


def batch_of(cols: dict, cfg: Config, *, max_gap_frames: int = 5):
    """A `TrackBatch` of tracks columns (as `make_tracks` gives), through a temporary file so
    that the validation of `rhythmjax.io.read_tracks` applies."""
    import tempfile
    from pathlib import Path

    from rhythmjax.io import read_tracks, to_batch, write_table

    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / "tracks.parquet"
        write_table(p, cols, [k for k in cols if k in ("track_id", "frame", "t", "u", "v",
                                                        "width_px", "intensity", "label")])
        tr = read_tracks(p, fps=cfg.camera.fps)
    return to_batch(tr, max_gap_frames=max_gap_frames, min_len=cfg.thresholds.n,
                    fps=cfg.camera.fps)


def study(n_walkers: int = 2000, seed: int = 0) -> None:  # pragma: no cover - a script
    """``python -c "from fit.walking import study; study(2000)"``: acceptance of issue 5,
    recovery of the generating N(2.05, 0.183) Hz, N(0.72, 0.09) m (clipped to [1.6, 2.6] Hz,
    [0.5, 0.95] m by the generator) and the held-out balanced accuracy. Walkers and 10 % as
    many each of bicycles, dogs and cars, generated in blocks of 200 walkers."""
    import time

    cfg = Config()
    blocks, s = [], seed
    while len(blocks) < max(1, n_walkers // 200):
        s += 1
        try:  # the generator occasionally cannot place a path: take the next seed
            cols, _ = make_labelled(n_walkers=200, n_bicycles=20, n_dogs=20, n_cars=20, seed=s)
        except RuntimeError:
            continue
        cols["track_id"] = np.asarray([f"b{s}-{t}" for t in cols["track_id"]])
        cols["frame"] = cols["frame"] + 10**6 * s
        blocks.append(cols)
    b = batch_of({k: np.concatenate([c[k] for c in blocks]) for k in blocks[0]}, cfg)
    t0 = time.perf_counter()
    f = features(cfg, b)
    t1 = time.perf_counter()
    fit_walking(cfg, b, feats=f, seed=seed)
    t2 = time.perf_counter()
    r = fit_walking(cfg, b, feats=f, seed=seed)
    t3 = time.perf_counter()
    print(r.summary())
    rng = np.random.default_rng(1)
    clip = {"pace": np.clip(rng.normal(2.05, 0.183, 10**6), 1.6, 2.6),
            "stride": np.clip(rng.normal(0.72, 0.09, 10**6), 0.5, 0.95)}
    for k, (m, s) in (("pace", (2.05, 0.183)), ("stride", (0.72, 0.09))):
        e = r.estimates[k]
        print(f"{k}: mean {e['mean']:.4f} ({100 * (e['mean'] / m - 1):+.2f} % of {m}), std "
              f"{e['std']:.4f} ({100 * (e['std'] / s - 1):+.2f} % of {s}; "
              f"{100 * (e['std'] / clip[k].std() - 1):+.2f} % of the clipped {clip[k].std():.4f})")
    print(f"{len(b.ids)} tracks: features (EKF + spectra, with compilation) {t1 - t0:.1f} s; "
          f"fit {t2 - t1:.2f} s with compilation, {t3 - t2:.3f} s after")

