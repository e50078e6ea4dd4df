"""Is a quarter right? The largest missing fraction of a rhythm window that is still judged
(`model.rhythm.MAX_MISSING_FRACTION`, 0.25; a study by replay, not the library).

A rhythm window of N = 64 samples with more than the fraction of its samples missing (I(k) NaN:
frames where two tracks share one blob) is not judged (`track.toolkit.match_window` skips it,
the next starts after its last missing sample). The classification never feeds back into the
tracking, so the own scenes' cached tracks (`study_false_positives.py`, ``-d`` default
/tmp/study_fp) are re-judged (`fp_replay.replay` with `max_missing`: a window with more than a
quarter but at most the fraction missing is judged on its linearly interpolated signals, the
values `rhythm.fill_gaps` gives the spectrum) and scored by track as eval_all scores
(`sim.evaluate.score` without windows: an object's verdict is its longest judged assigned
track's). Per fraction: walkers judged Pedestrian of the judged walkers and of all walkers,
non-walkers judged Pedestrian, and the objects whose verdict changed against 0.25.

    python benchmarks/study_max_missing.py 5555 6666 --fractions 0.25 0.3 0.35 0.4 0.5
    python benchmarks/study_max_missing.py 20240603 777001 dev     # report only

Seeds 5555 and 6666 are the training seeds (a fraction may be chosen there); 20240603 and
777001 are reported only.

`--gaps segments|interpolate` sets how the windows' missing samples (at most the library's
fraction) enter the spectrum (`rhythm.GAPS`; docs/rules.md, "Missing samples in a rhythm
window"); `rules-gaps run gaps on|off ...` runs eval_rules with it (ON "segments", OFF
"interpolate"), `rules-gaps table -d OUT` prints the table:

    python benchmarks/study_max_missing.py 5555 6666 --fractions 0.25 --gaps interpolate
    RHYTHMJAX_DATA=../shared/data/real \
        python benchmarks/study_max_missing.py rules-gaps run gaps on \
        --only pets,ucsd,casia,dev_count,pets_count -d OUT

``rules VALUE ARGS`` measures a fraction on the other sources without a config key:
`benchmarks/eval_rules.py` (ARGS its own) with a rule `max_missing` (ON: VALUE, OFF: 0.25)
that sets the module constant in this process (`rhythm`, `fast_window` and `track.toolkit`'s
`MAX_MISSING_FRACTION`, before anything is compiled). `rhythm --boxes` (pets_boxes) runs in a
subprocess the patch does not reach, so the tracker sources only:

    python benchmarks/study_max_missing.py rules 0.35 run max_missing on \
        --only synthetic,dev,pets,ucsd,casia --seeds 20240603,777001 -d /tmp/mm_rules
    python benchmarks/study_max_missing.py rules 0.35 table -d /tmp/mm_rules
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np


sys.path.insert(0, str(Path(__file__).parent))

from eval_all_score import verdict_row  # noqa: E402
from eval_synthetic import RECOMMENDED  # noqa: E402
from fp_replay import deciding, replay  # noqa: E402
from study_tracks import dev_scenes, own_scenes  # noqa: E402

from rhythmjax.model.params import config_from_dict  # noqa: E402
from rhythmjax.model.status import Verdict  # noqa: E402
from rhythmjax.sim.evaluate import score  # noqa: E402


def replayed_verdicts(cfg, objs, max_missing: float) -> tuple[dict, int]:
    """(verdict columns as `score` reads them, number of windows judged with more than N/4
    missing: at 0.25 only `final` windows, which come out bad-signal, Unclassified): each
    track's verdict is its deciding window's (the first Pedestrian one, else the first judged;
    'unclassified' with no window)."""
    cols = {"track_id": [], "verdict": [], "n_samples": [], "pace_hz": [], "stride_m": []}
    n, extra = cfg.thresholds.n, 0
    for o in objs:
        res = replay(cfg, o, max_missing=max_missing)
        for w in res:
            x = np.asarray([r.intensity for r in o.rows[w["k"]:w["k"] + n]])
            extra += int(np.sum(~np.isfinite(x)) > 0.25 * n)
        d = deciding(res)
        v = "unclassified" if d is None else Verdict(int(d["out"]["verdict"])).label
        cols["track_id"].append(o.track_id)
        cols["verdict"].append(v)
        cols["n_samples"].append(len(o.rows))
        cols["pace_hz"].append(np.nan if d is None else float(d["out"]["pace_hz"]))
        cols["stride_m"].append(np.nan if d is None else float(d["out"]["stride_m"]))
    return {k: np.asarray(v) for k, v in cols.items()}, extra


def rules_main(value: float, argv: list[str]) -> int:
    """eval_rules.py's main with the rule `max_missing` (module doc)."""
    import eval_rules as er
    import eval_rules_table as ert

    import rhythmjax.model.fast_window as fw
    import rhythmjax.model.rhythm as rh
    import rhythmjax.track.toolkit as tk

    ert.RULES["max_missing"] = (
        "constant", "MAX_MISSING_FRACTION", value, 0.25, ert.TRACKER_SOURCES,
        "own training seeds 5555, 6666 (replay, benchmarks/study_max_missing.py)")
    ert.DEFAULT_ON["max_missing"] = ()
    if argv[:3] == ["run", "max_missing", "on"]:
        for m in (rh, fw, tk):
            m.MAX_MISSING_FRACTION = value
    return er.main(argv)


