"""Does PETS's lens distortion (or the Tsai -> (3) conversion) bias self-calibration's tilt?

Issue 19.

On PETS09-S2L1 `rhythmjax-fit selfcal` gives a tilt of 11.6-12.3 deg against the Tsai
calibration's 16.48 deg (h 6.4 against 7.06 m). PETS's camera is a Tsai model with radial
distortion (kappa1), a principal point off the image centre, a f != b f and a roll of -3.1 deg;
the fit's camera is the pin-hole of (3) with the principal point at the centre, no roll and
a f = b f (what a config giving only the image size holds). This study makes the SAME synthetic
walkers on PETS's ground and sees them through several cameras, then runs the same fit on each:

- ``ideal``:  the camera of (3) the fit can represent exactly: PETS's h and tilt, a f = b f =
  740.6 px, principal point at the image centre, roll 0 (the PETS geometry alone: far walkers,
  7 fps);
- ``pinhole``: (a) the camera of (3) nearest to the Tsai camera (`rhythmjax camera --tsai`,
  `rhythmjax.evaluation.datasets.pets_camera`): principal point (202.6, 176.6) px, a f 740.6,
  b f 746.6 px, roll -3.09 deg, no distortion;
- ``tsai``: (b) the full Tsai camera of View_001.xml at 0.625 scale, its kappa1 included (the
  ground truth of where PETS's pixels are);
- ``undistorted``: (b)'s foot points, box edges and top rows undistorted with the known kappa1
  (Tsai's exact inverse) before the fit: the Tsai pin-hole without distortion;
- ``tsai_known_pp`` (with ``--known-pp``): (b) fitted from a start that holds Tsai's principal
  point, roll and b/a (only h, tilt, a f fitted): what is left of (b) when the conversion is known.

How the tracks are made: `fit.walking.make_labelled` (`rhythmjax.sim.tracks.make_tracks`,
walkers only: 1.5 px foot-point noise, 3 % gaps, heads N(1.70, 0.07) m, widths as eval_selfcal)
through the ``pinhole`` camera at 7 fps, with the simulator's depth range moved to PETS's ground
(RANGE_Y_M 12-36 m ahead, starts 13-34 m: the TrajNet positions of PETS's people lie 11.5-36 m
ahead of the camera's foot, 5-95 % 15-33 m) and 40-80 frames a track (6-11 s at 7 fps). The
true ground paths (x, y), heights and per-point noises are then kept and the image is
re-projected through each camera: foot point = camera(x, y, 0) + the same noise; width = the
same width x (the camera's |du| of a lateral 1 m at the foot) / (the pinhole's); top row =
camera(x, y, H) row + the same noise. So every variant has the same walkers, seeds, paces,
strides, heights, gaps and noise; only the camera differs.

The fit: `fit.selfcal.fit_selfcal` with its default cues (gait, speed, width, height), fitting
a f, h and tilt from the start config `benchmarks/selfcal_real.py` and the video command use
(only image size 480x360, fps 7, principal point at the centre; the fit's own grid of starts
does the rest: a rough start, not the Tsai camera). Errors are against the Tsai camera: h of (3)
7.064 m (the camera centre is 7.066 m above the ground), tilt 16.48 deg, a f 740.6 px (b f
746.6), all read from the XML here.

    python benchmarks/study_selfcal_distortion.py [n_seeds=5] [first_seed=0] [--walkers 30]
        [--known-pp] [--only ideal,pinhole,tsai,undistorted] [--kappa-scale K]

    python benchmarks/study_selfcal_distortion.py --pets-tracks WORK/pets/rough/tracks.parquet

`--pets-tracks` (what remains on real data): a PETS tracks file that `rhythmjax run` wrote (e.g.
`benchmarks/selfcal_real.py`'s rough tracks, with v_top) is matched row by row to Milan's
annotated boxes (nearest annotated foot point of the same frame within 0.3 box heights); it
prints the tracker-minus-annotation offsets of foot rows, columns, widths and top rows, the
annotated boxes' heights in metres through the Tsai camera, and the fit (gait+speed+width and
the default cues; the start of `benchmarks/selfcal_real.py`) with the tracker's foot points,
widths and top rows swapped for the annotated ones step by step (the rhythm signal, hence the
gait peaks, stays the tracker's), and with the annotated points undistorted with kappa1. The
tracks are read where they lie; nothing is written.

`--kappa-scale K` multiplies kappa1 in the ``tsai`` and ``undistorted`` variants (a sensitivity
check: how much distortion would it take to move the tilt by PETS's -4 deg?).

Prints one line per seed and variant, then a markdown table: per variant the median and the
range (min..max) over the seeds of the h error (%), the tilt error (deg) and the a f error (%),
the walkers used and how many fits were flagged ill-determined. Takes about a minute per seed
on 2 CPU cores (one jitted fit per variant).
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

import rhythmjax.sim.tracks as st
from fit.selfcal import fit_selfcal
from fit.selfcal_data import camera_values, scene_batch
from fit.walking import make_labelled
from rhythmjax.evaluation.datasets import pets_camera_from, pets_tsai
from rhythmjax.io import config_or_bad_input
from rhythmjax.model.camera_np import project_3d
from rhythmjax.model.params import Camera


SIZE, FPS, SCALE = (480, 360), 7.0, 0.625
RANGE_Y_M = (12.0, 36.0)  # PETS's people: 11.5-36 m ahead (TrajNet, in the pinhole's frame)
START_Y_M = (13.0, 34.0)
FRAMES = (40, 80)
VARIANTS = ("ideal", "pinhole", "tsai", "undistorted")


def cameras():
    """(Tsai calibration, CameraFrom of its nearest (3), the ideal (3) camera)."""
    tsai = pets_tsai()
    cf = pets_camera_from(None, SCALE)
    pin = cf.camera()
    af = float(pin.a) * float(pin.f)
    ideal = Camera(f=float(pin.f), h=float(pin.h), theta=float(pin.theta), a=af / float(pin.f),
                   b=af / float(pin.f), uc=SIZE[0] / 2, vc=SIZE[1] / 2, roll=0.0, fps=FPS,
                   image_width=SIZE[0], image_height=SIZE[1])
    return tsai, cf, ideal


def projector(name, tsai, cf, ideal):
    """(x, y, z) in the pinhole's ground frame (m) -> (u, v) px through camera `name`."""
    pin = cf.camera()
    if name == "pinhole":
        return lambda x, y, z: project_3d(pin, x, y, z)
    if name == "ideal":
        return lambda x, y, z: project_3d(ideal, x, y, z)

    def through_tsai(x, y, z):
        wx, wy = cf.transform.inverse(x, y)
        return tsai.world_to_image(wx, wy, z, scale=SCALE)

    return through_tsai


