"""Self-calibration from the counting tracker's tracks (issue 19; a measurement, nothing chosen).

`rhythmjax-fit selfcal` fits the tracks files of `rhythmjax run` (frame-difference foot
points). `rhythmjax count` writes tracks in the same format from background subtraction and
camera-sized patches, with the top rows of the pedestrians' own blobs (`v_top`), so all four
default cues apply (`--cues` to change). This runs the counting tracker and the fit:

- `pets`: PETS09-S2L1 (480x360, 7 fps) from a rough camera (f 500 px, h 5 m, tilt 20 deg),
  `--rounds` rounds, each counted with the previous round's camera; against Tsai's h 7.07 m,
  tilt 16.5 deg, a f 742 px (the footprints');
- `dev`: the 18 dev clips, each counted, their tracks pooled (one camera), with their true
  camera and with a rough one (f 700 px, h 1.5 m, tilt 10 deg); against the clips' camera;
- `rendered`: own videos, per seed a random camera and `--clips` clips of 5 walkers, a bicycle
  and a dog, counted with the true camera (in process) and pooled; the median errors.

    python benchmarks/selfcal_count_tracks.py [--data ../shared/data] [--work /tmp/scc] \\
        [--only pets,dev,rendered] [--rounds 4] [--seeds 3800-3807] [--clips 3] \\
        [--cues gait,speed,width,height] [--top-depth M]

`--top-depth` is `rhythmjax-fit selfcal --top-depth` for every fit; `--cues ...,slant` adds the
head columns count writes (`u_top`). Counted tracks are kept in `--work` and reused (tracks
counted before `u_top` existed lack it: use a fresh `--work` for the slant). Results in
docs/selfcal.md, "From the counting tracker's tracks", "Count's top rows and the top row's
depth" and "Heads over feet".
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path


sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

CUES = ("gait", "speed", "width", "height")  # the command's default cues (`--cues` to change)


def counted(video: Path, config: Path, out: Path, fps: float) -> Path | None:
    """out/tracks.parquet of `rhythmjax count` on `video` (made when absent; None on failure)."""
    t = out / "tracks.parquet"
    if not t.exists():
        done = subprocess.run(["rhythmjax", "count", str(video), "-c", str(config), "--fps",
                               str(fps), "--no-report", "--no-camera-check", "-q", "-o",
                               str(out)], check=False, capture_output=True, text=True)
        if done.returncode:
            print(f"{video.name}: rhythmjax count exited {done.returncode}: "
                  f"{done.stderr.strip()[-300:]}", flush=True)
    return t if t.exists() else None


def fit_line(name: str, paths: list[Path], size, fps: float, truth, fit_kw: dict) -> dict | None:
    """Fit the pooled tracks (`fit_selfcal(cfg, batch, **fit_kw)`: cues, top_depth_m); print
    one line; the fitted values (None without tracks or a camera; an ill-determined fit is
    printed as refused and its values still returned, so the next round can count with them,
    as the video command's rounds do)."""
    import selfcal_real as sr

    from fit.selfcal import fit_selfcal

    if not paths:
        print(f"{name}: no tracks", flush=True)
        return None
    cfg, batch = sr.pooled_batch(paths, size, fps)
    r = fit_selfcal(cfg, batch, **fit_kw)
    if r.camera is None or r.ill_determined:
        print(f"{name}: {r.n_walkers} walkers of {r.n_tracks} tracks; refused: "
              f"{'; '.join(r.reasons)}", flush=True)
        return None if r.camera is None else r.values
    v, se = r.values, r.se
    print(f"{name}: {r.n_walkers} walkers of {r.n_tracks} tracks; h {v['h']:.2f} +- "
          f"{se['h']:.2f} m ({100 * (v['h'] / truth[0] - 1):+.1f} %), tilt {v['theta']:.1f} +- "
          f"{se['theta']:.1f} deg ({v['theta'] - truth[1]:+.1f}), a f {v['af']:.0f} +- "
          f"{se['af']:.0f} px (truth {truth[0]} m, {truth[1]} deg, {truth[2]} px)", flush=True)
    return v


def pets(data: Path, work: Path, rounds: int, fit_kw: dict) -> None:
    import selfcal_real as sr

    video = data / "real" / "pets2009_s2l1" / "video" / "vtest_480x360.avi"
    if not video.exists():
        print("PETS09 absent: skipped")
        return
    size, fps, truth = (480, 360), 7.0, (7.07, 16.5, 742)
    cam = sr.camera_json(work / "pets_cam0.json", size, fps, 500, 5, 20)
    for k in range(1, rounds + 1):
        t = counted(video, cam, work / f"pets_round{k}", fps)
        v = fit_line(f"PETS round {k}", [t] if t else [], size, fps, truth, fit_kw)
        if v is None:
            return
        cam = sr.camera_json(work / f"pets_cam{k}.json", size, fps, v["af"], v["h"], v["theta"])


def dev(data: Path, work: Path, fit_kw: dict) -> None:
    import selfcal_real as sr

    clips = sorted((data / "dev").glob("dev_*.avi"))
    if not clips:
        print("dev clips absent: skipped")
        return
    cams = {json.dumps(json.loads(p.with_suffix(".json").read_text())["camera"],
                       sort_keys=True) for p in clips}
    if len(cams) != 1:
        raise SystemExit(f"the dev clips have {len(cams)} cameras: not pooled")
    c = json.loads(cams.pop())
    size, fps = (c["width_px"], c["height_px"]), 15.0
    truth = (c["h_m"], c["theta_deg"], c["f_px"])
    for tag, cam in (("true", (c["f_px"], c["h_m"], c["theta_deg"])), ("rough", (700, 1.5, 10))):
        cfg = sr.camera_json(work / f"dev_{tag}.json", size, fps, *cam)
        paths = [counted(v, cfg, work / f"dev_{tag}" / v.stem, fps) for v in clips]
        fit_line(f"dev clips ({len(clips)}, pooled), counted with the {tag} camera",
                 [p for p in paths if p], size, fps, truth, fit_kw)


def rendered(work: Path, seeds: list[int], clips: int, fit_kw: dict) -> None:
    """Own rendered videos: per seed a random camera (`fit.selfcal_data.random_camera`), `clips`
    scenes of 5 walkers, a bicycle and a dog (`rhythmjax.sim.scene.random_spec`), each counted
    with the true camera (in process), their tracks pooled and fitted; then the median errors."""
    import numpy as np

    from fit.selfcal_data import camera_values, random_camera
    from rhythmjax.count import count_frames
    from rhythmjax.io import write_table
    from rhythmjax.model.params import Config
    from rhythmjax.sim.placement import PlacementError
    from rhythmjax.sim.scene import random_spec, render_scene

    errs = []
    for seed in seeds:
        rng = np.random.default_rng(seed)
        paths = []
        while not paths:
            cam = random_camera(rng)
            try:
                specs = [random_spec(seed * 100 + k, camera=cam) for k in range(clips)]
            except PlacementError:
                continue  # a camera that sees too little of the ground: drawn again
            for k, spec in enumerate(specs):
                t = work / f"rendered_{seed}" / f"clip{k}" / "tracks.parquet"
                if not t.exists():
                    sc = render_scene(seed * 100 + k, spec)
                    res = count_frames(Config(camera=cam), ((i, i / sc.fps, g) for i, g in
                                                            enumerate(sc.frames)))
                    t.parent.mkdir(parents=True, exist_ok=True)
                    write_table(t, res.tracks, list(res.tracks))
                paths.append(t)
        c = camera_values(cam)
        size = (int(cam.image_width), int(cam.image_height))
        v = fit_line(f"seed {seed} ({size[0]}x{size[1]})", paths, size, float(cam.fps),
                     (round(c["h"], 2), round(c["theta"], 1), round(c["af"])), fit_kw)
        if v is not None:
            errs.append((abs(v["h"] / c["h"] - 1) * 100, abs(v["theta"] - c["theta"]),
                         abs(v["af"] / c["af"] - 1) * 100))
    if errs:
        e = np.median(np.asarray(errs), axis=0)
        print(f"rendered, {len(errs)} of {len(seeds)} fitted: median |h err| {e[0]:.1f} %, "
              f"|tilt err| {e[1]:.2f} deg, |a f err| {e[2]:.1f} %", flush=True)


def main(argv=None) -> int:
    a = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    a.add_argument("--data", default=os.path.join(os.path.dirname(__file__), "..", "..",
                                                  "shared", "data"))
    a.add_argument("--work", default=os.path.join(tempfile.gettempdir(), "selfcal_count"))
    a.add_argument("--only", default="pets,dev")
    a.add_argument("--rounds", type=int, default=4)
    a.add_argument("--cues", default=",".join(CUES))
    a.add_argument("--top-depth", type=float, default=0.0, help="m (fit.selfcal_height)")
    a.add_argument("--cue-spreads", default="model", choices=("model", "data"))
    a.add_argument("--seeds", default="3800-3807", help="rendered: first-last")
    a.add_argument("--clips", type=int, default=3, help="rendered: clips per camera")
    args = a.parse_args(argv)
    fit_kw = {"cues": tuple(args.cues.split(",")), "top_depth_m": args.top_depth,
              "cue_spreads": args.cue_spreads}
    lo, _, hi = args.seeds.partition("-")
    data, work = Path(args.data), Path(args.work)
    work.mkdir(parents=True, exist_ok=True)
    for name in args.only.split(","):
        if name == "pets":
            pets(data, work, args.rounds, fit_kw)
        elif name == "dev":
            dev(data, work, fit_kw)
        elif name == "rendered":
            rendered(work, list(range(int(lo), int(hi or lo) + 1)), args.clips, fit_kw)
        else:
            raise SystemExit(f"unknown part {name!r} (pets, dev, rendered)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
