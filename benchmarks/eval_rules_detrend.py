"""`benchmarks/eval_rules.py` with the rule `detrend`: ON, `rhythm.DETREND` "line" (each rhythm
window's least-squares line removed before Burg); OFF, "mean" (the paper's, the default). Set in
this process before the first window is traced (issue 16, twenty-fourth round; docs/rules.md).
The counting sources are measured faster by `reclassify_dumps.py`.

    python benchmarks/eval_rules_detrend.py run detrend on --only synthetic,dev,pets,ucsd,casia \\
        -d OUT
    python benchmarks/eval_rules_detrend.py run detrend off --only ... -d OUT
    python benchmarks/eval_rules_detrend.py table -d OUT
"""

from __future__ import annotations

import os
import sys


sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))


def main(argv=None) -> int:
    import eval_rules as er
    import eval_rules_table as ert

    import rhythmjax.model.rhythm as rh

    argv = sys.argv[1:] if argv is None else argv
    ert.RULES["detrend"] = (
        "constant", "DETREND", "line", "mean", ert.TRACKER_SOURCES,
        "nothing (a priori; counting pools 160001-8 screened, reclassify_dumps.py)")
    ert.DEFAULT_ON["detrend"] = ()
    if argv[:2] == ["run", "detrend"]:
        rh.DETREND = "line" if argv[2:3] == ["on"] else "mean"
    return er.main(argv)


if __name__ == "__main__":
    raise SystemExit(main())
