"""The foot-point gates of `count.foot_gate` (options a and b) on and off, through eval_all's
count sources: own counting scenes of `--sources count:SEED` (eval_count's scene specs),
`dev_count` (report only) and `pets_count`; `benchmarks/eval_count_options.py` with each
variant's settings. One `--variant NAME` at a time (2 shared cores):

    off    the defaults
    a      placement.in_range
    a2     placement.in_range, placement.gate_heights = 1
    g1/g2  placement.gate_heights = 1 / 2
    r, g1r stitch.reid alone / with placement.gate_heights = 1
    b      placement.lift_heights = 0.15
    b25    placement.lift_heights = 0.25
    bu     placement.lift_heights = 0.15, placement.lift_keep_u
    ab     in_range and lift_heights = 0.15

    python benchmarks/eval_foot_gate.py --variant a --sources count:42024,count:31337,dev_count
"""

from __future__ import annotations

import argparse
import json


VARIANTS = {
    "off": {},
    "a": {"placement.in_range": True},
    "a2": {"placement.in_range": True, "placement.gate_heights": 1.0},
    "g1": {"placement.gate_heights": 1.0},
    "g2": {"placement.gate_heights": 2.0},
    "r": {"stitch.reid": True},
    "g1r": {"placement.gate_heights": 1.0, "stitch.reid": True},
    "b": {"placement.lift_heights": 0.15},
    "b25": {"placement.lift_heights": 0.25},
    "bu": {"placement.lift_heights": 0.15, "placement.lift_keep_u": True},
    "ab": {"placement.in_range": True, "placement.lift_heights": 0.15},
}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--variant", default="off", choices=sorted(VARIANTS))
    p.add_argument("--sources", default="count:42024")
    p.add_argument("-o", "--output")
    a = p.parse_args(argv)
    import eval_count_options

    sets = [x for k, v in VARIANTS[a.variant].items() for x in ("--set", f"{k}={json.dumps(v)}")]
    return eval_count_options.main(["--sources", a.sources, "--name", a.variant, *sets,
                                    *(["-o", a.output] if a.output else [])])


if __name__ == "__main__":
    raise SystemExit(main())