def undistort_px(tsai, u, v):
    """Pixels (u, v) of the 0.625-scaled Tsai image -> the same camera without its radial
    distortion (Tsai's model is explicit in this direction: X_u = X_d (1 + kappa1 r_d^2))."""
    xd = (np.asarray(u) / SCALE - tsai.cx) * tsai.dpx / tsai.sx
    yd = (np.asarray(v) / SCALE - tsai.cy) * tsai.dy
    k = 1 + tsai.kappa1 * (xd**2 + yd**2)
    return (SCALE * (tsai.cx + tsai.sx * xd * k / tsai.dpx), SCALE * (tsai.cy + yd * k / tsai.dy))


def pinhole_scene(seed: int, walkers: int, pin: Camera):
    """make_tracks' columns through the pinhole (PETS's ground range) and each track's head
    height (m), replayed from make_tracks' own generator for the top rows."""
    saved = st.RANGE_Y_M, st.START_Y_M
    st.RANGE_Y_M, st.START_Y_M = RANGE_Y_M, START_Y_M
    try:
        cols, truth = make_labelled(n_walkers=walkers, n_bicycles=0, n_dogs=0, n_cars=0,
                                    seed=seed, camera=pin, min_frames=FRAMES[0],
                                    max_frames=FRAMES[1])
    finally:
        st.RANGE_Y_M, st.START_Y_M = saved
    rng_top = np.random.default_rng([seed, 19])
    H = np.empty(cols["x"].shape)
    for tr in truth:  # make_tracks draws, per object in order: its height, then n noises
        m = cols["track_id"] == tr.track_id
        H[m] = rng_top.normal(*st.HEIGHT_M[tr.label])
        rng_top.normal(0, 1.5, int(m.sum()))
    top = np.asarray(project_3d(pin, cols["x"], cols["y"], H)[1])
    seen = np.isfinite(cols["v_top"])
    # the replay must give make_tracks' rows to within its noise (1.5 px, 6 sigma)
    assert np.all(np.abs(cols["v_top"][seen] - top[seen]) < 9.0), "height replay is off"
    return cols, H


