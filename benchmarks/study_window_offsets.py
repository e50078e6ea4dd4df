"""Window B moved up or down from the foot row, and candidate windows (issue 16, item 2; a study).

The tracker's window B is W px wide and W/5 rows high, its bottom row the measured foot row
(`vision.window_b.window_b_rect`). Here every tracked object's rhythm signal I(k) is summed
again, on the tracker's own difference images (`eval_window_b.differences`) and at its own
foot points and W, with window B moved by `OFFSETS` (in W, negative = up: -0.2 is the W/5
rows just above the paper's window), and each rhythm window (N rows, one every hop; more than a
quarter missing: skipped, as the classifier does) is judged by the reference
`rhythm.classify_window_jit` with:
- each fixed offset (0 is what the tracker does);
- `candidates`: per rhythm window, the offset whose strongest spectral peak is highest (the
  "several candidate windows, the strongest periodicity taken" of the issue).
An object counts as Pedestrian when any window of any track assigned to it says so
(`sim.evaluate.match_tracks`; PETS: `eval_real_video.score_pets` with each track's verdict
replaced by that). Nothing in the library changes; this only measures.

    python benchmarks/study_window_offsets.py own 5555 [SCENES]   # own scenes, eval_synthetic's
    python benchmarks/study_window_offsets.py dev                 # report only
    python benchmarks/study_window_offsets.py pets

Prints one line per object, then per kind: objects judged, Pedestrian per offset, Pedestrian
with candidates. Figures and what may be chosen on which source: docs/window_b.md.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import jax.numpy as jnp
import numpy as np


sys.path.insert(0, str(Path(__file__).parent))

import eval_window_b as ew  # noqa: E402

from rhythmjax.model.camera import image_width  # noqa: E402
from rhythmjax.model.rhythm import classify_window_jit  # noqa: E402
from rhythmjax.model.status import Verdict  # noqa: E402
from rhythmjax.sim.evaluate import match_tracks  # noqa: E402
from rhythmjax.track import track_frames  # noqa: E402
from rhythmjax.track.options import TrackerOptions  # noqa: E402
from rhythmjax.vision import detect  # noqa: E402


OFFSETS = (-0.2, -0.1, 0.0, 0.1)  # window B's shift, in walker widths W (negative: up)


def judge_window(cfg, t, signal, xy, k):
    """(strongest peak P, Pedestrian) of the rhythm window starting at row k; None when more
    than a quarter of its samples are missing."""
    n = int(cfg.thresholds.n)
    x = signal[k:k + n]
    if np.sum(~np.isfinite(x)) > 0.25 * n:
        return None
    r = classify_window_jit(cfg, jnp.asarray(x, jnp.float32),
                            jnp.asarray(t[k:k + n] - t[k], jnp.float32),
                            jnp.asarray(xy[k:k + n], jnp.float32), jnp.asarray(True))
    p = np.asarray(r.peak_power)[np.asarray(r.peak_mask)]
    return (float(p.max()) if p.size else 0.0), int(r.verdict) == Verdict.PEDESTRIAN


def track_outcomes(cfg, tracks, D, t_id) -> tuple[bool, list[bool]] | None:
    """(judged, Pedestrian per offset and then with candidates) of one track; None when it has
    fewer than N rows."""
    n, hop = int(cfg.thresholds.n), int(cfg.thresholds.hop_samples)
    sel = np.asarray(tracks["track_id"]) == t_id
    f = np.asarray(tracks["frame"])[sel]
    if len(f) < n:
        return None
    x, y = np.asarray(tracks["x_est"])[sel], np.asarray(tracks["y_est"])[sel]
    W = np.asarray(image_width(cfg.camera, cfg.width.mean, jnp.asarray(y, jnp.float32)), float)
    u, v = np.asarray(tracks["u"])[sel], np.asarray(tracks["v"])[sel]
    ok = np.isfinite(np.asarray(tracks["intensity"])[sel]) & np.isfinite(u) & np.isfinite(v)
    signals = [np.array([detect.window_b_intensity(D[k], u[i], v[i] + o * W[i], W[i])
                         if ok[i] and D[k] is not None else math.nan
                         for i, k in enumerate(f)]) for o in OFFSETS]
    tt, xy = np.asarray(tracks["t"])[sel], np.stack([x, y], 1)
    ped, judged = [False] * (len(OFFSETS) + 1), False
    for k in range(0, len(f) - n + 1, hop):
        res = [judge_window(cfg, tt, s, xy, k) for s in signals]
        if res[OFFSETS.index(0.0)] is None:
            continue
        judged = True
        for j, r in enumerate(res):
            ped[j] |= bool(r and r[1])
        best = max((j for j, r in enumerate(res) if r), key=lambda j: res[j][0])
        ped[-1] |= res[best][1]
    return judged, ped


def clip_objects(name, cfg, frames, truth, options) -> list[dict]:
    """One row per true object with a track: kind, judged, Pedestrian per offset + candidates."""
    fps = float(cfg.camera.fps)
    tracks, _, _, _ = track_frames(cfg, ((i, i / fps, f) for i, f in enumerate(frames)),
                                   progress=False, options=options)
    D = ew.differences(frames, options)
    rows: dict = {}
    for t_id, obj in match_tracks(tracks, truth).items():
        row = rows.setdefault(obj.track_id, {"clip": name, "object": str(obj.track_id),
                                             "kind": obj.kind, "judged": False,
                                             "ped": [False] * (len(OFFSETS) + 1)})
        out = track_outcomes(cfg, tracks, D, t_id)
        if out is not None:
            row["judged"] |= out[0]
            row["ped"] = [a or b for a, b in zip(row["ped"], out[1])]
    for r in rows.values():
        print(name, r["object"], r["kind"], r["judged"], r["ped"], flush=True)
    return list(rows.values())


def own_clips(seed: int, n_scenes: int):
    import eval_synthetic as es

    from rhythmjax.model.params import config_from_dict
    from rhythmjax.sim.presets import synthetic_options
    from rhythmjax.sim.scene import render_scene

    cfg = config_from_dict(es.RECOMMENDED)
    for s, spec in es.scene_specs(seed, n_scenes, camera=cfg.camera):
        scene = render_scene(s, spec)
        yield f"own{s}", cfg, list(scene.frames), scene.truth, synthetic_options()


def pets() -> None:
    """PETS09-S2L1 through the tracker (eval_all's config): people judged Pedestrian."""
    import eval_real_video as ev

    from rhythmjax.evaluation import datasets
    from rhythmjax.vision.video import VideoSource

    cfg = ev.video_config(ev.pets_config_dict(), datasets.pets_video(), datasets.PETS_FPS)
    frames = [f for _, _, f in VideoSource(str(datasets.pets_video()), fps=datasets.PETS_FPS)]
    opt = TrackerOptions(max_objects=ev.MAX_OBJECTS)
    tracks, verdicts, _, _ = track_frames(
        cfg, ((i, i / datasets.PETS_FPS, f) for i, f in enumerate(frames)), progress=False,
        options=opt)
    D = ew.differences(frames, opt)
    outcome = {int(t): track_outcomes(cfg, tracks, D, int(t)) for t in verdicts["track_id"]}
    for j, label in enumerate([f"offset {o:+g} W" for o in OFFSETS] + ["candidates"]):
        v = dict(verdicts)
        v["verdict"] = np.array([
            ("pedestrian" if outcome[int(t)][1][j] else "non-pedestrian")
            if outcome[int(t)] is not None and outcome[int(t)][0] else str(old)
            for t, old in zip(verdicts["track_id"], verdicts["verdict"])], dtype=object)
        people = ev.score_pets(tracks, v, datasets.pets_boxes())["people"].values()
        print(f"pets {label}: {sum(p['verdict'] == 'pedestrian' for p in people)} of "
              f"{len(people)} people Pedestrian", flush=True)


def main(argv: list[str]) -> int:
    if argv[:1] == ["pets"]:
        pets()
        return 0
    if argv[:1] == ["dev"]:
        gen = ((*c, TrackerOptions()) for c in ew.dev_clips())
    elif argv[:1] == ["own"] and len(argv) >= 2:
        gen = own_clips(int(argv[1]), int(argv[2]) if len(argv) > 2 else 10)
    else:
        print(__doc__, file=sys.stderr)
        return 2
    rows = []
    for name, cfg, frames, truth, opt in gen:
        rows += clip_objects(name, cfg, frames, truth, opt)
    for kind in sorted({r["kind"] for r in rows}):
        rs = [r for r in rows if r["kind"] == kind and r["judged"]]
        per = [sum(r["ped"][j] for r in rs) for j in range(len(OFFSETS))]
        print(f"{kind}: judged {len(rs)}; Pedestrian per offset "
              + ", ".join(f"{o:+g} W {p}" for o, p in zip(OFFSETS, per))
              + f"; candidates {sum(r['ped'][-1] for r in rs)}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