def gaps_rules_main(argv: list[str]) -> int:
    """eval_rules.py's main with the rule `gaps` (ON: `rhythm.GAPS` "segments", Burg over the
    known runs of a window; OFF: "interpolate", the default), set in this process."""
    import eval_rules as er
    import eval_rules_table as ert

    import rhythmjax.model.rhythm as rh

    ert.RULES["gaps"] = (
        "constant", "GAPS", "segments", "interpolate", ert.TRACKER_SOURCES,
        "own training seeds 5555, 6666 (replay, benchmarks/study_max_missing.py --gaps)")
    ert.DEFAULT_ON["gaps"] = ()
    if argv[:2] == ["run", "gaps"]:
        rh.GAPS = "segments" if argv[2:3] == ["on"] else "interpolate"
    return er.main(argv)


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] == ["rules"]:
        return rules_main(float(argv[1]), argv[2:])
    if argv[:1] == ["rules-gaps"]:
        return gaps_rules_main(argv[1:])
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("seeds", nargs="+", help="own scene seeds, or 'dev' (the dev clips, each "
                   "with its own config, as eval_all tracks them; report only)")
    p.add_argument("--scenes", type=int, default=10)
    p.add_argument("--fractions", type=float, nargs="+", default=[0.25, 0.3, 0.35, 0.4, 0.5])
    p.add_argument("-d", "--cache", default="/tmp/study_fp")
    p.add_argument("--gaps", choices=("interpolate", "segments", "segments_taper"),
                   help="how a window's missing samples enter the spectrum (`rhythm.GAPS`; "
                        "default the library's)")
    a = p.parse_args(argv)
    import rhythmjax.model.rhythm as rh

    rh.GAPS = a.gaps or rh.GAPS  # before the first window is traced
    cfg = config_from_dict(RECOMMENDED)
    print("| seed | max missing | walkers Ped./judged | walkers Ped./all | non-walkers Ped. "
          "(judged/all) | pace MAE (Hz), step err. (cm) | windows judged with > N/4 missing | "
          "changed against the first fraction |")
    print("|---|---|---|---|---|---|---|---|")
    for seed in a.seeds:
        if seed == "dev":
            scenes = dev_scenes(Path(a.cache))
        else:
            scenes = [(nm, cfg, *x) for nm, *x in own_scenes(cfg, int(seed), a.scenes,
                                                             Path(a.cache))]
        base = None
        for f in a.fractions:
            tot = dict.fromkeys(("walkers", "walkers_judged", "walkers_pedestrian", "others",
                                 "others_judged", "others_pedestrian"), 0)
            extra, verdicts, objects = 0, {}, []
            for name, c, tracks, objs, truth in scenes:
                cols, e = replayed_verdicts(c, objs, f)
                extra += e
                s = score(tracks, cols, truth)
                for k in ("walkers", "walkers_judged", "walkers_pedestrian", "others",
                          "others_judged"):
                    tot[k] += s[k]
                tot["others_pedestrian"] += s["others_judged"] - s["others_non_pedestrian"]
                objects += s["objects"]
                for r in s["objects"]:
                    verdicts[f"{name}/{r['object']}"] = (r["kind"][:3], r["verdict"])
            base = base or verdicts
            acc = verdict_row(objects)
            changed = [f"{k}({v[0]}: {base[k][1][:5]}->{v[1][:5]})"
                       for k, v in verdicts.items() if v != base[k]]
            print(f"| {seed} | {f} | {tot['walkers_pedestrian']}/{tot['walkers_judged']} | "
                  f"{tot['walkers_pedestrian']}/{tot['walkers']} | "
                  f"{tot['others_pedestrian']} ({tot['others_judged']}/{tot['others']}) | "
                  f"{acc['pace_mae_hz']:.3f}, {acc['step_median_err_cm']:.1f} | "
                  f"{extra} | {', '.join(changed) or 'none'} |", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