def reproject(cols, H, pin: Camera, proj, tsai=None, undistort=False):
    """The same walkers through `proj` (module doc), optionally undistorted with kappa1."""
    x, y = cols["x"], cols["y"]
    z0 = np.zeros_like(x)
    ua, va = (np.asarray(q) for q in project_3d(pin, x, y, z0))
    ub, vb = (np.asarray(q) for q in proj(x, y, z0))
    out = dict(cols)
    u, v = ub + (cols["u"] - ua), vb + (cols["v"] - va)
    lat = lambda p: np.abs(np.asarray(p(x + 0.5, y, z0)[0]) - np.asarray(p(x - 0.5, y, z0)[0]))
    wa = lat(lambda *a: project_3d(pin, *a))
    w = cols["width_px"] * lat(proj) / wa
    top = np.asarray(proj(x, y, H)[1]) + (cols["v_top"] - np.asarray(project_3d(pin, x, y, H)[1]))
    if undistort:
        left, _ = undistort_px(tsai, u - w / 2, v)
        right, _ = undistort_px(tsai, u + w / 2, v)
        _, top = undistort_px(tsai, u, top)  # the head taken in the foot point's column
        u, v = undistort_px(tsai, u, v)
        w = right - left
    top = np.where(top >= 0, top, np.nan)
    out.update(u=u, v=v, width_px=w, v_top=top)
    return out


def start_config(tsai_pp: Camera | None = None):
    """The start the video command and benchmarks/selfcal_real.py use: image size, fps and the
    image centre; with `tsai_pp` its principal point, roll and b/a instead (held, not fitted)."""
    cam = {"image_width_px": SIZE[0], "image_height_px": SIZE[1], "fps": FPS,
           "uc_px": SIZE[0] / 2, "vc_px": SIZE[1] / 2}
    if tsai_pp is not None:
        v = camera_values(tsai_pp)
        cam.update(uc_px=v["uc"], vc_px=v["vc"], roll_deg=v["roll"])
    cfg = config_or_bad_input({"camera": cam, "thresholds": {"range_min_m": 3.0,
                                                             "range_max_m": 20.0}}, "start")
    if tsai_pp is not None:  # b/a of the Tsai camera (b f follows a f at the start's b/a)
        import equinox as eqx

        cfg = eqx.tree_at(lambda c: c.camera.b, cfg, cfg.camera.a * (tsai_pp.b / tsai_pp.a))
    return cfg


