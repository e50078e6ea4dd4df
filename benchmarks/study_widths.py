"""How wide walkers are against W, per source, and the width gate's spread fitted with its mean
held (issue 16, twenty-eighth round; docs/rules.md, "How wide walkers are against W").

W is the image width of the width model's mean walker (0.5 m, Table 1) at a foot point, through
the source's camera (`vision.window_b.walker_width_px`). Two widths are compared with it:

- the box width: PETS09's annotated boxes (`--pets`) or the own renderer's truth width
  (`--own`, `--fit`), what a person drew or the silhouette's extent;
- the tracker's measured width `width_px` (the projection slice of the difference image, what
  the width gate (10) reads) on its rows whose foot point lies within `MATCH_W` W of a true
  walker's foot point (all rows with a measurement, observed or refused).

`--fit SEED,SEED` fits the gate's spread on the own scenes of those seeds by maximum likelihood
with the mean held at the config's (so W, and every constant written in W, stay as they are):
sigma^2 = mean (w - mean_m)^2 over the matched rows, w = mean_m * width_px / W (m).

    python benchmarks/study_widths.py --own 20240603 --scenes 4
    RHYTHMJAX_DATA=../shared/data/real python benchmarks/study_widths.py --pets
    python benchmarks/study_widths.py --fit 5555,6666             # rule 22's width.std_m
"""

from __future__ import annotations

import argparse
import os
import sys

import numpy as np


sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

MATCH_W = 0.35  # a measured foot point within this many W of the truth's is on that walker
# (the scoring's limit, `sim.evaluate`)


def held_mean_std(w, mean: float) -> float:
    """The maximum-likelihood spread (same units as w) of a Gaussian with its mean held at
    `mean`: sqrt(mean((w - mean)^2)) over the finite w; NaN if none."""
    w = np.asarray(w, np.float64)
    w = w[np.isfinite(w)]
    return float(np.sqrt(np.mean((w - mean) ** 2))) if w.size else float("nan")


def matched_ratios(u, v, width_px, u_true, v_true, W) -> np.ndarray:
    """width_px / W of the rows (arrays of one length: a measured foot point (u, v), its width,
    the true foot point of the same frame and W there) whose foot point lies within `MATCH_W` W
    of the truth's and whose values are finite."""
    u, v, wp, ut, vt, W = (np.asarray(a, np.float64) for a in (u, v, width_px, u_true,
                                                                 v_true, W))
    ok = np.isfinite(u) & np.isfinite(v) & np.isfinite(wp) & np.isfinite(W) & (W > 0)
    ok &= np.hypot(u - ut, v - vt) < MATCH_W * np.where(ok, W, np.inf)
    return wp[ok] / W[ok]


def own_ratios(seeds, scenes: int) -> tuple[np.ndarray, np.ndarray, object]:
    """(measured width / W of the tracker's matched rows, truth width / W of every visible walker
    frame, the config) over the own scenes of `seeds` (eval_synthetic's preset)."""
    import eval_synthetic as es
    import pandas as pd

    from rhythmjax.model.params import config_from_dict
    from rhythmjax.vision.window_b import walker_width_px

    cfg = config_from_dict(es.RECOMMENDED)
    measured, truth = [], []
    for seed in seeds:
        for s, spec in es.scene_specs(seed, camera=cfg.camera)[:scenes]:
            _, tracks, _, scene, _ = es.run_scene(cfg, s, spec, es.synthetic_options())
            tr = pd.DataFrame(tracks)
            for o in scene.truth:
                if o.kind != "pedestrian":
                    continue
                k = np.flatnonzero(np.isfinite(o.u) & np.isfinite(o.v))
                Wt = walker_width_px(cfg.camera, cfg.width, o.u[k], o.v[k])
                truth.append(o.width_px[k] / Wt)
                m = tr.merge(pd.DataFrame({"frame": k, "ut": o.u[k], "vt": o.v[k], "W": Wt}),
                             on="frame")
                measured.append(matched_ratios(m.u, m.v, m.width_px, m.ut, m.vt, m.W))
    return np.concatenate(measured), np.concatenate(truth), cfg


