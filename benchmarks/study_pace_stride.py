"""The pace/stride study on real walkers (issue 20): one CSV row per judged track, its pace F
(Hz, steps per second), step length T (m per step) and ground speed (m/s), verdict, class and
source. Nothing here chooses a rule or threshold: every run uses the defaults (Table 1's walking
model, the paper's (13)-(15)) and the cameras the other benchmarks use.

Sources (each skipped when its data folder is absent):

- `casia`: CASIA-B side view, the 14 walking clips of `casia_b_090/` (subject, condition nm /
  bg / cl from the file name), through the online tracker as `rhythmjax run` does, with the
  GUESSED camera `eval_real_video.CASIA_CONFIG` (focal 400 px, h 0.85 m, tilt 2 deg, window
  1.92 s): pace is measured, step length and speed carry the guessed scale. One row per clip:
  its longest track (the walker).
- `pets`: PETS09-S2L1, the 19 people's annotated boxes through `rhythmjax rhythm` with the camera
  derived from the Tsai calibration (`eval_rhythm_boxes.pets`).
- `ucsd`: UCSD Ped2 Test002/004/006/010 (camera GUESSED, 30 fps, window 32/30 s). (a) The anomaly
  boxes linked into box tracks through `rhythmjax rhythm` (`eval_rhythm_boxes.ucsd`): class
  `bicycle`, except Test004's box track that starts before frame CART_BEFORE (the cart enters at
  frame 30, the cyclist late in the clip: SOURCE.md), class `cart`. (b) The online tracker's
  tracks (`eval_real_video.track`): a track on the anomaly boxes (`eval_real_video.score_ucsd`'s
  rule) is class `bicycle/cart`, every other one `walker` (presumed: Ped2 marks only the
  anomalies, so these may include groups and fragments).
- `dev`: the independent renderer's 18 clips (`../shared/data/dev`), every object's truth
  through `rhythmjax rhythm` twice (`eval_rhythm_boxes.dev`: the true foot point and the
  silhouette box), with the truth's kind, pace and stride beside it. Report only.

    python benchmarks/study_pace_stride.py [-o docs/data/pace_stride_real.csv]
        [--only casia --only pets ...]   (rows of the other sources already in -o are kept)

Data from `$RHYTHMJAX_DATA` (else ../shared/data/real), dev clips from `$RHYTHMJAX_DEV`.
About 4 min on 2 shared cores (200 s measured). The CSV is written atomically (temp file, then
rename).
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import sys
import tempfile
import time

import numpy as np


sys.path.insert(0, os.path.dirname(__file__))

import eval_real_video as erv  # noqa: E402
import eval_rhythm_boxes as erb  # noqa: E402

from rhythmjax.evaluation import datasets  # noqa: E402


SOURCES = ("casia", "pets", "ucsd", "dev")
COLUMNS = ("source", "clip", "track_id", "subject", "condition", "class", "label_basis",
           "variant", "camera", "verdict", "reason", "pace_hz", "step_m", "speed_mps",
           "n_samples", "true_pace_hz", "true_step_m", "true_speed_mps", "classifiable")
CONDITIONS = {"nm": "normal", "bg": "bag", "cl": "coat"}
CART_BEFORE = 60  # UCSD Test004: the box track starting before this frame is the cart
T0 = time.perf_counter()


def say(msg: str) -> None:
    print(f"[{time.perf_counter() - T0:6.0f} s] {msg}", flush=True)


def num(x) -> str:
    """A float cell: 4 decimals, empty when missing or not finite."""
    try:
        v = float(x)
    except (TypeError, ValueError):
        return ""
    return f"{v:.4f}" if math.isfinite(v) else ""


def row(source, clip, verdict: dict, **kw) -> dict:
    r = {k: "" for k in COLUMNS}
    r.update(source=source, clip=clip, track_id=str(verdict.get("track_id", "")),
             verdict=str(verdict.get("verdict", "")), reason=str(verdict.get("reason", "")),
             pace_hz=num(verdict.get("pace_hz")), step_m=num(verdict.get("stride_m")),
             speed_mps=num(verdict.get("speed_mps")), n_samples=str(verdict.get("n_samples", "")))
    r.update({k: (num(v) if k.startswith("true_") else str(v)) for k, v in kw.items()})
    return r


def verdict_rows(verdicts) -> list[dict]:
    """The tracker's verdict columns (dict of arrays) as one dict per track."""
    keys = list(verdicts)
    return [{k: verdicts[k][i] for k in keys} for i in range(len(verdicts["track_id"]))]


def casia() -> list[dict]:
    folder = datasets.DATA_ROOT / "casia_b_090"
    if not folder.is_dir():
        say("CASIA-B absent: skipped")
        return []
    out = []
    clips = [p for p in sorted(folder.glob("*.avi")) if "bkgrd" not in p.stem]
    for i, path in enumerate(clips):
        subject, cond, seq = path.stem.split("-")[:3]
        cfg = erv.video_config(erv.CASIA_CONFIG, path, 25.0)
        tracks, verdicts = erv.track(cfg, path, 25.0, None, max_objects=8)
        tid = np.asarray(tracks["track_id"])
        if not tid.size:
            say(f"CASIA {path.stem}: no track")
            continue
        ids, frames = np.unique(tid, return_counts=True)
        best = int(ids[int(np.argmax(frames))])
        v = next(r for r in verdict_rows(verdicts) if int(r["track_id"]) == best)
        out.append(row("casia", path.stem, v, subject=subject, condition=CONDITIONS[cond],
                       **{"class": "walker"}, label_basis="one walker per clip (SOURCE.md); "
                       "its longest track", variant="tracker", camera="guessed"))
        say(f"CASIA {i + 1}/{len(clips)} {path.stem}: {v['verdict']} pace "
            f"{float(v['pace_hz']):.2f} Hz step {float(v['stride_m']):.2f} m")
    return out


