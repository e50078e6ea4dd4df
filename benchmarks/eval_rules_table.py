"""The rules `eval_rules.py` measures (`RULES`: kind, key, ON and OFF values, the sources each
can change, what it was chosen on; `DEFAULT_ON`: where ON is a source's default) and its
`table` of saved runs: per rule and source, the change ON - OFF (module doc of eval_rules.py)."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path


sys.path.insert(0, str(Path(__file__).resolve().parent))

from eval_rules_fit import TRAIN_SEEDS, ba_cells  # noqa: E402


TRACKER_SOURCES = ("synthetic", "dev", "pets", "ucsd", "casia")
COUNT_SOURCES = ("count", "dev_count", "pets_count")

# rule -> (kind, key, ON value, OFF value, sources it can change, chosen on)
RULES = {
    "half_pace": ("config", ("thresholds", "harmonic_max_ratio"), 0.25, 0.0,
                  TRACKER_SOURCES + COUNT_SOURCES + ("pets_boxes",),
                  "own training seeds 5555, 6666 (validation.md sources table)"),
    "high_foot": ("tracker", "body.high_foot_widths", 0.25, 0.0, TRACKER_SOURCES,
                  "own training seeds 5555, 6666; left off by default because of PETS09"),
    "hop": ("hop", None, "N/2", "N", TRACKER_SOURCES + COUNT_SOURCES + ("pets_boxes",),
            "own training seeds 5555, 6666"),
    "relink": ("tracker", "relink.within_s", 3.0, 0.0, TRACKER_SOURCES,
               "own training seeds 5555, 6666"),
    "stitch": ("count", "stitch.enabled", True, False, COUNT_SOURCES,
               "own counting seeds 42024, 7, 44024 (gap, velocity-jump end)"),
    "parts": ("tracker", "body.parts_widths", 1.8, 0.0, TRACKER_SOURCES,
              "own synthetic seeds (b02e743: 20240603, 779, 777)"),
    "sample_estimate": ("tracker", "body.sample_estimate", True, False, TRACKER_SOURCES,
                        "own synthetic seeds (b02e743: 20240603, 779, 777)"),
    "velocity_jump": ("count", "life.max_dv_mps", 1.5, 1e9, COUNT_SOURCES,
                      "own counting seeds 42024, 7, 44024; checked on PETS (746aacb)"),
    "still": ("count", "life.still_s", 5.0, 0.0, COUNT_SOURCES,
              "none: set from geometry (1ad0850, issue 16 item 4)"),
    "stabilise": ("tracker", "motion.stabilise", True, False, TRACKER_SOURCES,
                  "own scenes, seeds 4100-7100 with 1 px shake (docs/window_b.md; 95875e0)"),
    "candidates": ("tracker", "body.window_candidates", True, False,
                   TRACKER_SOURCES + ("pets_boxes",),
                   "none: offsets -0.2, -0.1, +0.1 W set a priori (docs/window_b.md)"),
    "shared_overlap": ("tracker", "body.shared_overlap", 0.8, 0.5, TRACKER_SOURCES,
                       "own training seeds 5555, 6666 (benchmarks/study_missed_walkers.py)"),
    "split_shared": ("tracker", "body.split_shared", True, False, TRACKER_SOURCES,
                     "own training seeds 5555, 6666 (split_near_widths 0.3; "
                     "benchmarks/study_missed_walkers.py)"),
    "split_depth": ("tracker", "body.split_depth_widths", 0.5, 0.0, TRACKER_SOURCES,
                    "own training seeds 5555, 6666 (benchmarks/study_depth_split.py); ON also "
                    "sets body.split_shared (TRACKER_WITH); both on by default since the "
                    "sixth round"),
    "count_candidates": ("count", "verdicts.window_candidates", True, False, COUNT_SOURCES,
                         "none: offsets -0.2, -0.1, +0.1 W set a priori (docs/window_b.md)"),
    "side_anchor": ("tracker", "body.side_anchor", True, False, TRACKER_SOURCES,
                    "own training seeds 5555, 6666 (the mechanism was found on dev_multi_01, "
                    "so the dev clips only report it; docs/rules.md, rule 16)"),
    "reid": ("count", "stitch.reid", True, False, COUNT_SOURCES,
             "own counting seeds (left off: neutral there; 95875e0)"),
    "still_end": ("patch", "PedestrianLevel._still", "on", "off (ghost drop kept)",
                  COUNT_SOURCES, "none: set from geometry (1ad0850, issue 16 item 4)"),
    "min_height": ("tracker", "size.min_height_heights", 0.5, 0.0, TRACKER_SOURCES,
                   "nothing fitted (half a walker, a priori); heights looked at on own training "
                   "seeds 5555, 6666 (docs/rules.md, rule 26); the deciding window's rows "
                   "(26c, size.min_height_scope 'window') since the thirtieth round"),
    "min_height_track": ("tracker", "size.min_height_heights", 0.5, 0.0, TRACKER_SOURCES,
                         "as min_height, every row of the track (26b, size.min_height_scope "
                         "'track'; decided on own seeds 230001-260001)"),
    "height_fallback": ("tracker", "size.min_height_scope", "window-or-track", "window",
                        TRACKER_SOURCES, "nothing fitted (26d's 0.5 walker heights and 10 rows); "
                        "the dogs it is for found on own seeds 1170001-1280001 (rule 26f)"),
    "recheck": ("tracker", "recheck.enabled", True, False, TRACKER_SOURCES,
                "nothing fitted (the walking model's bounds); later windows looked at on own "
                "seeds 5555, 6666, 20240603, 777001, 888001, 999001, 230001-280001 (rule 29)"),
    "recheck_all": ("tracker", "recheck.tail", True, False, TRACKER_SOURCES,
                    "nothing fitted (rule 29's bounds); the last and earlier windows looked at on "
                    "own seeds 5555, 6666, 16, 20240603, 777001, 888001, 999001, 230001-280001 "
                    "(rule 30; ON also sets recheck.earlier)"),
    "recheck_tail": ("tracker", "recheck.tail", True, False, TRACKER_SOURCES,
                     "nothing fitted (rule 29's bounds); the last windows looked at on own seeds "
                     "5555, 6666, 16, 20240603, 777001, 888001, 999001, 230001-280001, "
                     "370001-420001 (rule 30a)"),
    "recheck_speed": ("tracker", "recheck.earlier", "speed", "off", TRACKER_SOURCES,
                      "nothing fitted (rule 29's speed bound); the earlier windows looked at on "
                      "own seeds 5555, 6666, 16, 20240603, 777001, 888001, 999001, "
                      "230001-280001, 450001-540001 and PETS09 (rule 30b)"),
    "core_column": ("tracker", "body.column_fraction", 0.3, None, TRACKER_SOURCES,
                    "nothing fitted (0.3, the projections' first slice fraction); found on the "
                    "dev clips (dev_walk_05's suitcase), so they only report it; only where the "
                    "extent is wider than the predicted body box (rule 32b)"),
    "upper_column": ("tracker", "body.column_rows", 0.5, None, TRACKER_SOURCES,
                     "nothing fitted (0.5, a walker's hips at half its height); the case found "
                     "on the dev clips (dev_walk_05's suitcase), so they only report it; only "
                     "where the extent is wider than the predicted body box (rule 33)"),
    "pace_window": ("tracker", "body.pace_window_widths", 2.0, 0.0, TRACKER_SOURCES,
                    "nothing fitted (2 W, a step of a crossing walker, a priori); the need found "
                    "on own crossing seeds 1470001-1520001, measured on fresh 1530001-1640001 "
                    "(rule 34: the pace and stride only; off: worse on the dev clips)"),
    "window_per_pixel": ("tracker", "body.window_per_pixel", True, False, TRACKER_SOURCES,
                         "own scenes with knees, radial 1830001-1840001 (rule 35; confirmed on "
                         "fresh 1850001-1880001: off, non-walkers more)"),
    "top_inside": ("tracker", "size.top_inside_heights", 0.1, 0.0, TRACKER_SOURCES,
                   "nothing fitted (0.1 walker heights a priori; the case seen on own seed 12's "
                   "dog, rule 36)"),
    "twice_pace": ("tracker", "size.twice_pace_heights", 0.57, 0.0, TRACKER_SOURCES,
                   "the case seen on own knees radial 2070001-2120001 (rule 37, 0.75 a priori); "
                   "0.57 fitted on own knees 5555, 6666, 2830001-2860001 (fortieth round)"),
    "count_twice": ("count", "verdicts.twice_pace_heights", 0.57, 0.0, COUNT_SOURCES,
                    "the tracker's rule 37 in count's verdicts (decided on fresh own counting "
                    "seeds 2430001-2460001 at 0.75; the tracker's fitted 0.57 since the fortieth "
                    "round)"),
    "twice_edge": ("tracker", "size.twice_pace_edge", True, False, TRACKER_SOURCES,
                   "nothing fitted (a lower bound, a priori; rule 37b in the tracker, decided on "
                   "fresh own knees 2530001-2600001)"),
    "count_edge": ("count", "verdicts.twice_pace_edge", True, False, COUNT_SOURCES,
                   "nothing fitted (a lower bound, a priori; the cut heads seen on own counting "
                   "seeds 2430001-2440001; decided on fresh 2490001-2520001)"),
    "twice_fitted": ("tracker", "size.twice_pace_heights", 0.57, 0.75, TRACKER_SOURCES,
                     "fitted (fit.heights on own knees 5555, 6666, 2830001-2860001, held out "
                     "2870001-2920001; OFF is the a priori 0.75)"),
    "count_twice_fitted": ("count", "verdicts.twice_pace_heights", 0.57, 0.75, COUNT_SOURCES,
                           "fitted (the tracker's fitted rule 37 threshold; OFF the a priori "
                           "0.75)"),
    "trend": ("config", ("thresholds", "trend_max_cycles"), 2.0, 0.0,
              TRACKER_SOURCES + COUNT_SOURCES + ("pets_boxes",),
              "nothing fitted (2 cycles a window a priori: fewer is a trend, not a rhythm); the "
              "case seen on own 20240603, 777001, 11, 12 (study_missed_walkers: 8 of 9 walkers "
              "judged no-model-match had a window whose strongest peak is at 0.11-0.53 Hz)"),
    "hop4": ("hop4", None, "N/4", "N/2", TRACKER_SOURCES + COUNT_SOURCES + ("pets_boxes",),
             "nothing fitted (N/4 halves again the kept N/2, a priori); found on used seeds "
             "3110001-3140001, 3300001-3350001 (study_rescue_windows: most missed walkers' "
             "tracks give one window)"),
    "tail": ("tail", None, "tail window", "none", TRACKER_SOURCES,
             "nothing fitted (the paper's N rows, no constant); found on used seeds "
             "2930001-2960001, 3110001-3140001, 3300001-3330001, 3380001-3410001 (replay)"),
    "across": ("tracker", "body.across_candidates", True, False, TRACKER_SOURCES,
               "nothing fitted (0.1 W, the vertical candidates' step, a priori); suggested by "
               "study_window_column on used seeds 5120001-5130001, 5280001-5290001 and the dev "
               "clips (round 48); rule 37 on the across windows too (a patch)"),
    "across_solo": ("tracker", "body.across_candidates", True, False, TRACKER_SOURCES,
                    "as across; written after across's UCSD anomaly track "
                    "(Test004, an across candidate judged by rule 37)"),
    "fast_stretch": ("tracker", "recheck.fast_stretch", 0.25, 0.0, TRACKER_SOURCES,
                     "nothing fitted ((14)'s fastest walk); the filter's speed and N/4 rows "
                     "chosen with study_tail_speed on used seeds 7800001-7830001, "
                     "7960001-7980001 (rule 52)"),
    "twice_quantile": ("tracker", "size.twice_pace_quantile", 0.25, 0.5, TRACKER_SOURCES,
                       "0.25 a priori (rule 37's threshold kept); suggested by "
                       "study_twice_heights on used seeds 8100001-8190001, 8260001-8330001 "
                       "(rule 53)"),
    "upper_filter": ("tracker", "body.column_filter_only", True, False, TRACKER_SOURCES,
                     "nothing fitted (rule 33's 0.5; ON also sets body.column_rows 0.5); "
                     "written after rule 33 re-tested on the own defaults (round 53: crossing "
                     "pace and straight-legged walkers lost with window B moved) (rule 54)"),
    "upper_always": ("tracker", "body.column_everywhere", True, False, TRACKER_SOURCES,
                     "nothing fitted (ON also sets body.column_rows 0.5 and "
                     "body.column_filter_only); written after rule 54's screen on the own "
                     "defaults (round 53: its moved column toggles with the width) (rule 54b)"),
    "upper_median": ("tracker", "body.column_filter_only", True, False, TRACKER_SOURCES,
                     "nothing fitted (ON also sets body.column_rows 0.5 and recheck.median_pace: "
                     "rules 54 and 47 together); written after decision 54 failed on the "
                     "crossing pace (round 53)"),
    "strongest_pace": ("tracker", "recheck.strongest_pace", True, False, TRACKER_SOURCES,
                       "nothing fitted (a Pedestrian track's pace and stride those of its "
                       "Pedestrian window with the strongest chosen peak); written after "
                       "decision 54's crossing pace (round 53's lead) (rule 55)"),
    "upper_strongest": ("tracker", "body.column_filter_only", True, False, TRACKER_SOURCES,
                        "nothing fitted (ON also sets body.column_rows 0.5 and "
                        "recheck.strongest_pace: rules 54 and 55 together); written after "
                        "decision 54 failed on the crossing pace (round 54)"),
    "lean": ("tracker", "body.lean_column", True, False, TRACKER_SOURCES,
             "nothing fitted (half the config's walker height, a priori); found on used seeds "
             "3300001-3330001, 3380001-3410001 (study_window_placement)"),
    "relink_speed": ("tracker", "relink.side_rows", 0.25, 0.0, TRACKER_SOURCES,
                     "nothing fitted ((14)'s fastest walk, N/4 rows a side as rule 52's "
                     "stretch, a priori); found with a study of relinks on used seeds "
                     "12320001-12370001 and study_switch_rows on six samples (rule 57)"),
    "halves": ("tracker", "recheck.halves", True, False, TRACKER_SOURCES,
               "nothing fitted (N/2 and (14)'s fastest walk, a priori); found on used seeds "
               "3920001-3950001 (study_half_speed, rule 42)"),
    "pixel_halves": ("tracker", "recheck.halves", True, False, TRACKER_SOURCES,
                     "rule 35 with rule 42 against both off (ON also sets "
                     "body.window_per_pixel); found on used seeds 3920001-3950001"),
    "recheck_resolved": ("tracker", "recheck.earlier", "resolved", "off", TRACKER_SOURCES,
                         "nothing fitted (rule 30's bounds; the frame rate against twice the "
                         "fastest pace, a priori); found on used seeds 4040001-4070001 (rule 30c)"),
    "recheck_low": ("tracker", "recheck.low", True, False, TRACKER_SOURCES,
                    "nothing fitted (rule 26's 0.5 walker heights over 10 rows on the windows "
                    "the recheck reads); found on used seeds 4040001-4070001 (rule 43)"),
    # the rules on `recheck.earlier` (recheck_all, recheck_speed, recheck_resolved, this one)
    # read OFF as "off": since rule 30d that is not the default ("speed-low") but no test at all
    "recheck_speed_low": ("tracker", "recheck.earlier", "speed-low", "off", TRACKER_SOURCES,
                          "nothing fitted (rule 29's speed and rule 26's height on the windows "
                          "before the verdict); found on used seeds 4040001-4070001, "
                          "4160001-4230001 (rule 30d)"),
    "mean_refused": ("tracker", "body.window_mean_refused", True, False, TRACKER_SOURCES,
                     "nothing fitted (rule 35's mean, read only where the sum refuses a window; "
                     "ON without rule 35c's gate); found on used radial seeds 4520001-4590001 "
                     "(rule 35b)"),
    "mean_trend": ("tracker", "body.window_mean_refused", True, False, TRACKER_SOURCES,
                   "nothing fitted (half Table 1's slowest pace, (14)'s fastest walk); rule 35b "
                   "behind a trend and halves gate (ON also sets body.mean_refused_gate); "
                   "found on used 4640001-4710001, 777001, UCSD Test010 (rule 35c)"),
    "halves_around": ("tracker", "recheck.halves_around", True, False, TRACKER_SOURCES,
                      "nothing fitted (rule 42's half test and (14)'s 2.57 m/s, before and after "
                      "the deciding window only); found on used seeds 4650001, 4680001 (rule 44)"),
    "window_low": ("tracker", "size.every_window", True, False, TRACKER_SOURCES,
                   "nothing fitted (rule 26's 0.5 walker heights over 10 rows on every window, "
                   "as the batch classifier reads them); found on own 777001 scene 8 with "
                   "straight legs (rule 45)"),
    "pace_tall": ("tracker", "recheck.pace_tall", True, False, TRACKER_SOURCES,
                  "nothing fitted (rule 37's fitted 0.57 walker heights over 10 rows on the later "
                  "windows rule 29's pace test refuses); found on used seeds 5120001-5190001 "
                  "(study_later_paces, rule 46)"),
    "median_pace": ("tracker", "recheck.median_pace", True, False, TRACKER_SOURCES,
                    "nothing fitted (a Pedestrian track's pace and stride as the medians over "
                    "its windows judged Pedestrian); suggested by study_lateral_pace's "
                    "trk_median on used seeds (rule 47)"),
    "mass_column": ("tracker", "body.mass_column", True, False, TRACKER_SOURCES,
                    "nothing fitted (a box u_p +- W wide and one walker height high, a priori); "
                    "suggested by study_window_column's mass_u on used seeds 5120001-5130001, "
                    "5280001-5290001, 6080001-6110001 and the dev clips (rule 48)"),
    "mass_crossing": ("tracker", "body.mass_crossing", 0.7071, 0.0, TRACKER_SOURCES,
                      "nothing fitted (sin 45 degrees, the midpoint, a priori; ON also sets "
                      "body.mass_column); found on rule 48's pools 6120001-6350001 (rule 48b)"),
    "twice_sub": ("tracker", "size.twice_pace_sub", 0.02, 0.0, TRACKER_SOURCES,
                  "0.02 chosen on used cached seeds 6120001-6480001 (rule 37's windows: 18 "
                  "walkers' sub-harmonic 0.000-0.543, 5 dogs' 0.000-0.532); 0.2 Hz a priori "
                  "(rule 49)"),
    "stride_peak": ("tracker", "size.stride_peak", True, False,
                    TRACKER_SOURCES + ("pets_boxes",),
                    "nothing fitted (rule 37's fitted 0.57 walker heights, (14) at twice the "
                    "strongest peak); found on decision 55's radial suitcase pool "
                    "9740001-9810001, used; on since decision 56 (rule 56)"),
    "twice_refit": ("tracker", "size.twice_pace_heights", 0.51, 0.57, TRACKER_SOURCES,
                    "fitted (fit.heights on own knees 10520001-10550001 under round 55's "
                    "defaults, held out 10560001-10590001: balanced accuracy 0.939 -> 0.955; "
                    "OFF the earlier fit, 0.57) (rule 37 refitted; rules 46 and 56 read it)"),
    "low_refit": ("tracker", "size.min_height_heights", 0.47, 0.5, TRACKER_SOURCES,
                  "fitted (fit.heights on own knees 10520001-10550001 under round 55's "
                  "defaults, held out 10560001-10590001: balanced accuracy 0.968 -> 0.972; "
                  "OFF the a priori 0.5) (rule 26 refitted; count's verdicts keep 0.5)"),
    "count_stride": ("count", "verdicts.stride_peak", True, False, COUNT_SOURCES,
                     "nothing fitted (rule 56 in count's verdicts, as the tracker's); "
                     "decided with decision 56's count screen: PETS09 27 -> 30, off"),
    "count_low": ("count", "verdicts.min_height_heights", 0.5, 0.0, COUNT_SOURCES,
                  "nothing fitted (the tracker's rule 26 in count's verdicts; decided on fresh "
                  "own counting seeds 2730001-2760001: no verdict changed)"),
}
# the sources where the rule is ON in the defaults eval_all.py runs with (the own scenes use
# sim.presets' SYNTHETIC_CONFIG and SYNTHETIC_OPTIONS)
# tracker keys a rule's ON side sets besides its own (its OFF side is the defaults)
TRACKER_WITH = {"split_depth": {"body.split_shared": True},
                "min_height_track": {"size.min_height_scope": "track"},
                "recheck_all": {"recheck.earlier": "any"},
                "pixel_halves": {"body.window_per_pixel": True},
                "mean_refused": {"body.mean_refused_gate": False},
                "mean_trend": {"body.mean_refused_gate": True},
                "mass_crossing": {"body.mass_column": True},
                "upper_filter": {"body.column_rows": 0.5},
                "upper_always": {"body.column_rows": 0.5, "body.column_filter_only": True},
                "upper_median": {"body.column_rows": 0.5, "recheck.median_pace": True},
                "upper_strongest": {"body.column_rows": 0.5, "recheck.strongest_pace": True},
                "upper_column": {"body.column_filter_only": False},
                "core_column": {"body.column_filter_only": False}}
# tracker keys a rule's OFF side sets besides its own, where the defaults are not that side
# (rules 54 and 55 on since decision 55: the OFF side of the rules built with them is the
# defaults before it, no column rule and the deciding window's pace)
TRACKER_WITH_OFF = {"upper_filter": {"body.column_rows": None},
                    "upper_median": {"body.column_rows": None, "recheck.strongest_pace": False},
                    "upper_strongest": {"body.column_rows": None,
                                        "recheck.strongest_pace": False},
                    "core_column": {"body.column_rows": None}}
ALL = TRACKER_SOURCES + COUNT_SOURCES + ("pets_boxes",)
DEFAULT_ON = {"half_pace": (), "high_foot": ("synthetic",), "hop": ALL,
              "relink": ALL, "stitch": ALL, "parts": ALL, "sample_estimate": (),
              "velocity_jump": ALL, "still": ALL, "still_end": ALL,
              "stabilise": ALL, "reid": (), "candidates": (), "count_candidates": (),
              "shared_overlap": (), "split_depth": TRACKER_SOURCES,
              "split_shared": TRACKER_SOURCES, "side_anchor": (), "min_height": TRACKER_SOURCES,
              "min_height_track": (), "recheck": TRACKER_SOURCES, "recheck_all": (),
              "recheck_tail": TRACKER_SOURCES, "recheck_speed": (),
              "core_column": (), "upper_column": (), "height_fallback": (),
              "pace_window": (), "window_per_pixel": (), "top_inside": TRACKER_SOURCES,
              "twice_pace": TRACKER_SOURCES, "count_twice": COUNT_SOURCES,
              "count_edge": COUNT_SOURCES, "twice_edge": TRACKER_SOURCES,
              "count_low": COUNT_SOURCES, "twice_fitted": (), "trend": (), "hop4": (),
              "tail": (), "lean": (), "count_twice_fitted": (), "halves": (),
              "recheck_resolved": (), "pixel_halves": (), "recheck_low": (),
              "recheck_speed_low": TRACKER_SOURCES, "mean_refused": (),
              "halves_around": (), "mean_trend": TRACKER_SOURCES,
              "window_low": TRACKER_SOURCES, "pace_tall": TRACKER_SOURCES, "median_pace": (),
              "mass_column": (), "mass_crossing": (), "twice_sub": (), "across": (),
              "across_solo": TRACKER_SOURCES, "fast_stretch": (),
              "twice_quantile": (), "upper_filter": TRACKER_SOURCES,
              "upper_always": (), "upper_median": (), "strongest_pace": TRACKER_SOURCES,
              "upper_strongest": TRACKER_SOURCES, "stride_peak": TRACKER_SOURCES + ("pets_boxes",),
              "count_stride": (), "twice_refit": (), "low_refit": (),
              "relink_speed": TRACKER_SOURCES}
COUNT_VARIANTS = {
    "default": "not judged non-pedestrian, unjudged and too fast not counted (COUNT_RULE)",
    "no_speed_cut": "not judged non-pedestrian (every unjudged track counted)",
    "judged_only": "judged Pedestrian only (walkers_low)",
    "every_track": "every track (the counting paper, no classifier)",
}




def variant_mask(verdict, fast, name) -> list[bool]:
    """Per track, whether count variant `name` counts it."""
    if name == "default":
        return [w != "non-pedestrian" and not (w == "unclassified" and f)
                for w, f in zip(verdict, fast)]
    if name == "no_speed_cut":
        return [w != "non-pedestrian" for w in verdict]
    if name == "judged_only":
        return [w == "pedestrian" for w in verdict]
    return [True] * len(verdict)


def rows_of(out: dict) -> dict[str, dict]:
    """source row name -> {"v": verdict columns, "c": count clips} of a saved run."""
    import eval_all as ea

    out = ea.rescore(out)
    rows = {}
    for name, r in out["sources"].items():
        if "skipped" in r:
            continue
        if name in ("synthetic", "count"):
            for seed, s in r.items():
                rows[f"{name} {seed}"] = {"v": s.get("verdicts"), "c": s.get("clips")
                                          if name == "count" else None}
        elif name == "pets_count":
            rows[name] = {"v": None, "c": [r["clip"]]}
        else:
            rows[name] = {"v": r.get("verdicts"), "c": r.get("clips") if name == "dev_count"
                          else None}
    return rows


def _frac(a, b):
    return "-" if not b else f"{a}/{b}"


def verdict_cells(v, extra=False):
    if not v:
        return ["-"] * (4 if extra else 3)
    f = lambda x, fmt: "-" if x is None or not math.isfinite(x) else format(x, fmt)  # noqa: E731
    more = [f"{f(v.get('pace_mae_hz'), '.3f')} Hz, {f(v.get('step_median_err_cm'), '.1f')} cm"
            ] if extra else []
    return more + [_frac(v.get("walkers_pedestrian", 0), v.get("walkers_judged", 0)),
            _frac(v.get("classifiable_pedestrian", 0), v.get("walkers_classifiable", 0))
            if "walkers_classifiable" in v else "-",
            _frac(v.get("others_pedestrian", 0), v.get("others", 0))]


def count_cell(clips, variant="default"):
    if not clips:
        return "-"
    got = [c.get("variants", {}).get(variant, {"counted": c["counted"],
                                               "others_counted": c.get("others_counted", 0)})
           for c in clips]
    true = sum(c["true"] for c in clips)
    unowned = "?"
    if all("owner_kind" in c for c in clips):  # counted tracks that follow no truth object
        unowned = sum(sum(1 for m, o in zip(variant_mask(c["verdicts"], c["too_fast"], variant),
                                             c["owner_kind"]) if m and o is None)
                      for c in clips)
    err = sum(abs(g["counted"] - c["true"]) for g, c in zip(got, clips)) / true if true else \
        math.nan
    mota = [c["mota"] for c in clips if math.isfinite(c.get("mota", math.nan))]
    mota = f", MOTA {sum(mota) / len(mota):.3f}" if mota and variant == "default" else ""
    return f"{sum(g['counted'] for g in got)}/{true} ({100 * err:.1f} %{mota}, " \
           f"{sum(g['others_counted'] for g in got)} non-walkers, {unowned} on no object)"


def rule_table(rule: str, on: dict, off: dict) -> str:
    a, b = rows_of(on), rows_of(off)
    lines = [f"### {rule}: ON {RULES[rule][2]!r} vs OFF (paper) {RULES[rule][3]!r}; chosen on: "
             f"{RULES[rule][5]}", "",
             "| source | walkers Ped./judged ON / OFF | walkers Ped./all classifiable ON / OFF | "
             "non-walkers Ped./all ON / OFF | pace MAE, step err. median ON / OFF | walkers "
             "counted/true (err., non-walkers counted) ON / OFF | quick |",
             "|---|---|---|---|---|---|---|"]
    for name in a:
        if name not in b:
            continue
        va, vb = verdict_cells(a[name]["v"], True), verdict_cells(b[name]["v"], True)
        va, vb = va[1:] + va[:1], vb[1:] + vb[:1]
        cells = [f"{x} / {y}" + (" **changed**" if x != y else "") for x, y in zip(va, vb)]
        ca, cb = count_cell(a[name]["c"]), count_cell(b[name]["c"])
        cells.append(f"{ca} / {cb}" + (" **changed**" if ca != cb else ""))
        lines.append(f"| {name} | " + " | ".join(cells) + f" | {on.get('quick')} |")
    return "\n".join(lines)


def count_rule_table(out: dict) -> str:
    rows = rows_of(out)
    lines = ["### counting of unjudged tracks and the speed cut (one run, the defaults)", "",
             "| source | " + " | ".join(COUNT_VARIANTS) + " |", "|---|" + "---|" * len(
                 COUNT_VARIANTS)]
    for name, r in rows.items():
        if r["c"]:
            lines.append(f"| {name} | " + " | ".join(count_cell(r["c"], k)
                                                    for k in COUNT_VARIANTS) + " |")
    return "\n".join(lines) + "\n\n" + "\n".join(f"- {k}: {d}" for k, d in COUNT_VARIANTS.items())


def seeds_tables(outdir: Path) -> None:
    """Rules run on other own-scene seeds (`--seeds`): ON and OFF files side by side."""
    for rule in RULES:
        for on in sorted(outdir.glob(f"{rule}-on-seeds-*.json")):
            off = outdir / on.name.replace("-on-", "-off-")
            if off.is_file():
                print(rule_table(rule, json.loads(on.read_text()), json.loads(off.read_text()))
                      .replace("### ", f"### (seeds {on.stem.split('-seeds-')[1]}) ", 1))
                print()
    for d in sorted(outdir.glob("still-on-seeds-*.json")):  # the defaults' counting run
        print(count_rule_table(json.loads(d.read_text())).replace(
            "### ", f"### (seeds {d.stem.split('-seeds-')[1]}) ", 1).split("\n\n- ")[0])
        print()


def table(outdir: Path) -> None:
    seeds_tables(outdir)
    for rule in RULES:
        on, off = outdir / f"{rule}-on.json", outdir / f"{rule}-off.json"
        d = outdir / "default-on.json"
        base = json.loads(d.read_text()) if d.is_file() else {"sources": {}}
        sides = {}
        for state, path in (("on", on), ("off", off)):
            got = json.loads(path.read_text()) if path.is_file() else {"sources": {}}
            # a source the rule's side was not run on: the defaults' run, where the default
            # is that side
            for n, r in base["sources"].items():
                if n not in got["sources"] and n in RULES[rule][4] and \
                        (n in DEFAULT_ON[rule]) == (state == "on"):
                    got["sources"][n] = r
                    got.setdefault("quick", base.get("quick"))
            sides[state] = got
        if sides["on"]["sources"] and sides["off"]["sources"]:
            print(rule_table(rule, sides["on"], sides["off"]))
            print()
    d = outdir / "default-on.json"
    if d.is_file():
        print(count_rule_table(json.loads(d.read_text())))
    f = outdir / "fitted-on.json"
    if f.is_file() and d.is_file():
        fit = json.loads((outdir / "fitted_sets.json").read_text())
        print("\n### walking model and P_thr, R_thr, k_sigma3 fitted on own training seeds "
              f"{TRAIN_SEEDS}: " + ", ".join(f"{a}.{b}={c:.4g}" for a, b, c in fit["sets"]))
        b = fit["fit"]["balanced_accuracy"]
        print(f"\nfitting layer's own split (training seeds' tracks, 30 % held out): train "
              f"{b['train']:.3f}, held-out {b['test']:.3f}, held-out with the start config "
              f"{b['test_start']:.3f}\n")
        print("| held-out own seed (labelled tracks, batch classifier) | start config | fitted "
              "| fitted walking and thresholds, start width model |\n|---|---|---|---|")
        for seed, r in fit["held_out_seeds"].items():
            print(f"| {seed} | " + " | ".join(
                f"BA {r[k]['ba']:.3f} (TPR {r[k]['tpr']:.3f}, TNR {r[k]['tnr']:.3f}; "
                f"{r[k]['judged']}/{r[k]['labelled']} judged)" for k in
                ("start", "fitted", "fitted_no_width")) + " |")
        a, c = rows_of(json.loads(d.read_text())), rows_of(json.loads(f.read_text()))
        print("\n| source (eval_all, by object) | defaults | fitted walking + thresholds |"
              "\n|---|---|---|")
        for name in c:
            if name in a and c[name]["v"]:
                print(f"| {name} | {ba_cells(a[name]['v'])}; "
                      f"{' / '.join(verdict_cells(a[name]['v']))} | {ba_cells(c[name]['v'])}; "
                      f"{' / '.join(verdict_cells(c[name]['v']))} |")
