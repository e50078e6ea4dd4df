"""Self-calibration from people walking (issue 19) on synthetic scenes with random cameras.

For each seed: a random camera (`fit.selfcal_data.random_camera`: h 2-10 m, tilt 5-40 deg,
a f 400-1500 px, real image sizes, principal point at the centre, roll 0), 20 walkers
(`rhythmjax.sim.tracks.make_tracks`: 1.5 px foot-point noise, 3 % gaps, 72-110 frames at
15 fps), optionally with bicycles and dogs mixed in; the start config gives only the image size
and fps (h 4 m, tilt 15 deg, a f = the image width: the grid of starts does the rest). Each cue
set is fitted (`fit.selfcal.fit_selfcal`, the CLI's function) and compared with the truth.

    python benchmarks/eval_selfcal.py [n_scenes=20] [first_seed=0] [--mix] [--sets A+B,C]
        [--outliers] [--frame-union] [--stride-model walk-ratio] [--height-mean-sd M]
        [--stride-mean-sd M] [--cue-spreads data]
    python benchmarks/eval_selfcal.py --tracks T.parquet [T2.parquet ...] --image-size WxH
        --fps F --truth H_M,TILT_DEG[,AF_PX]

The second form pools tracks files that `rhythmjax run` wrote (track ids prefixed by their
folder, so clips of one camera pool), self-calibrates from them and prints the errors against a
known camera (PETS09-S2L1: Tsai's h 7.07 m, tilt 16.5 deg; the dev clips: their JSON's camera).
Real data is read where it lies, never copied into the repository. For example:

    rhythmjax camera --video $D/video/vtest_480x360.avi --fps 7 --focal-px 500 --height 5 \
        --tilt 20 -o rough.json
    rhythmjax run $D/video/vtest_480x360.avi -c rough.json --fps 7 --max-objects 24 \
        --no-overlay --no-camera-check -o pets_out
    python benchmarks/eval_selfcal.py --tracks pets_out/tracks.parquet --image-size 480x360 \
        --fps 7 --truth 7.07,16.5

Prints per cue set: median |h error| (%), median |tilt error| (deg), median |a f error| (%),
how many fits were flagged ill-determined (the CLI would refuse them), the median walkers used
and how many non-walkers were among them; each fit's line also gives the clearance (px) of the
used foot points below the fitted horizon (`fit.selfcal_checks`: under 4 px it is refused).
`--outliers` turns on the foot-point outlier rule (`fit.selfcal_outliers`, off by default) to
compare; `--frame-union` the frame-difference correction (`fit.selfcal_union`, off by
default): the simulator draws no union, so this measures what the correction costs where there
is nothing to correct. `--stride-model walk-ratio` gives the gait cue a stride that follows the
pace (`fit.selfcal_gait.expected_stride`); the simulator draws pace and stride independently (Table
1), so this measures what that model costs where it does not hold. `--height-mean-sd M` is the
spread of the walkers' mean height about 1.70 m (the command's; default 0.05, 0 holds it; the
simulator's walkers are N(1.70, 0.07^2) m, so it costs what estimating the mean costs where it
is known). `--stride-mean-sd M` lets the crowd's mean stride differ from the walking model's
(the command's; default 0, held): the simulator's walkers keep Table 1's mean, so it costs what
estimating that mean costs where it is known. h is not determined by
``speed`` alone (scale-free): its h column is left out. The simulator writes no tracker `state`
column, so the observed-rows rule (`fit.selfcal_rows`, the command's `--observed-only`) has
nothing to act on here.
"""

from __future__ import annotations

import math
import sys
import time

import numpy as np

from fit.selfcal import fit_selfcal
from fit.selfcal_checks import horizon_clearance
from fit.selfcal_data import camera_values, scene, scene_batch as batch_of
from fit.selfcal_height import HEIGHT_MEAN_SD_M
from rhythmjax.model.params import Camera, Config


CUE_SETS = (("gait", "speed", "width"), ("gait", "speed"), ("gait",), ("speed",), ("width",),
            ("speed", "width"), ("height",), ("gait", "height"),
            ("gait", "speed", "width", "height"))


