"""How the tracker's foot points and top rows differ from the truth, and what that does to the tilt
self-calibration fits (issue 19: PETS09-S2L1's tilt 11.6-12.3 deg against Tsai's 16.5).

**Measure** (`measure`): each tracker row with a foot point is matched to the reference point of
its frame nearest to it (within 0.3 of the reference's pixel height); per row the offsets
tracker - reference of the foot row dv, the foot column du and the top row dtop (px; + = lower /
to the right), tabulated against the reference's image row v, its pixel height (foot row - top
row) and its image velocity (px per frame, from the same object's previous frame). References:

- ``pets``: Milan's annotated boxes (`rhythmjax.evaluation.datasets.pets_boxes`: bottom centre,
  top row) against a PETS tracks file (`benchmarks/selfcal_real.py`'s WORK/pets/rough);
- ``dev``: the dev clips' truth (DEV/*_truth.csv foot points; the head row is the point at the
  object's `height_m` above its foot, through the clip's camera of (3)) against the tracks
  `benchmarks/selfcal_real.py` made with their true camera (WORK/dev_true/CLIP); report only;
- ``own``: rendered scenes of `rhythmjax.sim.scene` (6 walkers, 150 frames, a camera at 4 m,
  tilt 20 deg, a f 700 px, 640x480, at 15 and at 7 fps), tracked by the library's
  `OnlineTracker` with their camera; truth from the scene (foot point, head row as
  `benchmarks/eval_top_row.py`).

Beside each table: the offsets the **frame-difference union** predicts (`rhythmjax.vision.detect`:
the motion image is |I(k) - I(k-1)|, so its extent is the union of the object at frames k-1 and
k): du = -du1 / 2 (the extent's centre lags half a frame), dv = max(0, -dv1) (a receding walker's
lowest row is the previous frame's), dtop = -max(0, dtop1) (an approaching walker's top row is
the previous frame's head), with du1, dv1, dtop1 the reference's displacement from frame k-1 to k.

**Decompose** (`decompose`): which part of the PETS tracker's offsets moves the fitted tilt.
The matched rows of the PETS tracks get the annotated feet plus one part of the tracker's
offsets (none, dv only, du only, the union's, the rest, shuffled over rows, each track's median,
the rest about it, clipped at 3 MADs, on observe rows only); unmatched rows lose their foot
point, width and top row; each is self-calibrated (`fit.selfcal.fit_selfcal`, `--cues`, the
start of benchmarks/selfcal_real.py), and the used walkers' strides, relative speed changes and
heights through the camera of (3) nearest to Tsai's are printed. The simulation and the
correction's ON/OFF: benchmarks/study_foot_bias_fit.py.

    python benchmarks/study_foot_bias.py measure [--pets T] [--dev-work DIR] [--own-scenes N]
    python benchmarks/study_foot_bias.py decompose [--pets T] [--cues gait+speed+width+height]
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np


sys.path.insert(0, str(Path(__file__).parent))

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT.parent / "shared" / "data"
MATCH_FRACTION = 0.3  # a reference matches within this fraction of its pixel height


def mad(a) -> float:
    a = np.asarray(a, float)
    a = a[np.isfinite(a)]
    return 1.4826 * float(np.median(np.abs(a - np.median(a)))) if a.size else math.nan


def displacement(obj, frame, x) -> np.ndarray:
    """Per reference row, x at this frame minus x at the previous frame of the same object
    (NaN where that frame is absent)."""
    key = {(o, f): i for i, (o, f) in enumerate(zip(obj, frame, strict=True))}
    prev = np.array([key.get((o, f - 1), -1) for o, f in zip(obj, frame, strict=True)])
    return np.where(prev >= 0, x - x[np.maximum(prev, 0)], np.nan)


def match(tr: dict, ref: dict) -> dict:
    """Tracker rows (frame, u, v, v_top; optional state) matched to reference rows (obj, frame,
    u, v, top, px height): per matched row the offsets and the union model's predictions."""
    by_frame: dict[int, np.ndarray] = {}
    for i, f in enumerate(ref["frame"]):
        by_frame.setdefault(int(f), []).append(i)
    j = np.full(len(tr["frame"]), -1)
    for i, (f, u, v) in enumerate(zip(tr["frame"], tr["u"], tr["v"], strict=True)):
        k = np.asarray(by_frame.get(int(f), []), int)
        if k.size == 0 or not (np.isfinite(u) and np.isfinite(v)):
            continue
        d = np.hypot(ref["u"][k] - u, ref["v"][k] - v)
        q = int(np.nanargmin(d)) if np.isfinite(d).any() else -1
        if q >= 0 and d[q] < MATCH_FRACTION * ref["hpx"][k[q]]:
            j[i] = k[q]
    m = j >= 0
    r = j[m]
    d1 = {c: displacement(ref["obj"], ref["frame"], ref[c]) for c in ("u", "v", "top")}
    top = tr.get("v_top", np.full(len(tr["frame"]), np.nan))
    return {"dv": tr["v"][m] - ref["v"][r], "du": tr["u"][m] - ref["u"][r],
            "dtop": top[m] - ref["top"][r], "v": ref["v"][r], "hpx": ref["hpx"][r],
            "vel_v": d1["v"][r], "vel_u": d1["u"][r],
            "pred_dv": np.maximum(0.0, -d1["v"][r]), "pred_du": -0.5 * d1["u"][r],
            "pred_dtop": -np.maximum(0.0, d1["top"][r]),
            "state": np.asarray(tr["state"])[m] if "state" in tr else None,
            "n_rows": int(np.sum(np.isfinite(tr["u"]) & np.isfinite(tr["v"]))),
            "n_matched": int(m.sum()), "row": np.flatnonzero(m)}


