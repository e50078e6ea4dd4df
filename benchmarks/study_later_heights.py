"""How tall each rhythm window of a Pedestrian track reads against its deciding window, and what
each followed (issue 16, forty-seventh round; a study: nothing is chosen here).

A walker's track that carries on with a dog after its verdict keeps the walker's verdict where
the dog's windows pass rule 29's speed and pace tests (`track.recheck.not_a_walk`). Rule 43
(rule 26's height in those windows, off) lost a walker whose own later window read under half a
walker. This prints, per track judged Pedestrian at the defaults (own scenes,
`eval_synthetic.scene_specs`), the median height (`track.size.rows_height`, rule 36's rows) of
its deciding window and of each later window with the tail (`track.recheck.later_windows`), the
ratio of the two, and the object each window followed (`sim.evaluate.window_objects`):

    python benchmarks/study_later_heights.py SEED [SEED ...] [--scenes 10] [--lateral] \
        [-o ROWS.json]

`--lateral`: every path within 30 degrees of crossing the view (`eval_all.py`'s
`synthetic_lateral`). `-o` writes one row per later window (seed, scene, track, first and end
row, the kind followed, its height and the deciding window's in walker heights, readable rows):
labelled windows for a height bound. The tracks are the defaults' (as `eval_all.py` tracks
them), so each is read as the recheck left it: cut where rule 29 or 30a refused a window.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path


sys.path.insert(0, str(Path(__file__).parent))

import eval_synthetic as es  # noqa: E402
from study_switches import tracked_scenes  # noqa: E402

from rhythmjax.model.camera_np import camera_tuple  # noqa: E402
from rhythmjax.model.params import config_from_dict  # noqa: E402
from rhythmjax.model.status import Verdict  # noqa: E402
from rhythmjax.sim.evaluate import window_objects  # noqa: E402
from rhythmjax.sim.presets import synthetic_options  # noqa: E402
from rhythmjax.track.recheck import later_windows  # noqa: E402
from rhythmjax.track.size import rows_height  # noqa: E402


def followed(obj, tracks, truth, a: int, b: int) -> str:
    """The kind ('ped', 'bic', 'dog', 'car' or 'none') of the object rows a..b-1 followed."""
    span = {obj.track_id: (int(obj.rows[a][0]), int(obj.rows[b - 1][0]))}
    seen = window_objects(tracks, truth, span).get(obj.track_id)
    return "none" if seen is None else f"{seen.track_id}:{seen.kind[:3]}"


def study_arguments(argv: list[str], doc: str) -> argparse.Namespace:
    """The later-window studies' command line: SEED ..., --scenes, --lateral, -o."""
    p = argparse.ArgumentParser(description=doc.splitlines()[0])
    p.add_argument("seeds", type=int, nargs="+")
    p.add_argument("--scenes", type=int, default=10)
    p.add_argument("--lateral", action="store_true")
    p.add_argument("-o", "--out", type=Path)
    return p.parse_args(argv)


def main(argv: list[str]) -> int:
    a = study_arguments(argv, __doc__)
    cfg = config_from_dict(es.RECOMMENDED)
    cam, walker_m = camera_tuple(cfg.camera), float(cfg.width.height)
    top = synthetic_options().size.top_inside_heights

    def walkers(h: float) -> float | None:  # a height in walker heights; None: unreadable
        return h / walker_m if math.isfinite(h) else None

    rows = []
    for seed, s, scene, tracks, _, objs, _, _ in tracked_scenes(
            cfg, a.seeds, a.scenes, synthetic_options(), lateral_deg=30.0 if a.lateral else None):
        for o in objs:
            if o.result is None or int(o.result["verdict"]) != Verdict.PEDESTRIAN:
                continue
            k0, k1 = (int(k) for k in o.result["window"])
            hd, nd = rows_height(cam, o.rows[k0:k1], walker_m, top)
            line = [f"{seed} {s} track {o.track_id} decided {k0}-{k1} "
                    f"{followed(o, tracks, scene.truth, k0, k1)} {hd:.2f} m ({nd})"]
            for r in later_windows(cfg, o, tail=True):
                a0, b0 = (int(k) for k in r["window"])
                h, n = rows_height(cam, o.rows[a0:b0], walker_m, top)
                seen = followed(o, tracks, scene.truth, a0, b0)
                line.append(f"  later {a0}-{b0} {seen} {h:.2f} m ({n}) ratio {h / hd:.2f}")
                rows.append({"seed": seed, "scene": s, "track": int(o.track_id), "first": a0,
                             "end": b0, "kind": seen.split(":")[-1], "height": walkers(h),
                             "rows": int(n), "deciding_height": walkers(hd)})
            print("\n".join(line), flush=True)
    if a.out:
        a.out.write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
