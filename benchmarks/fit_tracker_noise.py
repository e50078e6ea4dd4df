"""The tracker's EKF noise (q, R) fitted from labelled own-scene tracks (issue 16, rule 19).

`rhythmjax run`'s EKF takes the config's noise: Table 1's R of 2 px, or the own scenes' preset
(`sim.presets.SYNTHETIC_CONFIG`, 4 px) there. This fits it with the fitting layer
(`fit.noise.fit_noise`: BFGS on the EKF's innovation likelihood, float64) to the tracker's own
measurements on own scenes (`eval_synthetic.py`'s scenes and preset, seeds `--seeds`): every
track `sim.evaluate.match_tracks` gives to a walker; a row used where it was measured and its
foot point lies within `--within` of the walker's truth width from the walker's truth foot point
(rows on another object are left out as missing: they are what the gates are for, not the
noise). Writes the fitted keys as `--set` items (OUT/fitted_sets.json) for
`eval_rules.py run fitted on -d OUT`.

    python benchmarks/fit_tracker_noise.py [--seeds 5555,6666] [--scenes 10] [--max-steps 1000]
                                           [-d OUT]

Nothing else is chosen here.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

import numpy as np


sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))


def labelled_rows(tracks: dict, truth, within: float) -> list[np.ndarray]:
    """Per walker-matched track: (T, 3) rows (frame, u, v) ordered by frame, one per frame,
    u and v NaN where the row is not a measurement on its walker (unmeasured, or farther than
    `within` x its truth width from its truth foot point)."""
    from rhythmjax.sim.evaluate import match_tracks

    own = match_tracks(tracks, truth)
    tid, fr = np.asarray(tracks["track_id"]), np.asarray(tracks["frame"])
    u, v = np.asarray(tracks["u"], np.float64), np.asarray(tracks["v"], np.float64)
    out = []
    for t, obj in own.items():
        if obj.kind != "pedestrian":
            continue
        m = np.flatnonzero(tid == t)
        m = m[np.unique(fr[m], return_index=True)[1]]  # one row per frame (a relink may repeat)
        f = fr[m]
        ok = f < len(obj.u)
        fc = np.where(ok, f, 0)
        d = np.hypot(u[m] - obj.u[fc], v[m] - obj.v[fc])
        near = ok & obj.visible[fc] & (d <= within * obj.width_px[fc])
        out.append(np.stack([f, np.where(near, u[m], np.nan), np.where(near, v[m], np.nan)], 1))
    return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--seeds", default="5555,6666")
    p.add_argument("--scenes", type=int, default=10)
    p.add_argument("--within", type=float, default=0.5, help="truth widths (default 0.5)")
    p.add_argument("--max-steps", type=int, default=1000, help="BFGS steps (default 1000)")
    p.add_argument("-d", "--dir", default="fit_tracker_noise")
    a = p.parse_args(argv)

    import eval_synthetic as es
    from fit_count_noise import batch

    from fit.noise import fit_noise
    from rhythmjax.model.params import config_from_dict

    cfg = config_from_dict(es.RECOMMENDED)
    rows = []
    for seed in (int(s) for s in a.seeds.split(",")):
        for s, spec in es.scene_specs(seed, a.scenes, camera=cfg.camera):
            _, tracks, _, scene, _ = es.run_scene(cfg, s, spec)
            rows += labelled_rows(tracks, scene.truth, a.within)
        print(f"seed {seed}: {len(rows)} walker tracks so far", flush=True)
    rows = [r for r in rows if np.isfinite(r[:, 1]).sum() >= 2]
    z, width, dt, present = batch(rows, float(cfg.camera.fps))  # counting's padding
    n_rows = int(np.sum(np.all(np.isfinite(z), axis=-1)))
    print(f"{len(rows)} walker tracks, {n_rows} measured rows on their walker")
    res = fit_noise(cfg.camera, z, width, dt, present, cfg.noise, max_steps=a.max_steps)
    print(res.summary())
    v = res.values
    sets = [["noise", "q_std_mps_per_sqrt_s", [round(v["q_x"], 4), round(v["q_y"], 4)]],
            ["noise", "r_std_px", [round(v["r_u"], 3), round(v["r_v"], 3)]],
            ["noise", "r_corr", round(v["r_corr"], 3)]]
    out = Path(a.dir)
    out.mkdir(parents=True, exist_ok=True)
    tmp = out / "fitted_sets.json.tmp"
    tmp.write_text(json.dumps({"fit": res.to_dict(), "tracks": len(rows), "rows": n_rows,
                               "seeds": a.seeds, "within": a.within, "sets": sets}, indent=1,
                              default=float))
    os.replace(tmp, out / "fitted_sets.json")
    print(" ".join(f"--set {s}.{k}={json.dumps(x)}" for s, k, x in sets))
    return 0 if res.success and not res.ill_determined else 1


if __name__ == "__main__":
    raise SystemExit(main())
