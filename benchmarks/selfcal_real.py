"""Self-calibration (issue 19, `rhythmjax-fit selfcal`) on real video: a small derived table.

For each source the videos are tracked with the project's `rhythmjax run` (a rough camera: the
tracker needs one), the tracks files of one camera are pooled (track ids prefixed by the clip)
and `fit.selfcal.fit_selfcal` (the command's function) fits h, tilt and a f with the cue sets
gait+speed+width (the default), gait+speed, gait, height (foot-head from the tracker's top rows,
the classical approach), gait+height and gait+speed+width+height. Rows:

- `pets`: PETS09-S2L1 (`real/pets2009_s2l1`, 480x360 at 7 fps) tracked with a rough camera
  (f 500 px, h 5 m, tilt 20 deg), then tracked again with the camera the default cues gave
  and with the one gait+speed+width+height gave (the tracker's top rows need a camera that
  sizes its detection window near the people's size). Truth: its Tsai calibration, h 7.07 m,
  tilt 16.5 deg, a f 742 px (`rhythmjax-fit camera` on its footprints).
- `dev`: the 18 clips of `dev/` (512x512 at 15 fps, one camera), pooled, tracked with a rough
  camera (f 700 px, h 1.5 m, tilt 10 deg) and with their true camera (the truth of each clip's
  JSON: f 500 px, h 1 m, tilt 15 deg), an upper bound for the tracker.
- `casia`: CASIA-B's 14 side-view walks (`real/casia_b_090`, 320x240 at 25 fps), pooled, tracked
  with the guessed camera of the pace/stride study (focal 400 px, h 0.85 m, tilt 2 deg; a
  rhythm window of 1.92 s, 48 samples: the clips are 106 frames).
  No truth camera is published: estimate and SE only.

    python benchmarks/selfcal_real.py [--data ../shared/data] [--work /tmp/selfcal_real]
        [-o docs/data/selfcal_real.csv] [--only pets,dev,casia] [--outliers] [--observed-only]
        [--frame-union] [--stride-model walk-ratio] [--height-mean-sd M] [--stride-mean-sd M]
        [--cue-spreads data]
        [--sets gait+speed+width+height,...]

`--outliers` turns on the fit's foot-point outlier rule (`fit.selfcal_outliers`, off by default)
to compare; give it its own `--work` for the re-tracked PETS rows (tracked with the fitted camera).
`--observed-only` likewise turns on the observed-rows rule (`fit.selfcal_rows`, the command's
`--observed-only`, off by default: only the rows whose tracker state is observe keep their foot
point, width and top row). `--frame-union` undoes the frame-difference union in the foot
points, widths and top rows (`fit.selfcal_union`, the command's `--frame-union`, off by default).
`--stride-model walk-ratio` gives the gait cue a stride that follows the pace
(`fit.selfcal_gait.expected_stride`, the command's `--stride-model`). `--height-mean-sd M` is the
spread of the walkers' mean height about 1.70 m (the command's `--height-mean-sd`; 0 holds it),
`--stride-mean-sd M` that of their mean stride about the walking model's (the command's; 0 holds
it).

Tracks are made under `--work` (WORK/SOURCE/CLIP/tracks.parquet) unless already there, so a
rerun only fits; the videos are read where they lie and nothing of them is copied into the
repository. The CSV holds only derived numbers: estimates with standard errors, the truth, the
walkers used of the tracks pooled, and the command's refusal reason (empty when it would write
the config).
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np


ROOT = Path(__file__).resolve().parents[1]
CUE_SETS = (("gait", "speed", "width"), ("gait", "speed"), ("gait",), ("height",),
            ("gait", "height"), ("gait", "speed", "width", "height"))
FIELDS = ("source", "tracking camera", "cues", "tracks", "walkers", "h_m", "h_se_m", "h_truth_m",
          "tilt_deg", "tilt_se_deg", "tilt_truth_deg", "af_px", "af_se_px", "af_truth_px",
          "refused")
PETS_TRUTH = (7.07, 16.5, 742.0)
OUTLIERS = [False]  # the outlier rule of the fits (`--outliers` sets it on)
OBSERVED = [False]  # the observed-rows rule of the fits (`--observed-only` sets it on)
SETS = [CUE_SETS]  # the cue sets fitted (`--sets A+B,C` chooses)
UNION = [False]  # the frame-union correction of the fits (`--frame-union` sets it on)
STRIDE = ["table1"]  # the gait cue's stride model (`--stride-model`)
SPREADS = ["model"]  # the gait's and heights' spreads (`--cue-spreads`)
HEIGHT_MEAN_SD = [None]  # the crowd's mean height's prior spread (m; `--height-mean-sd`;
# None: fit_selfcal's default)
STRIDE_MEAN_SD = [None]  # the crowd's mean stride's prior spread (m; `--stride-mean-sd`)


def say(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


def cli(*args: str) -> None:
    """Run a project command (the venv's console scripts beside this Python)."""
    exe = Path(sys.executable).parent / args[0]
    subprocess.run([str(exe) if exe.exists() else args[0], *args[1:]], check=True,
                   stdout=subprocess.DEVNULL)


def camera_json(path: Path, size: tuple[int, int], fps: float, focal: float, h: float,
                tilt: float, window_s: float | None = None) -> Path:
    if not path.exists():
        path.parent.mkdir(parents=True, exist_ok=True)
        cli("rhythmjax", "camera", "--image-size", f"{size[0]}x{size[1]}", "--fps", str(fps),
            "--focal-px", str(focal), "--height", str(h), "--tilt", str(tilt), "-o", str(path),
            *(("--window-s", str(window_s)) if window_s else ()))
    return path


def tracked(video: Path, config: Path, out: Path, *extra: str) -> Path | None:
    """out/tracks.parquet of `rhythmjax run` on `video` (made when absent; None on failure)."""
    t = out / "tracks.parquet"
    if not t.exists():
        say(f"tracking {video.name} -> {out}")
        try:
            cli("rhythmjax", "run", str(video), "-c", str(config), "--no-overlay",
                "--no-camera-check", *extra, "-o", str(out))
        except subprocess.CalledProcessError as e:
            say(f"{video.name}: rhythmjax run exited {e.returncode}")
    return t if t.exists() else None


def pooled_batch(paths: list[Path], size: tuple[int, int], fps: float, window_s=None):
    """(start Config, TrackBatch) of tracks files of one camera, ids prefixed by the clip."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    from rhythmjax.io import config_or_bad_input, read_tracks

    parts = []
    for p in paths:
        tab = pq.read_table(p)
        clip = p.parent.name
        col = tab.schema.get_field_index("track_id")
        ids = [f"{clip}:{i}" for i in tab.column(col).to_pylist()]
        parts.append(tab.set_column(col, "track_id", pa.array(ids, pa.string())))
    # what the command holds of a config giving only the image size and fps
    cam = {"image_width_px": size[0], "image_height_px": size[1], "fps": fps,
           "uc_px": size[0] / 2, "vc_px": size[1] / 2}
    thr = {"range_min_m": 3.0, "range_max_m": 20.0, **({"window_s": window_s} if window_s
                                                       else {})}
    cfg = config_or_bad_input({"camera": cam, "thresholds": thr}, "start")
    with tempfile.TemporaryDirectory() as d:
        f = Path(d) / "pooled.parquet"
        pq.write_table(pa.concat_tables(parts, promote_options="default"), f)
        tr = read_tracks(f, fps=fps)
    if OBSERVED[0]:
        from fit.selfcal_rows import observed_rows

        tr, n_left = observed_rows(tr)
        say(f"{n_left} foot points of rows not observed left out (of "
            f"{int(np.sum(np.isfinite(tr.u))) + n_left})")
    batch = tr.to_batch(max_gap_frames=5, min_len=cfg.thresholds.n, fps=fps)
    return cfg, batch


def fit_rows(source: str, how: str, paths: list[Path], size, fps, truth,
             window_s=None) -> tuple[list, object]:
    """One row per cue set; also the fits by cue set (for re-tracking)."""
    from fit.selfcal import fit_selfcal

    rows, fits = [], {}
    if not paths:
        return [{"source": source, "tracking camera": how, "refused": "no tracks"}], {}
    cfg, batch = pooled_batch(paths, size, fps, window_s)
    for cues in SETS[0]:
        hsd = {} if HEIGHT_MEAN_SD[0] is None else {"height_mean_sd": HEIGHT_MEAN_SD[0]}
        if STRIDE_MEAN_SD[0] is not None:
            hsd["stride_mean_sd"] = STRIDE_MEAN_SD[0]
        r = fit_selfcal(cfg, batch, cues=cues, outliers=OUTLIERS[0], frame_union=UNION[0],
                        stride_model=STRIDE[0], cue_spreads=SPREADS[0], **hsd)
        fits[cues] = r
        v, se = (r.values, r.se) if r.camera is not None else ({}, {})
        get = lambda d, k: f"{d[k]:.5g}" if k in d and math.isfinite(d[k]) else ""
        rows.append({"source": source, "tracking camera": how, "cues": "+".join(cues),
                     "tracks": r.n_tracks, "walkers": r.n_walkers,
                     "h_m": get(v, "h"), "h_se_m": get(se, "h"), "h_truth_m": truth[0],
                     "tilt_deg": get(v, "theta"), "tilt_se_deg": get(se, "theta"),
                     "tilt_truth_deg": truth[1], "af_px": get(v, "af"),
                     "af_se_px": get(se, "af"), "af_truth_px": truth[2],
                     "refused": "; ".join(r.reasons) if r.ill_determined else ""})
        say(f"{source} ({how}) {'+'.join(cues)}: " + (
            f"h {v['h']:.2f} +- {se['h']:.2f}, tilt {v['theta']:.1f} +- {se['theta']:.1f}, "
            f"af {v['af']:.0f} +- {se['af']:.0f}" if v else "no camera")
            + f"; {r.n_walkers} of {r.n_tracks}; {'; '.join(r.reasons)}")
    return rows, fits


def pets(data: Path, work: Path) -> list[dict]:
    d = data / "real" / "pets2009_s2l1"
    video, size, fps = d / "video" / "vtest_480x360.avi", (480, 360), 7.0
    if not video.exists():
        say("PETS09-S2L1 absent: skipped")
        return []
    run = ("--fps", "7", "--max-objects", "24")
    rough = camera_json(work / "pets_rough.json", size, fps, 500, 5, 20)
    t = tracked(video, rough, work / "pets" / "rough", *run)
    rows, fits = fit_rows("PETS09-S2L1", "rough (f 500 px, h 5 m, tilt 20 deg)",
                          [t] if t else [], size, fps, PETS_TRUTH)
    # tracked again with the camera of the default cues, and with that of all four
    for cues, tag, name in ((CUE_SETS[0], "retracked", "pets_selfcal.json"),
                            (CUE_SETS[-1], "retracked_height", "pets_selfcal_height.json")):
        r = fits.get(cues)
        if r is None or r.camera is None:
            continue
        from rhythmjax.model.params import Config, config_to_dict

        again = work / name
        if not again.exists():
            c = config_to_dict(Config(camera=r.camera))
            again.write_text(json.dumps({"camera": c["camera"]}, indent=2) + "\n")
        t2 = tracked(video, again, work / "pets" / tag, *run)
        rows += fit_rows("PETS09-S2L1", f"self-calibrated ({'+'.join(cues)}) from the rough "
                         "tracks", [t2] if t2 else [], size, fps, PETS_TRUTH)[0]
    return rows


def dev(data: Path, work: Path) -> list[dict]:
    clips = sorted((data / "dev").glob("dev_*.avi"))
    if not clips:
        say("dev clips absent: skipped")
        return []
    cams = {json.dumps({k: c[k] for k in ("width_px", "height_px", "f_px", "h_m", "theta_deg")},
                       sort_keys=True)
            for c in (json.loads(p.with_suffix(".json").read_text())["camera"] for p in clips)}
    if len(cams) != 1:
        raise SystemExit(f"the dev clips have {len(cams)} cameras: not pooled")
    c = json.loads(cams.pop())
    size, fps = (c["width_px"], c["height_px"]), 15.0
    truth = (c["h_m"], c["theta_deg"], c["f_px"])
    rows = []
    for tag, how, cam in (("rough", "rough (f 700 px, h 1.5 m, tilt 10 deg)", (700, 1.5, 10)),
                          ("true", "the true camera", (c["f_px"], c["h_m"], c["theta_deg"]))):
        cfg = camera_json(work / f"dev_{tag}.json", size, fps, *cam)
        paths = [tracked(v, cfg, work / f"dev_{tag}" / v.stem) for v in clips]
        rows += fit_rows("dev clips (18, pooled)", how, [p for p in paths if p], size, fps,
                         truth)[0]
    return rows


def casia(data: Path, work: Path) -> list[dict]:
    clips = sorted(p for p in (data / "real" / "casia_b_090").glob("*-090.avi")
                   if "bkgrd" not in p.name)
    if not clips:
        say("CASIA-B absent: skipped")
        return []
    size, fps = (320, 240), 25.0
    cfg = camera_json(work / "casia.json", size, fps, 400, 0.85, 2, window_s=1.92)
    paths = [tracked(v, cfg, work / "casia" / v.stem, "--fps", "25") for v in clips]
    return fit_rows(f"CASIA-B 090 ({len(clips)} walks, pooled)",
                    "guessed (f 400 px, h 0.85 m, tilt 2 deg)", [p for p in paths if p], size,
                    fps, ("", "", ""), window_s=1.92)[0]


def main(argv=None) -> int:
    a = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    a.add_argument("--data", default=str(ROOT.parent / "shared" / "data"))
    a.add_argument("--work", default=os.path.join(tempfile.gettempdir(), "selfcal_real"))
    a.add_argument("-o", "--output", default=str(ROOT / "docs" / "data" / "selfcal_real.csv"))
    a.add_argument("--only", default="pets,dev,casia")
    a.add_argument("--outliers", action="store_true")
    a.add_argument("--observed-only", action="store_true")
    a.add_argument("--frame-union", action="store_true")
    a.add_argument("--stride-model", default="table1", choices=("table1", "walk-ratio"))
    a.add_argument("--cue-spreads", default="model", choices=("model", "data"))
    a.add_argument("--height-mean-sd", type=float,
                   help="the command's --height-mean-sd (default the command's; 0 holds it)")
    a.add_argument("--stride-mean-sd", type=float,
                   help="the command's --stride-mean-sd (default the command's; 0 holds it)")
    a.add_argument("--sets", help="cue sets to fit, e.g. gait+speed+width+height (default all)")
    args = a.parse_args(argv)
    OUTLIERS[0] = args.outliers
    OBSERVED[0] = args.observed_only
    UNION[0] = args.frame_union
    STRIDE[0] = args.stride_model
    SPREADS[0] = args.cue_spreads
    HEIGHT_MEAN_SD[0] = args.height_mean_sd
    STRIDE_MEAN_SD[0] = args.stride_mean_sd
    if args.sets:
        SETS[0] = tuple(tuple(c.split("+")) for c in args.sets.split(","))
    data, work = Path(args.data), Path(args.work)
    work.mkdir(parents=True, exist_ok=True)
    rows = []
    for name in args.only.split(","):
        rows += {"pets": pets, "dev": dev, "casia": casia}[name](data, work)
    if not rows:
        say(f"no data under {data}: nothing written")
        return 1
    out = Path(args.output)
    tmp = out.with_suffix(".tmp")
    with open(tmp, "w", newline="") as f:
        w = csv.DictWriter(f, FIELDS)
        w.writeheader()
        w.writerows({k: r.get(k, "") for k in FIELDS} for r in rows)
    os.replace(tmp, out)
    say(f"wrote {out} ({len(rows)} rows)")
    return 0


if __name__ == "__main__":
    np.seterr(all="ignore")
    sys.exit(main())