def report(name: str, o: dict, height_px: float) -> None:
    """Markdown tables of one source's offsets (module doc)."""
    med = lambda a: float(np.nanmedian(a)) if np.isfinite(a).any() else math.nan  # noqa: E731
    print(f"\n### {name}: {o['n_matched']} of {o['n_rows']} tracker foot points matched\n")
    print(f"all: dv median {med(o['dv']):+.2f} px (1.4826 MAD {mad(o['dv']):.2f}), du "
          f"{med(o['du']):+.2f} (MAD {mad(o['du']):.2f}), dtop {med(o['dtop']):+.2f} (MAD "
          f"{mad(o['dtop']):.2f}; {np.isfinite(o['dtop']).sum()} rows with a top row), "
          f"dv / px height {med(o['dv'] / o['hpx']):+.4f}")
    head = ("| rows | n | dv median (px) | dv MAD | dv / px height | du median | dtop median "
            "| union: dv | du | dtop |")
    sep = "|---" * 10 + "|"

    def rows(label, key, edges, fmt):
        print(f"\nby {label}\n\n{head}\n{sep}")
        x = o[key]
        for lo, hi in zip(edges[:-1], edges[1:], strict=True):
            b = (x >= lo) & (x < hi)
            if b.sum() < 10:
                continue
            print(f"| {lo:{fmt}} to {hi:{fmt}} | {b.sum()} | {med(o['dv'][b]):+.2f} | "
                  f"{mad(o['dv'][b]):.2f} | {med(o['dv'][b] / o['hpx'][b]):+.4f} | "
                  f"{med(o['du'][b]):+.2f} | {med(o['dtop'][b]):+.2f} | "
                  f"{med(o['pred_dv'][b]):+.2f} | {med(o['pred_du'][b]):+.2f} | "
                  f"{med(o['pred_dtop'][b]):+.2f} |")

    rows("foot row v (px)", "v", np.linspace(0, height_px, 7).round(), ".0f")
    rows("pixel height (px; reference foot row - top row)", "hpx",
         np.unique(np.r_[np.percentile(o["hpx"], [0, 20, 40, 60, 80]), o["hpx"].max() + 1].round()),
         ".0f")
    rows("image velocity of the foot row (px/frame; - = receding)", "vel_v",
         [-99, -1.5, -0.5, 0.5, 1.5, 99], "+.1f")
    rows("image velocity of the foot column (px/frame)", "vel_u", [-99, -3, -1, 1, 3, 99], "+.0f")
    if o["state"] is not None:
        for s in np.unique(o["state"].astype(str)):
            b = o["state"].astype(str) == s
            print(f"state {s}: {b.sum()} rows, dv median {med(o['dv'][b]):+.2f} (MAD "
                  f"{mad(o['dv'][b]):.2f}), du MAD {mad(o['du'][b]):.2f}")
    # least squares: each offset on a constant, the px height and the union's prediction
    for off, pred in (("dv", "pred_dv"), ("du", "pred_du"), ("dtop", "pred_dtop")):
        ok = np.isfinite(o[off]) & np.isfinite(o[pred]) & (np.abs(o[off]) < 0.5 * o["hpx"])
        if ok.sum() < 20:
            continue
        A = np.c_[np.ones(ok.sum()), o["hpx"][ok] / 100.0, o[pred][ok]]
        c = np.linalg.lstsq(A, o[off][ok], rcond=None)[0]
        res = o[off][ok] - A @ c
        print(f"{off} = {c[0]:+.2f} px {c[1]:+.2f} px per 100 px of height {c[2]:+.2f} x the "
              f"union's ({ok.sum()} rows; MAD {mad(o[off][ok]):.2f} -> {mad(res):.2f} px)")