def start_config(cam: Camera) -> Config:
    """What the user knows: image size and fps (the principal point at the centre)."""
    return Config(camera=Camera(f=0.008, h=4.0, theta=math.radians(15.0),
                                a=cam.image_width / 0.008, b=cam.image_width / 0.008,
                                uc=cam.image_width / 2, vc=cam.image_height / 2, fps=cam.fps,
                                image_width=cam.image_width, image_height=cam.image_height))


def run(n_scenes: int, seed0: int, mix: bool, cue_sets=CUE_SETS, outliers: bool = False,
        frame_union: bool = False, stride_model: str = "table1",
        height_mean_sd: float = HEIGHT_MEAN_SD_M, stride_mean_sd: float = 0.0,
        cue_spreads: str = "model") -> dict:
    rows = {c: [] for c in cue_sets}
    for seed in range(seed0, seed0 + n_scenes):
        rng = np.random.default_rng(seed)
        cam, cols, _ = scene(rng, walkers=20, bicycles=4 if mix else 0, dogs=4 if mix else 0)
        tv = camera_values(cam)
        cfg = start_config(cam)
        b = batch_of(cols, cfg)
        labels = dict(zip(b.ids, b.labels, strict=True))
        for cues in cue_sets:
            t0 = time.perf_counter()
            r = fit_selfcal(cfg, b, cues=cues, outliers=outliers, frame_union=frame_union,
                            stride_model=stride_model, height_mean_sd=height_mean_sd,
                            stride_mean_sd=stride_mean_sd, cue_spreads=cue_spreads)
            dt = time.perf_counter() - t0
            if r.camera is None:
                rows[cues].append(None)
                continue
            others = sum(labels[i] != "pedestrian" for i in r.walker_ids)
            # px from the fitted horizon to the nearest used foot point (the pinned-horizon check)
            clear = horizon_clearance(r.camera, b, np.isin(b.ids, r.walker_ids))[0]
            rows[cues].append({
                "h": 100 * (r.values["h"] / tv["h"] - 1), "theta": r.values["theta"] - tv["theta"],
                "af": 100 * (r.values["af"] / tv["af"] - 1), "ill": r.ill_determined,
                "walkers": r.n_walkers, "others": others, "s": dt,
                "se_h": 100 * r.se["h"] / r.values["h"], "se_theta": r.se["theta"]})
            print(f"seed {seed} {'+'.join(cues):18s} h {tv['h']:5.2f} -> {r.values['h']:6.2f}  "
                  f"tilt {tv['theta']:5.2f} -> {r.values['theta']:6.2f}  af {tv['af']:6.0f} -> "
                  f"{r.values['af']:7.0f}  walkers {r.n_walkers} ({others} not)  "
                  f"clearance {clear:.0f} px  "
                  f"{'ILL ' if r.ill_determined else ''}{dt:.1f} s", flush=True)
    return rows


def table(rows: dict, title: str) -> None:
    print(f"\n{title}")
    print("| cues | median abs h error (%) | median abs tilt error (deg) | median abs af error (%) "
          "| median SE h (%) / tilt (deg) | flagged ill-determined | walkers used (median) "
          "| non-walkers used (total) |")
    print("|---|---|---|---|---|---|---|---|")
    for cues, rs in rows.items():
        ok = [r for r in rs if r is not None]
        med = lambda k, ok=ok: float(np.median([abs(r[k]) for r in ok]))
        h = "n/a (scale-free)" if cues == ("speed",) else f"{med('h'):.1f}"
        print(f"| {'+'.join(cues)} | {h} | {med('theta'):.2f} | {med('af'):.1f} | "
              f"{float(np.median([r['se_h'] for r in ok])):.1f} / "
              f"{float(np.median([r['se_theta'] for r in ok])):.2f} | "
              f"{sum(r['ill'] for r in ok)} of {len(rs)} | "
              f"{int(np.median([r['walkers'] for r in ok]))} | {sum(r['others'] for r in ok)} |")


