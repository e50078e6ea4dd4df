"""How long the counting tracker's pedestrians keep their predictions in a merge, and how they
end: a diagnostic for `life.merge_hold_s` (issue 16, twenty-third round, docs/rules.md).

Every frame of every pedestrian `count.coast.advance_coast` sees is tallied: measured or not,
marked `merged` (the blob it shares too narrow for them side by side, `PedestrianLevel._place`),
held (merged after entering the merge measured); per pedestrian the longest run of held time
(s, `Pedestrian.held`); per end reason the ended pieces, those that time out split by whether
they had been held since their last measurement.

    python benchmarks/study_merge_hold.py count --seed 160001 --scenes 10 [--focal-px 500] \\
        [--clothing any] [--set life.merge_hold_s=3.0]

SOURCE as `count_dump.py` (pets, count, dev_count).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import sys
from collections import Counter

import numpy as np


sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))


@contextlib.contextmanager
def watched_coasts(module, tally: Counter, longest: dict):
    """Within the block, `module.advance_coast` (count.pedestrian_level's) and
    `module.PedestrianLevel._end` are watched: `tally` counts "frames", "unmeasured", "merged",
    "held" (frames) and "end <reason>", "timeout held" / "timeout coasting"; `longest[id(p)]`
    is the longest hold (s) each pedestrian reached. Both are restored after the block."""
    advance, level_class = module.advance_coast, module.PedestrianLevel
    end = level_class._end
    alive: list = []  # every pedestrian seen, kept so that no id is reused in the block

    def advance_watched(p, measured, dt, hold_s):
        held = (not measured) and hold_s > 0 and p.merged and p.coast == 0.0
        tally.update({"frames": 1, "unmeasured": int(not measured), "merged": int(p.merged),
                      "held": int(held)})
        advance(p, measured, dt, hold_s)
        if p.held > 0:
            if id(p) not in longest:
                alive.append(p)
            longest[id(p)] = max(longest.get(id(p), 0.0), p.held)

    def end_watched(level, p, reason):
        tally[f"end {reason}"] += 1
        if reason == "timeout":
            tally["timeout held" if p.held > 0 else "timeout coasting"] += 1
        return end(level, p, reason)

    module.advance_coast, level_class._end = advance_watched, end_watched
    try:
        yield
    finally:
        module.advance_coast, level_class._end = advance, end


def main(argv=None) -> int:
    from count_dump import clips_of

    import rhythmjax.count.pedestrian_level as level_module
    from rhythmjax.count import CountOptions
    from rhythmjax.track.options import with_changes
    from rhythmjax.vision.frames import drive_frames

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("source")
    ap.add_argument("--seed", default="160001")
    ap.add_argument("--scenes", type=int, default=10)
    ap.add_argument("--clothing", default="contrasted", choices=("contrasted", "any"))
    ap.add_argument("--focal-px", type=float, default=0.0)
    ap.add_argument("--set", action="append", default=[])
    a = ap.parse_args(argv)
    opt = with_changes(CountOptions(),
                       {k: json.loads(v) for k, v in (x.split("=", 1) for x in a.set)})
    tally: Counter = Counter()
    longest: dict = {}
    for seed in a.seed.split(","):
        for _name, cfg, frames, *_ in clips_of(a.source, int(seed), a.scenes, a.clothing,
                                              a.focal_px):
            level = level_module.PedestrianLevel(cfg, opt, defer=True)
            with watched_coasts(level_module, tally, longest):
                drive_frames(iter(frames), level.update, None, n_frames=len(frames),
                             progress=False)
                level.end_all()
    print(json.dumps(dict(sorted(tally.items()))))
    held = np.asarray(list(longest.values()), np.float64)
    if held.size:
        p50, p90, top = np.percentile(held, [50, 90, 100])
        print(f"{held.size} pedestrians held: longest hold median {p50:.2f} s, 90 % {p90:.2f} s, "
              f"max {top:.2f} s")
    else:
        print("no pedestrian held (life.merge_hold_s 0, or no merge)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