def tracks_cols(path: Path, frame_shift: int = 0) -> dict:
    """A tracks file's columns as numpy (frame shifted by `frame_shift`)."""
    import pyarrow.parquet as pq

    tab = pq.read_table(path)
    c = {k: tab.column(k).to_numpy(zero_copy_only=False) for k in tab.column_names}
    for k in ("u", "v", "v_top"):
        if k in c:
            c[k] = np.asarray(c[k], np.float64)
    c["frame"] = np.asarray(c["frame"], np.int64) + frame_shift
    return c


def pets_ref() -> dict:
    from rhythmjax.evaluation.datasets import pets_boxes

    b = pets_boxes()
    return {"obj": b["id"], "frame": b["frame"], "u": b["foot_u"], "v": b["foot_v"],
            "top": b["bb_top"], "hpx": b["bb_height"]}


def dev_pairs(work: Path) -> list[tuple[dict, dict]]:
    """(tracks, truth reference) per dev clip with tracks under `work`."""
    import csv

    from rhythmjax.model.camera_np import project_3d
    from rhythmjax.model.params import Camera

    out = []
    for js in sorted((DATA / "dev").glob("dev_*.json")):
        t = work / js.stem / "tracks.parquet"
        if not t.exists():
            continue
        meta = json.loads(js.read_text())
        c = meta["camera"]
        cam = Camera(f=c["f_m"], h=c["h_m"], theta=c["theta_rad"], a=c["a_px_per_m"],
                     b=c["b_px_per_m"], uc=c["uc_px"], vc=c["vc_px"], fps=meta["fps"],
                     image_width=c["width_px"], image_height=c["height_px"])
        rows = list(csv.DictReader(open(js.with_name(js.stem + "_truth.csv"))))
        rows = [r for r in rows if r["in_image"] == "1" and r["label"] == "pedestrian"]
        if not rows:
            continue
        col = lambda k, f=float, rows=rows: np.array([f(r[k]) for r in rows])  # noqa: E731
        obj, x, y = col("track_id", int), col("x"), col("y")
        H = np.array([meta["objects"][i].get("height_m", np.nan) for i in obj])
        top = np.asarray(project_3d(cam, x, y, H)[1])
        ref = {"obj": obj, "frame": col("frame", int), "u": col("u"), "v": col("v"),
               "top": top, "hpx": col("v") - top}
        out.append((tracks_cols(t), ref))
    return out


def own_pair(seed: int, fps: float, walkers: int = 6, seconds: float = 10.0
             ) -> tuple[dict, dict]:
    """(tracks, truth reference) of one rendered scene of walkers (module doc)."""
    from eval_top_row import CAMERA as C

    from rhythmjax.model.camera_np import project_3d
    from rhythmjax.model.params import Camera, Config
    from rhythmjax.sim.scene import random_spec, render_scene
    from rhythmjax.track.tracker import OnlineTracker

    cam = Camera(f=C.f, h=C.h, theta=C.theta, a=C.a, b=C.b, uc=C.uc, vc=C.vc, fps=fps,
                 image_width=C.image_width, image_height=C.image_height)
    n = int(round(seconds * fps))
    spec = random_spec(seed, n_walkers=walkers, n_bicycles=0, n_dogs=0, n_frames=n, camera=cam,
                       min_life=int(0.55 * n), max_life=int(0.8 * n))
    scene = render_scene(seed, spec)
    tracker = OnlineTracker(Config(camera=cam))
    for k, frame in enumerate(scene.frames):
        tracker.update(k, k / scene.fps, frame)
    cols, _, _ = tracker.finish()
    ref = {k: [] for k in ("obj", "frame", "u", "v", "top")}
    for i, (tr, act) in enumerate(zip(scene.truth, spec.actors, strict=True)):
        ok = np.isfinite(tr.u) & np.isfinite(tr.v) & np.asarray(tr.alive)
        top = np.asarray(project_3d(cam, tr.body_x, tr.body_y,
                                    np.full(tr.body_x.shape, act.height_m))[1])
        for k, a in (("obj", np.full(ok.sum(), i)), ("frame", np.flatnonzero(ok)),
                     ("u", tr.u[ok]), ("v", tr.v[ok]), ("top", top[ok])):
            ref[k].append(a)
    ref = {k: np.concatenate(a) for k, a in ref.items()}
    ref["hpx"] = ref["v"] - ref["top"]
    c = {k: np.asarray(v) for k, v in cols.items()}
    for k in ("u", "v", "v_top"):
        c[k] = c[k].astype(np.float64)
    return c, ref


