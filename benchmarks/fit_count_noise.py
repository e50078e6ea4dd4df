"""The counting tracker's EKF noise (q, R) fitted from labelled tracks (issue 16, counting).

`count`'s ground-plane EKF takes the config's noise, chosen for the rhythm tracker's detector.
This fits it to the counting tracker's own measurements with the fitting layer
(`fit.noise.fit_noise`: BFGS on the EKF's innovation likelihood, float64): the output tracks of
`benchmarks/count_dump.py` dumps whose majority owner is a walker (`eval_count.
owner_of_tracks`), a row used when its state is observe and its box overlaps that walker's
truth box with IoU >= 0.3 in the same frame (the rows on another object are left out as
missing: they are what gates and ends are for, not the noise). The camera is the own clips'
(`sim.presets.SYNTHETIC_CONFIG`, at `--focal-px`).

    python benchmarks/fit_count_noise.py tr_contrasted_800.pkl tr_any_800.pkl [--focal-px 800] \\
        [--json fit.json]

Prints the fitted q (m/s per sqrt(s)) and R (px) with standard errors, the log-likelihood gain
over the config's noise, and the `--set placement.noise=[...]` value that gives it to `count`.
"""

from __future__ import annotations

import argparse
import copy
import json
import os
import pickle
import sys

import numpy as np


sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from eval_count import iou_matrix, owner_of_tracks  # noqa: E402


def labelled_rows(dump: list[dict], min_iou: float = 0.3) -> list[np.ndarray]:
    """Per walker-owned output track: (T, 3) frame-ordered rows (frame, u, v), u and v NaN where
    the row is not a measurement on its owner (state not observe, or box IoU < min_iou)."""
    out = []
    for r in dump:
        hyp, truth, tr = r["mot"], r["truth"], r["tracks"]
        owners = owner_of_tracks(truth, hyp, r["offset"], min_iou)
        for tid, own in owners.items():
            if own is None or r["kinds"].get(own) != "pedestrian":
                continue
            k = np.flatnonzero(np.asarray(tr["track_id"]) == tid)
            if len(k) < 3:
                continue
            frames = np.asarray(tr["frame"])[k]
            u = np.asarray(tr["u"], np.float64)[k].copy()
            v = np.asarray(tr["v"], np.float64)[k].copy()
            obs = np.asarray([s == "observe" for s in np.asarray(tr["state"])[k]])
            hk = {int(f): i for f, i in zip(np.asarray(hyp["frame"]), range(len(hyp["frame"])))
                  if int(hyp["id"][i]) == tid}
            tk = {int(f): i for f, i in zip(np.asarray(truth["frame"]), range(len(truth["frame"])))
                  if int(truth["id"][i]) == own}
            for j, f in enumerate(frames):
                h, t = hk.get(int(f)), tk.get(int(f) + r["offset"])
                ok = obs[j] and h is not None and t is not None
                if ok:
                    hb = np.array([[hyp[c][h] for c in ("bb_left", "bb_top", "bb_width",
                                                          "bb_height")]], np.float64)
                    tb = np.array([[truth[c][t] for c in ("bb_left", "bb_top", "bb_width",
                                                            "bb_height")]], np.float64)
                    ok = float(iou_matrix(hb, tb)[0, 0]) >= min_iou
                if not ok:
                    u[j] = v[j] = np.nan
            if np.sum(np.isfinite(u)) >= 3:
                out.append(np.column_stack([frames, u, v]))
    return out


def batch(tracks: list[np.ndarray], fps: float):
    """TrackBatch-like arrays (z, width, dt, present) of the tracks, padded to the longest; a
    frame between a track's first and last with no row is missing (present, z NaN)."""
    T = max(int(t[-1, 0] - t[0, 0]) + 1 for t in tracks)
    B = len(tracks)
    z = np.full((B, T, 2), np.nan)
    present = np.zeros((B, T), bool)
    for b, t in enumerate(tracks):
        k = (t[:, 0] - t[0, 0]).astype(int)
        z[b, k] = t[:, 1:3]
        present[b, :k[-1] + 1] = True
    dt = np.full((B, T), 1.0 / fps)
    return z, np.full((B, T), np.nan), dt, present


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("dumps", nargs="+", help="count_dump.py files of own clips (one camera)")
    p.add_argument("--focal-px", type=float, default=800.0, help="their a f (px)")
    p.add_argument("--json", help="write the fit here")
    a = p.parse_args(argv)

    from fit.noise import fit_noise
    from rhythmjax.model.params import config_from_dict
    from rhythmjax.sim.presets import SYNTHETIC_CONFIG

    d = copy.deepcopy(SYNTHETIC_CONFIG)
    d["camera"] = {"a_px_per_m": a.focal_px / 0.008, "b_px_per_m": a.focal_px / 0.008}
    cfg = config_from_dict(d)
    tracks, fps = [], None
    for path in a.dumps:
        with open(path, "rb") as f:
            dump = pickle.load(f)
        fps = float(dump[0]["fps"])
        tracks += labelled_rows(dump)
    z, width, dt, present = batch(tracks, fps)
    n_rows = int(np.sum(np.all(np.isfinite(z), axis=-1)))
    print(f"{len(tracks)} walker tracks, {n_rows} measured rows on their walker")
    res = fit_noise(cfg.camera, z, width, dt, present, cfg.noise)
    print(res.summary())
    v = res.values
    value = [round(v["q_x"], 4), round(v["q_y"], 4), round(v["r_u"], 3), round(v["r_v"], 3),
             round(v["r_corr"], 3)]
    print(f"--set placement.noise='{json.dumps(value)}'")
    if a.json:
        tmp = a.json + ".tmp"
        with open(tmp, "w") as f:
            json.dump({**res.to_dict(), "tracks": len(tracks), "rows": n_rows,
                       "placement.noise": value}, f, indent=2)
        os.replace(tmp, a.json)
    return 0 if res.success and not res.ill_determined else 1


if __name__ == "__main__":
    raise SystemExit(main())
