"""Heights the tracker measures, per object of own scenes (issue 16; a study for a size rule).

Each object's tracks (`sim.evaluate.match_tracks`), with the height (H1) of
`fit.selfcal_height.height_from_top` on every row that has a top row (the tracks' v_top),
through the scene's own camera. One line per object: scene, kind, its verdict (eval_synthetic's
by-track scoring), and per track (id, verdict, rows, median height m, rows with a height).

    python benchmarks/study_track_heights.py SEED [SCENES]

Figures: docs/rules.md, "A size rule against dogs (measured, not built)".
"""

from __future__ import annotations

import sys
from pathlib import Path

import jax
import numpy as np


sys.path.insert(0, str(Path(__file__).parent))

import eval_synthetic as es  # noqa: E402

from fit.selfcal_height import height_from_top  # noqa: E402
from rhythmjax.model.params import config_from_dict  # noqa: E402
from rhythmjax.sim.evaluate import match_tracks  # noqa: E402


def track_height(cfg, tracks, sel) -> tuple[float, int]:
    """(median height m, rows with a height) of the rows `sel` of `tracks`."""
    col = {k: np.asarray(tracks[k])[sel].astype(np.float64) for k in ("u", "v", "v_top")}
    H, ok = height_from_top(cfg.camera, col["u"], col["v"], col["v_top"])
    H = np.asarray(H)[np.asarray(ok)]
    return (float(np.median(H)) if H.size else float("nan")), int(H.size)


def main(argv: list[str]) -> int:
    seed, n = int(argv[0]), int(argv[1]) if len(argv) > 1 else 10
    cfg = config_from_dict(es.RECOMMENDED)
    with jax.enable_x64(True):
        for s, spec in es.scene_specs(seed, n, camera=cfg.camera):
            _, tracks, verdicts, scene, scored = es.run_scene(cfg, s, spec)
            assigned = match_tracks(tracks, scene.truth)
            tid = np.asarray(tracks["track_id"])
            vid = [int(t) for t in verdicts["track_id"]]
            for obj, row in zip(scene.truth, scored["objects"]):
                hs = []
                for t in (t for t, o in assigned.items() if o is obj):
                    i = vid.index(t)
                    hs.append((int(t), str(verdicts["verdict"][i]),
                               int(verdicts["n_samples"][i]), *track_height(cfg, tracks, tid == t)))
                print(s, obj.kind, row["verdict"], hs, flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