def concat(parts: list[dict]) -> dict:
    out = {k: np.concatenate([p[k] for p in parts]) for k in parts[0]
           if isinstance(parts[0][k], np.ndarray)}
    out["state"] = None if parts[0]["state"] is None else out["state"]
    out["n_rows"] = sum(p["n_rows"] for p in parts)
    out["n_matched"] = sum(p["n_matched"] for p in parts)
    return out


def measure(args) -> int:
    for name in args.only.split(","):
        if name == "pets":
            tr = tracks_cols(Path(args.pets))
            report(f"PETS09-S2L1 ({args.pets})", match(tr, pets_ref()), 360)
            for shift in (-1, 1):  # the frame alignment check: offsets against frames k -+ 1
                o = match(tracks_cols(Path(args.pets), shift), pets_ref())
                print(f"(tracker frame k against the boxes of frame k{shift:+d}: dv MAD "
                      f"{mad(o['dv']):.2f}, du MAD {mad(o['du']):.2f} px)")
        elif name == "dev":
            pairs = dev_pairs(Path(args.dev_work))
            if pairs:
                report(f"dev clips ({len(pairs)} clips, tracked with the true camera)",
                       concat([match(t, r) for t, r in pairs]), 512)
        elif name == "own":
            for fps in (15.0, 7.0):
                parts = [match(*own_pair(s, fps)) for s in range(args.own_scenes)]
                report(f"own rendered scenes ({args.own_scenes} scenes, seeds 0-"
                       f"{args.own_scenes - 1}, {fps:g} fps)", concat(parts), 480)
    return 0


# ----------------------------------------------------------------------------------------------
# which part of the PETS tracker's offsets moves the tilt