def pets(work: str) -> list[dict]:
    if datasets.pets_root() is None:
        say("PETS09-S2L1 absent: skipped")
        return []
    res = erb.pets(work)
    say(f"PETS: {res['pedestrian']} of {res['people']} people judged pedestrian")
    return [row("pets", "S2L1", v, **{"class": "walker"}, label_basis="annotated person",
                variant="annotated boxes", camera="Tsai calibration") for v in res["tracks"]]


def ucsd_box_class(clip: str) -> dict[str, str]:
    """Class of each linked anomaly box track, by the MOT id eval_rhythm_boxes.ucsd gives it."""
    _, b = datasets.ucsd_clip(clip)
    ids = erb.link(b)
    cls = {}
    for k in np.unique(ids):
        first = int(np.min(b["frame"][ids == k]))
        cls[str(int(k))] = "cart" if clip == "Test004" and first < CART_BEFORE else "bicycle"
    return cls


def ucsd(work: str) -> list[dict]:
    if datasets.ucsd_root() is None:
        say("UCSD Ped2 absent: skipped")
        return []
    out = []
    for clip, rows in erb.ucsd(work).items():
        cls = ucsd_box_class(clip)
        out += [row("ucsd", clip, v, **{"class": cls.get(str(v["track_id"]), "bicycle")},
                    label_basis="anomaly boxes (SOURCE.md: cyclists; the Test004 cart)",
                    variant="anomaly boxes", camera="guessed") for v in rows]
    say(f"UCSD anomaly box tracks: {len(out)}")
    conf = {"camera": erv.UCSD_CAMERA, "thresholds": {"window_s": 32 / 30}}
    for clip in datasets.UCSD_CLIPS:
        folder, boxes = datasets.ucsd_clip(clip)
        cfg = erv.video_config(conf, folder, 30.0)
        tracks, verdicts = erv.track(cfg, folder, 30.0)
        tid = np.asarray(tracks["track_id"])
        n = 0
        for v in verdict_rows(verdicts):
            one = {k: np.asarray(a)[tid == int(v["track_id"])] for k, a in tracks.items()}
            single = {k: np.asarray([v[k]]) for k in verdicts}
            on_box = bool(erv.score_ucsd(one, single, boxes)["anomaly"])
            out.append(row("ucsd", clip, v, **{"class": "bicycle/cart" if on_box else "walker"},
                           label_basis="on the anomaly boxes" if on_box else
                           "off the anomaly boxes (presumed walker)", variant="tracker",
                           camera="guessed"))
            n += 1
        say(f"UCSD {clip} tracker: {n} tracks")
    return out


def dev(work: str) -> list[dict]:
    if not os.path.isdir(erb.DEV):
        say("dev clips absent: skipped")
        return []
    kinds = {"pedestrian": "walker"}
    truth = {}
    index = json.load(open(os.path.join(erb.DEV, "index.json")))
    for c in index["clips"]:
        t = json.load(open(os.path.join(erb.DEV, c["truth"])))
        for o in t["objects"]:
            truth[(c["clip"], str(o["id"]))] = o
    out = []
    for clip, res in erb.dev(work).items():
        for variant in ("foot", "box"):
            for v in res[variant]:
                o = truth[(clip, str(v["track_id"]))]
                step = o.get("stride_m")
                out.append(row(
                    "dev", clip, v, **{"class": kinds.get(o["kind"], o["kind"])},
                    label_basis="truth JSON", camera="known (renderer)",
                    variant="true foot point" if variant == "foot" else "silhouette box",
                    true_pace_hz=o.get("pace_hz"), true_step_m=step,
                    true_speed_mps=o.get("speed_mps"), classifiable=int(o["classifiable"])))
    say(f"dev: {len(out)} rows (two variants per object)")
    return out


def write_atomic(path: str, rows: list[dict]) -> None:
    folder = os.path.dirname(os.path.abspath(path))
    os.makedirs(folder, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=folder, suffix=".csv.tmp")
    try:
        with os.fdopen(fd, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=COLUMNS)
            w.writeheader()
            w.writerows(rows)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes it 0600; give it an ordinary file's mode
        os.replace(tmp, path)
    except BaseException:
        os.unlink(tmp)
        raise


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("-o", "--output", default="docs/data/pace_stride_real.csv")
    p.add_argument("--only", action="append", choices=SOURCES,
                   help="run this source only (repeatable); the other sources' rows already in "
                   "the output are kept")
    a = p.parse_args(argv)
    todo = a.only or list(SOURCES)
    kept = []
    if a.only and os.path.exists(a.output):
        with open(a.output) as f:
            kept = [r for r in csv.DictReader(f) if r["source"] not in todo]
    rows = []
    with tempfile.TemporaryDirectory() as work:
        for src in todo:
            say(f"{src} ...")
            got = {"casia": casia, "pets": lambda: pets(work), "ucsd": lambda: ucsd(work),
                   "dev": lambda: dev(work)}[src]()
            rows += got
            # written after every source, so a long run leaves what it has
            write_atomic(a.output, kept + rows)
    order = {s: i for i, s in enumerate(SOURCES)}
    write_atomic(a.output, sorted(kept + rows, key=lambda r: order[r["source"]]))
    say(f"{len(kept) + len(rows)} rows -> {a.output}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