def pets_tracks(path: str) -> int:
    """What remains on PETS (module doc, `--pets-tracks`): the tracker's foot points, widths and
    top rows against Milan's annotated boxes, and the fit with them swapped in."""
    import tempfile
    from pathlib import Path

    import pyarrow as pa
    import pyarrow.parquet as pq
    from selfcal_real import pooled_batch

    from rhythmjax.evaluation.datasets import pets_boxes

    tab = pq.read_table(path)
    cols = {k: tab.column(k).to_numpy(zero_copy_only=False) for k in tab.column_names}
    box = pets_boxes()
    n = len(cols["frame"])
    j = np.full(n, -1)
    for i in range(n):  # nearest annotated foot point of the same frame, within 0.3 box heights
        if not (np.isfinite(cols["u"][i]) and np.isfinite(cols["v"][i])):
            continue
        k = np.flatnonzero(box["frame"] == cols["frame"][i])
        if k.size:
            d = np.hypot(box["foot_u"][k] - cols["u"][i], box["foot_v"][k] - cols["v"][i])
            if d.min() < 0.3 * box["bb_height"][k[np.argmin(d)]]:
                j[i] = k[np.argmin(d)]
    m = j >= 0
    dv = cols["v"][m] - box["foot_v"][j[m]]
    du = cols["u"][m] - box["foot_u"][j[m]]
    wr = cols["width_px"][m] / box["bb_width"][j[m]]
    mad = lambda a: 1.4826 * float(np.nanmedian(np.abs(a - np.nanmedian(a))))
    print(f"{m.sum()} of {np.isfinite(cols['v']).sum()} tracker foot points matched to an "
          f"annotated box; tracker - annotation: foot row median {np.median(dv):+.2f} px "
          f"(1.4826 MAD {mad(dv):.2f}, 95 % of |.| under {np.percentile(np.abs(dv), 95):.1f}), "
          f"column {np.median(du):+.2f} px (MAD {mad(du):.2f}), width ratio "
          f"{np.nanmedian(wr):.3f}")
    if "v_top" in cols:
        dt = cols["v_top"][m] - box["bb_top"][j[m]]
        ht = (cols["v"][m] - cols["v_top"][m]) / box["bb_height"][j[m]]
        print(f"  top rows: {np.isfinite(dt).sum()} of the matched rows have one; tracker - "
              f"annotation median {np.nanmedian(dt):+.2f} px (MAD {mad(dt):.2f}); tracker's "
              f"foot-top height / the box's {np.nanmedian(ht):.3f}")
    # the annotated boxes' heights in metres through the Tsai camera (distortion included):
    # the H whose point above the foot's ground point projects to the box's top row
    tsai = pets_tsai()
    gx, gy = tsai.ground_of_image(box["foot_u"], box["foot_v"], scale=SCALE)
    grid = np.arange(0.8, 2.6, 0.005)
    vt = tsai.world_to_image(gx[:, None], gy[:, None], grid[None, :], scale=SCALE)[1]
    Hm = grid[np.argmin(np.abs(vt - box["bb_top"][:, None]), 1)]
    Hm = Hm[np.isfinite(gx) & (Hm > grid[0]) & (Hm < grid[-1])]
    print(f"annotated boxes' heights through the Tsai camera: median {np.median(Hm):.3f} m, "
          f"10-90 % {np.percentile(Hm, 10):.2f}-{np.percentile(Hm, 90):.2f} m over {Hm.size} "
          "boxes (the height cue's prior: 1.70 m)")
    fv = box["foot_v"][j[m]]
    hgt = box["bb_height"][j[m]]
    for lo, hi in ((0, 150), (150, 200), (200, 250), (250, 300), (300, 360)):
        b = (fv >= lo) & (fv < hi)
        if b.sum() >= 10:
            print(f"  annotated foot rows {lo}-{hi}: {b.sum():4d} points, foot row offset median "
                  f"{np.median(dv[b]):+.2f} px ({np.median(dv[b] / hgt[b]):+.3f} box heights), "
                  f"width ratio {np.nanmedian(wr[b]):.3f}, box height {np.median(hgt[b]):.0f} px")
    nan = np.full(n, np.nan)
    take = lambda a: np.where(m, a[np.maximum(j, 0)], nan)
    variants = {
        "tracker (as tracked)": {},
        "tracker feet+widths, annotated tops": {"v_top": take(box["bb_top"])},
        "tracker, matched rows only": {"u": np.where(m, cols["u"], nan),
                                       "v": np.where(m, cols["v"], nan)},
        "annotated feet": {"u": take(box["foot_u"]), "v": take(box["foot_v"])},
        "annotated feet+widths": {"u": take(box["foot_u"]), "v": take(box["foot_v"]),
                                  "width_px": take(box["bb_width"])},
        "annotated feet+widths+tops": {"u": take(box["foot_u"]), "v": take(box["foot_v"]),
                                       "width_px": take(box["bb_width"]),
                                       "v_top": take(box["bb_top"])},
    }
    a = variants["annotated feet+widths+tops"]
    tsai = pets_tsai()
    left, _ = undistort_px(tsai, a["u"] - a["width_px"] / 2, a["v"])
    right, _ = undistort_px(tsai, a["u"] + a["width_px"] / 2, a["v"])
    uu, vu = undistort_px(tsai, a["u"], a["v"])
    variants["the same, undistorted with kappa1"] = {
        "u": uu, "v": vu, "width_px": right - left, "v_top": undistort_px(tsai, a["u"],
                                                                          a["v_top"])[1]}
    tv = camera_values(cameras()[1].camera())
    print("| foot points, widths, top rows from | cues | walkers | h (m) | tilt (deg) | a f (px) |"
          " flagged |")
    print("|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as d:
        for name, repl in variants.items():
            c = dict(cols)
            if "u" in repl:  # rows without a match lose their measurements
                c["width_px"] = np.where(m, c["width_px"], np.nan)
                if "v_top" in c and "v_top" not in repl:
                    c["v_top"] = np.where(m, c["v_top"], np.nan)
            c.update(repl)
            p = Path(d) / name.split()[0].replace("+", "_") / "tracks.parquet"
            p.parent.mkdir(exist_ok=True)
            pq.write_table(pa.table(c), p)
            cfg, b = pooled_batch([p], SIZE, FPS)
            for cues in (("gait", "speed", "width"),) + (
                    (("gait", "speed", "width", "height"),) if "v_top" in c else ()):
                r = fit_selfcal(cfg, b, cues=cues)
                if r.camera is None:
                    print(f"| {name} | {'+'.join(cues)} | {r.n_walkers} | refused | | | "
                          f"{'; '.join(r.reasons)} |", flush=True)
                    continue
                v, se = r.values, r.se
                print(f"| {name} | {'+'.join(r.cues)} | {r.n_walkers} of {r.n_tracks} | "
                      f"{v['h']:.2f} +- {se['h']:.2f} | {v['theta']:.1f} +- {se['theta']:.1f} | "
                      f"{v['af']:.0f} +- {se['af']:.0f} | "
                      f"{'; '.join(r.reasons) if r.ill_determined else '-'} |", flush=True)
    print(f"(Tsai: h {tv['h']:.2f} m, tilt {tv['theta']:.2f} deg, a f {tv['af']:.0f} px)")
    return 0


def main(argv=None) -> int:
    a = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    a.add_argument("n_seeds", nargs="?", type=int, default=5)
    a.add_argument("first_seed", nargs="?", type=int, default=0)
    a.add_argument("--walkers", type=int, default=30)
    a.add_argument("--known-pp", action="store_true")
    a.add_argument("--only", default=",".join(VARIANTS))
    a.add_argument("--kappa-scale", type=float, default=1.0)
    a.add_argument("--pets-tracks")
    args = a.parse_args(argv)
    if args.pets_tracks:
        return pets_tracks(args.pets_tracks)
    tsai, cf, ideal = cameras()
    if args.kappa_scale != 1.0:  # a sensitivity check: PETS's kappa1 times this in (b)
        import dataclasses

        tsai = dataclasses.replace(tsai, kappa1=tsai.kappa1 * args.kappa_scale)
        print(f"kappa1 x {args.kappa_scale:g} (a sensitivity check, not PETS's camera)")
    pin = cf.camera()
    tv = camera_values(pin)
    print(f"Tsai: camera centre {tsai.h_m:.3f} m above the ground, (3)'s h {tv['h']:.3f} m, "
          f"tilt {tv['theta']:.2f} deg, a f {tv['af']:.1f} px, b f {tv['bf']:.1f} px, "
          f"principal point ({tv['uc']:.1f}, {tv['vc']:.1f}), roll {tv['roll']:.2f} deg, "
          f"kappa1 {tsai.kappa1:.4g} mm^-2; nearest (3): max {cf.residual_max_px:.2f} px, RMS "
          f"{cf.residual_rms_px:.2f} px", flush=True)
    variants = [q for q in args.only.split(",") if q]
    if args.known_pp:
        variants.append("tsai_known_pp")
    cfg0, cfg_pp = start_config(), start_config(pin)
    rows = {k: [] for k in variants}
    for seed in range(args.first_seed, args.first_seed + args.n_seeds):
        cols, H = pinhole_scene(seed, args.walkers, pin)
        for name in variants:
            base = "tsai" if name in ("undistorted", "tsai_known_pp") else name
            c = reproject(cols, H, pin, projector(base, tsai, cf, ideal), tsai,
                          undistort=name == "undistorted")
            cfg = cfg_pp if name == "tsai_known_pp" else cfg0
            b = scene_batch(c, cfg)
            d = np.hypot(c["u"] - cols["u"], c["v"] - cols["v"])
            d = d[np.isfinite(d)]
            moved = (f"feet moved from the pinhole's: median {np.median(d):.2f}, max "
                     f"{np.max(d):.2f} px")
            t0 = time.perf_counter()
            r = fit_selfcal(cfg, b)
            dt = time.perf_counter() - t0
            if r.camera is None:
                print(f"seed {seed} {name:14s} refused: {'; '.join(r.reasons)}", flush=True)
                rows[name].append(None)
                continue
            v = r.values
            e = {"h": 100 * (v["h"] / tv["h"] - 1), "theta": v["theta"] - tv["theta"],
                 "af": 100 * (v["af"] / tv["af"] - 1), "n": r.n_walkers,
                 "ill": r.ill_determined}
            rows[name].append(e)
            print(f"seed {seed} {name:14s} h {v['h']:5.2f} +- {r.se['h']:.2f} ({e['h']:+5.1f} %)"
                  f"  tilt {v['theta']:5.2f} +- {r.se['theta']:.2f} ({e['theta']:+5.2f} deg)  "
                  f"af {v['af']:5.0f} +- {r.se['af']:.0f} ({e['af']:+5.1f} %)  walkers "
                  f"{r.n_walkers} of {r.n_tracks}  cues {'+'.join(r.cues)}"
                  f"  {moved}{'  ILL: ' + '; '.join(r.reasons) if r.ill_determined else ''}"
                  f"  {dt:.0f} s",
                  flush=True)
    n = args.n_seeds
    print(f"\n{n} seeds ({args.first_seed}-{args.first_seed + n - 1}), {args.walkers} walkers, "
          "default cues, rough start (image centre); median [min..max] over the seeds")
    print("| camera the tracks are seen through | h error (%) | tilt error (deg) | a f error (%) "
          "| walkers used (median) | flagged |")
    print("|---|---|---|---|---|---|")
    for name, rs in rows.items():
        ok = [q for q in rs if q is not None]
        if not ok:
            print(f"| {name} | - | - | - | - | {len(rs)} refused |")
            continue
        def s(k, fmt, ok=ok):
            x = [q[k] for q in ok]
            return f"{np.median(x):{fmt}} [{min(x):{fmt}}..{max(x):{fmt}}]"

        print(f"| {name} | {s('h', '+.1f')} | {s('theta', '+.2f')} | {s('af', '+.1f')} | "
              f"{int(np.median([q['n'] for q in ok]))} | {sum(q['ill'] for q in ok)} of "
              f"{len(rs)} |")
    return 0


if __name__ == "__main__":
    np.seterr(all="ignore")
    sys.exit(main())