def decompose(args) -> int:
    """PETS's matched rows with the annotated feet plus parts of the tracker's offsets (module
    doc, `decompose`), each fitted with the default cues from the start of selfcal_real."""
    import tempfile

    import pyarrow as pa
    import pyarrow.parquet as pq
    from selfcal_real import pooled_batch

    from fit.selfcal import fit_selfcal

    tr = tracks_cols(Path(args.pets))
    o = match(tr, pets_ref())
    row, n = o["row"], len(tr["frame"])
    fu, fv = tr["u"][row] - o["du"], tr["v"][row] - o["dv"]  # the annotated feet
    du, dv = o["du"], o["dv"]
    ru, rv = du - np.nan_to_num(o["pred_du"]), dv - np.nan_to_num(o["pred_dv"])
    rng = np.random.default_rng(0)
    perm = rng.permutation(row.size)
    tid = np.asarray(tr["track_id"])[row]
    per_track = lambda d: np.array([np.median(d[tid == i]) for i in tid])  # noqa: E731
    clip = lambda d: np.clip(d, np.median(d) - 3 * mad(d), np.median(d) + 3 * mad(d))  # noqa
    obs = (o["state"].astype(str) == "observe") if o["state"] is not None else np.ones(row.size,
                                                                                        bool)
    variants = {
        "tracker feet (matched rows)": (du, dv),
        "annotated feet": (0 * du, 0 * dv),
        "annotated + tracker dv only": (0 * du, dv),
        "annotated + tracker du only": (du, 0 * dv),
        "annotated + the union's offsets": (np.nan_to_num(o["pred_du"]),
                                            np.nan_to_num(o["pred_dv"])),
        "annotated + tracker offsets less the union's": (ru, rv),
        "annotated + tracker offsets, shuffled over rows": (du[perm], dv[perm]),
        "annotated + each track's median offset": (per_track(du), per_track(dv)),
        "annotated + tracker offsets less each track's median": (du - per_track(du),
                                                                 dv - per_track(dv)),
        "annotated + tracker offsets clipped at 3 MADs": (clip(du), clip(dv)),
        "annotated + tracker offsets on observe rows only": (np.where(obs, du, 0),
                                                             np.where(obs, dv, 0)),
    }
    print("| foot points of PETS's matched rows | walkers | h (m) | tilt (deg) | a f (px) |")
    print("|---|---|---|---|---|")
    nan = np.full(n, np.nan)
    at_truth = []
    with tempfile.TemporaryDirectory() as d:
        for k, (name, (ou, ov)) in enumerate(variants.items()):
            if args.only and name not in args.only.split(";"):
                continue
            c = dict(tr)
            c["u"], c["v"] = nan.copy(), nan.copy()
            c["u"][row], c["v"][row] = fu + ou, fv + ov
            keep = np.zeros(n, bool)
            keep[row] = True
            for col in ("width_px", "v_top"):
                c[col] = np.where(keep, np.asarray(c[col], np.float64), np.nan)
            p = Path(d) / f"v{k}" / "tracks.parquet"
            p.parent.mkdir()
            pq.write_table(pa.table({q: np.asarray(a) for q, a in c.items()}), p)
            cfg, b = pooled_batch([p], (480, 360), 7.0)
            at_truth.append((name, cues_at_tsai(cfg, b)))
            r = fit_selfcal(cfg, b, cues=tuple(args.cues.split("+")),
                            frame_union=args.frame_union)
            if r.camera is None:
                print(f"| {name} | refused: {'; '.join(r.reasons)} | | | |", flush=True)
                continue
            v, se = r.values, r.se
            print(f"| {name} | {r.n_walkers} of {r.n_tracks} | {v['h']:.2f} +- {se['h']:.2f} | "
                  f"{v['theta']:.1f} +- {se['theta']:.1f} | {v['af']:.0f} +- {se['af']:.0f} |",
                  flush=True)
    print("\nthe used walkers' cues through the camera of (3) nearest to Tsai's\n")
    print("| foot points | stride median (m) | speed change: median abs, 1.4826 MAD | "
          "height median (m) |\n|---|---|---|---|")
    for name, (stride, ds, hgt) in at_truth:
        print(f"| {name} | {np.nanmedian(stride):.3f} | {np.nanmedian(np.abs(ds)):.3f}, "
              f"{mad(ds):.3f} | {np.nanmedian(hgt):.3f} |")
    return 0


def cues_at_tsai(cfg, batch) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(stride m, relative speed change, median height m) per used walker of `batch` through
    the pinhole of (3) nearest to PETS's Tsai camera (`fit.selfcal_cost.raw_cues`)."""
    import jax
    import study_selfcal_distortion as sd

    from fit.selfcal_cost import raw_cues
    from fit.selfcal_data import make_data, select

    used, pace = select(cfg, batch)
    with jax.enable_x64(True):
        data = make_data(batch, used, pace)
        r = raw_cues(sd.cameras()[1].camera(), data, cfg)
        ok = np.asarray(data.valid)
        hgt = np.where(np.asarray(r["hok"]), np.asarray(r["height"]), np.nan)
        return np.asarray(r["stride"])[ok], np.asarray(r["dspeed"])[ok], hgt[ok]


def main(argv=None) -> int:
    a = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = a.add_subparsers(dest="what", required=True)
    m = sub.add_parser("measure")
    m.add_argument("--pets", default="/tmp/selfcal_real/pets/rough/tracks.parquet")
    m.add_argument("--dev-work", default="/tmp/selfcal_real/dev_true")
    m.add_argument("--own-scenes", type=int, default=3)
    m.add_argument("--only", default="pets,dev,own")
    d = sub.add_parser("decompose")
    d.add_argument("--pets", default="/tmp/selfcal_real/pets/rough/tracks.parquet")
    d.add_argument("--frame-union", action="store_true")
    d.add_argument("--cues", default="gait+speed+width+height")
    d.add_argument("--only", default="", help="variants (their first words), ';'-separated")
    args = a.parse_args(argv)
    np.seterr(all="ignore")
    return {"measure": measure, "decompose": decompose}[args.what](args)


if __name__ == "__main__":
    sys.exit(main())