def pets_ratios() -> tuple[np.ndarray, np.ndarray, object]:
    """The same on PETS09-S2L1 (Tsai camera, 7 fps): the tracker's rows matched to the annotated
    boxes' bottom centres, and the annotated boxes away from the image's edges."""
    import eval_real_video as ev
    import pandas as pd

    from rhythmjax.evaluation import datasets
    from rhythmjax.vision.window_b import walker_width_px

    cfg = ev.video_config(ev.pets_config_dict(), datasets.pets_video(), datasets.PETS_FPS)
    b = pd.DataFrame(datasets.pets_boxes())
    b["W"] = walker_width_px(cfg.camera, cfg.width, b.foot_u.values, b.foot_v.values)
    w_img, h_img = datasets.PETS_SIZE
    inside = (b.bb_left > 2) & (b.bb_left + b.bb_width < w_img - 2) & (b.foot_v < h_img - 5)
    truth = (b.bb_width / b.W)[inside].to_numpy()
    tracks, _ = ev.track(cfg, datasets.pets_video(), datasets.PETS_FPS)
    tr = pd.DataFrame({k: np.asarray(tracks[k]) for k in ("track_id", "frame", "u", "v",
                                                          "width_px")})
    m = tr.merge(b[["frame", "foot_u", "foot_v", "W"]], on="frame")
    m["d"] = np.hypot(m.u - m.foot_u, m.v - m.foot_v)
    m = m.sort_values("d").drop_duplicates(["track_id", "frame"])  # each row's nearest person
    return matched_ratios(m.u, m.v, m.width_px, m.foot_u, m.foot_v, m.W), truth, cfg


def describe(name: str, measured, truth, mean_m: float, std_m: float, k_sigma1: float) -> str:
    """One line: the quantiles of both ratios, the share of measured rows gate (10) passes at
    (mean_m, std_m, k_sigma1), and `held_mean_std` of the measured widths (m)."""
    q = lambda a: "/".join(f"{x:.2f}" for x in np.percentile(a, [10, 25, 50, 75, 90]))
    w = mean_m * np.asarray(measured)
    inside = float(np.mean(np.abs(w - mean_m) <= k_sigma1 * std_m))
    return (f"{name}: box width / W q10/25/50/75/90 {q(truth)} ({len(truth)} frames); measured "
            f"width / W {q(measured)} ({len(measured)} rows); gate (10) at std {std_m:.3f} m "
            f"passes {inside:.1%}; spread with the mean held {held_mean_std(w, mean_m):.4f} m")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--own", help="comma-separated own-scene seeds")
    p.add_argument("--scenes", type=int, default=10, help="scenes per own seed")
    p.add_argument("--pets", action="store_true", help="PETS09-S2L1 (RHYTHMJAX_DATA)")
    p.add_argument("--fit", help="comma-separated own seeds: the gate's spread fitted there")
    a = p.parse_args(argv)
    runs = []
    if a.own:
        runs.append((f"own {a.own}", own_ratios([int(s) for s in a.own.split(",")], a.scenes)))
    if a.fit:
        runs.append((f"own {a.fit} (fit)", own_ratios([int(s) for s in a.fit.split(",")],
                                                      a.scenes)))
    if a.pets:
        runs.append(("PETS09", pets_ratios()))
    if not runs:
        p.error("give --own, --pets or --fit")
    for name, (measured, truth, cfg) in runs:
        mean_m, std_m = float(cfg.width.mean), float(cfg.width.std)
        print(describe(name, measured, truth, mean_m, std_m, float(cfg.thresholds.k_sigma1)))
        if name.endswith("(fit)"):
            print(f"width.std_m fitted (mean held at {mean_m} m): "
                  f"{held_mean_std(mean_m * measured, mean_m):.4f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