def real(paths: list[str], size: tuple[int, int], fps: float, truth: list[float]) -> None:
    """Pool `paths` (tracks files), self-calibrate with each cue set, print errors vs `truth`."""
    import tempfile
    from pathlib import Path

    import pyarrow as pa
    import pyarrow.parquet as pq

    from rhythmjax.io import read_tracks

    tables = []
    for p in paths:
        t = pq.read_table(p)
        name = Path(p).parent.name
        ids = pa.array([f"{name}:{i}" for i in t.column("track_id").to_pylist()], pa.string())
        tables.append(t.set_column(t.schema.get_field_index("track_id"), "track_id", ids))
    from rhythmjax.io import config_or_bad_input

    # as the command builds it: N = window_s x fps (64 at 15 fps), the image centre
    cfg = config_or_bad_input({"camera": {"image_width_px": size[0], "image_height_px": size[1],
                                          "fps": fps, "uc_px": size[0] / 2,
                                          "vc_px": size[1] / 2},
                               "thresholds": {"range_min_m": 3.0, "range_max_m": 20.0}}, "real")
    with tempfile.TemporaryDirectory() as d:
        pq.write_table(pa.concat_tables(tables, promote_options="default"), f"{d}/t.parquet")
        b = read_tracks(f"{d}/t.parquet", fps=fps).to_batch(
            max_gap_frames=5, min_len=cfg.thresholds.n, fps=fps)
    names = ("h", "theta", "af")
    for cues in CUE_SETS[:3]:
        r = fit_selfcal(cfg, b, cues=cues)
        line = "  ".join(f"{k} {r.values[k]:.2f} +- {r.se.get(k, math.nan):.2f} (truth {t})"
                         for k, t in zip(names, truth, strict=False))
        print(f"{'+'.join(cues):18s} {line}  walkers {r.n_walkers} of {r.n_tracks}  "
              f"{'REFUSED: ' + '; '.join(r.reasons) if r.ill_determined else ''}")


if __name__ == "__main__":
    if "--tracks" in sys.argv:
        a = sys.argv[1:]
        opt = lambda k: a[a.index(k) + 1]
        w, h = (int(q) for q in opt("--image-size").split("x"))
        tracks = [q for q in a if q.endswith((".parquet", ".csv"))]
        real(tracks, (w, h), float(opt("--fps")), [float(q) for q in opt("--truth").split(",")])
        sys.exit(0)
    sets_arg = sys.argv[sys.argv.index("--sets") + 1] if "--sets" in sys.argv else None
    model = (sys.argv[sys.argv.index("--stride-model") + 1] if "--stride-model" in sys.argv
             else "table1")
    hsd = (sys.argv[sys.argv.index("--height-mean-sd") + 1] if "--height-mean-sd" in sys.argv
           else None)
    tsd = (sys.argv[sys.argv.index("--stride-mean-sd") + 1] if "--stride-mean-sd" in sys.argv
           else None)
    spreads = (sys.argv[sys.argv.index("--cue-spreads") + 1] if "--cue-spreads" in sys.argv
               else "model")
    args = [a for a in sys.argv[1:] if not a.startswith("--")
            and a not in (sets_arg, model, hsd, tsd, spreads)]
    n = int(args[0]) if args else 20
    s0 = int(args[1]) if len(args) > 1 else 0
    mix = "--mix" in sys.argv
    sets = CUE_SETS  # --sets height,gait+height: only these (cues joined by +)
    if sets_arg:
        sets = tuple(tuple(c.split("+")) for c in sets_arg.split(","))
    on = "--outliers" in sys.argv
    fu = "--frame-union" in sys.argv
    title = f"{n} scenes (seeds {s0}-{s0 + n - 1}), 20 "
    sd = HEIGHT_MEAN_SD_M if hsd is None else float(hsd)
    ssd = 0.0 if tsd is None else float(tsd)
    table(run(n, s0, mix, sets, on, fu, model, sd, ssd, spreads), title +
          "walkers" + (" + 4 bicycles + 4 dogs" if mix else "") + (", outlier rule on" if on
                                                                  else "")
          + (", frame union undone" if fu else "") + f", stride model {model}"
          + (f", crowd height +- {sd:g} m" if sd > 0 else ", crowd height held")
          + (f", crowd stride +- {ssd:g} m" if ssd > 0 else ", crowd stride held"))
