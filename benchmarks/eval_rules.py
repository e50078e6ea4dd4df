"""Rules beyond the paper, leave-one-source-out (issue 16 item 3, "Rules that generalise").

For each rule this runs `benchmarks/eval_all.py`'s sources twice, the rule ON (the value the
project chose) and OFF (the paper's setting), and prints per source the change ON - OFF in
walkers judged Pedestrian of those judged, walkers judged Pedestrian of all classifiable,
non-walkers judged Pedestrian and the count error (per-clip errors summed), with the source the
rule was chosen on (docs/validation.md, sources table; `git log -S`). A rule is worth keeping
only where it helps on the sources it was NOT chosen on.

Rules (`RULES`; each sets one key for every source, whatever that source's default is):
- half_pace: `thresholds.harmonic_max_ratio` 0.25 (ON) vs 0 (the paper's (13)-(15)).
- high_foot: the tracker's `body.high_foot_widths` 0.25 vs 0 (tracker sources only).
- hop: overlapping rhythm windows, `thresholds.window_hop_samples` 0 (= N/2) vs N (the paper's
  back-to-back windows; N is each source's own window, so it is set by patching
  `Thresholds.hop_samples` in this process and written as a number for `rhythm --boxes`).
- relink: the tracker's re-acquisition `relink.within_s` 3 s vs 0 (off).
- stitch: counting's `stitch.enabled` True vs False (counting sources only).
- parts: the tracker's `body.parts_widths` 1.8 W vs 0 (a body's motion regions joined).
- sample_estimate: the tracker's window B at the filtered foot point (True) vs the measured one.
- velocity_jump: counting's "3d" end on a ground-velocity jump, `life.max_dv_mps` 1.5 vs 1e9.
- still: counting's still / ghost rule, `life.still_s` 5 s vs 0 (off).
- stabilise: the tracker's `motion.stabilise` (camera-shake alignment) True vs False (needs a
  tree that has it: after d9d8d45).
- reid: counting's `stitch.reid` True vs False (default off; after d9d8d45).
- candidates: the tracker's candidate windows B (`body.window_candidates`, issue 16 item 2)
  True vs False (`rhythm --boxes`: `--window-candidates`); count_candidates: counting's
  (`verdicts.window_candidates`).
- shared_overlap: the tracker's `body.shared_overlap` 0.8 vs 0.5 (the default): two tracks'
  detections are one shared blob (no measurement, no rhythm sample for either) only when they
  overlap by 0.8 of the smaller box (issue 16, why walkers are missed: docs/rules.md).
- split_shared: the tracker's `body.split_shared` True (the default) vs False: a shared blob
  is split between its sharers, each re-detected in a window as wide as its predicted body box
  (`track/split.py`; docs/rules.md, why walkers are missed); split_depth: its depth split,
  `body.split_depth_widths` 0.5 (the default, with split_shared) vs 0.
- min_height: the tracker's `size.min_height_heights` 0.5 vs 0 (rule 26: a track judged
  Pedestrian whose median measured height over its deciding window's rows is below half a
  walker's is Non-pedestrian; 26c); min_height_track: the same over every row of the track (26b).
- recheck: the tracker's `recheck.enabled` (rule 29: a Pedestrian track split at its first later
  window faster than any walk or with a peak faster than any walking pace).
- recheck_all: the tracker's `recheck.tail` and `recheck.earlier` (rule 30: the same test on the
  window of a Pedestrian track's last N rows and on the windows before its deciding one);
  recheck_tail: `recheck.tail` alone (rule 30a); recheck_speed: `recheck.earlier` "speed"
  (rule 30b: the windows before the deciding one, by the speed test alone).
- core_column: the tracker's `body.column_fraction` 0.3 vs None (rule 32b: where a detection is
  wider than its predicted body box, the foot column u_p is the centre of the columns reaching
  0.3 of the vertical projection's maximum, not 0.1's; both sides without rule 54's
  `body.column_rows`, ON with `body.column_filter_only` False).
- height_fallback: the tracker's `size.min_height_scope` "window-or-track" vs "window" (the
  default; rule 26f: a deciding window with fewer than `size.min_height_rows` readable heights
  is read over the whole track).
- upper_column: the tracker's `body.column_rows` 0.5 vs None (rule 33: where a detection is
  wider than its predicted body box, u_p is the centre of the slice extent of the motion's
  columns over the top half of its rows; ON with `body.column_filter_only` False, window B and
  the box moved too).
- pace_window: the tracker's `body.pace_window_widths` 2.0 vs 0 (rule 34: a Pedestrian window's
  pace and stride from I(k) of window B scaled by 2 where that window says Pedestrian too).
- window_per_pixel: the tracker's `body.window_per_pixel` True vs False (rule 35: I(k) the
  mean of D over window B, grey levels per pixel, instead of its sum).
- mean_refused: the tracker's `body.window_mean_refused` True (with `body.mean_refused_gate`
  False) vs False (rule 35b: rule 35's mean read only where the sum refuses a window).
- relink_speed: the tracker's `relink.side_rows` 0.25 (the default since the fifty-seventh round)
  vs 0 (rule 57: at a track's end, a relink whose observed rows next to its gap, N/4 a side,
  move faster on either side than any walk (14) accepts, 2.57 m/s, least-squares over the
  filter's ground positions, is undone: each side a track of its own, judged afresh;
  `track.relink.fast_gap`).
- halves_around: the tracker's `recheck.halves_around` True vs False (rule 44: rule 42's half
  test on the windows before and after the deciding one only).
- mean_trend: rule 35b with rule 35c's gate (`body.window_mean_refused` and
  `body.mean_refused_gate` True, the defaults) vs `body.window_mean_refused` False: the mean read
  only where the sum's strongest peak is a trend, and kept only where neither half of the window
  is faster than any walk.
- window_low: the tracker's `size.every_window` True vs False (rule 45: rule 26 on every
  window as it completes, so matching goes on past a window too low for a walker).
- pace_tall: the tracker's `recheck.pace_tall` True vs False (rule 46: a later window refused
  by rule 29's pace test alone kept where its rows are a walker's height by rule 37's test).
- median_pace: the tracker's `recheck.median_pace` True vs False (rule 47: a Pedestrian track's
  pace and stride the medians over its windows judged Pedestrian; verdicts unchanged; since
  decision 55 OFF is rule 55's strongest window, which rule 47 replaces where on).
- mass_column: the tracker's `body.mass_column` True vs False (rule 48: window B's column on a
  measured frame the mean column of the motion over the body, `track.lean.motion_column`).
- mass_crossing: the tracker's `body.mass_crossing` 0.7071 with `body.mass_column` vs the
  defaults (rule 48b: rule 48 only where the track crosses the line of sight at >= 45 degrees).
- twice_sub: the tracker's `size.twice_pace_sub` 0.02 vs 0 (rule 49: rule 37 only where the
  window also has a peak near half its strongest, the walker's own pace).
- top_inside: the tracker's `size.top_inside_heights` 0.1 vs 0 (rule 36: the size rule also
  reads rows where a walker's head would leave the image but the measured top lies inside it).
- twice_pace: the tracker's `size.twice_pace_heights` 0.57 (fitted) vs 0 (rule 37: a window
  refused by (14) judged at half its strongest peak where the height is a walker's).
- trend: `thresholds.trend_max_cycles` 2 vs 0 (rule 38: a window not judged Pedestrian whose
  strongest peak completes fewer than 2 cycles over the window, a trend, judged again with its
  least-squares line removed; every classifier, tracker and count alike).
- hop4: rhythm windows every N/4 samples (rule 39) vs N/2 (the default), each source's own N
  (patched in this process as hop's OFF side is, and written as a number for `rhythm --boxes`).
- tail: a tail window (rule 40; a tracker patch, tracker sources only): a track that ends with
  no Pedestrian window has its last N rows judged too where they start after its last judged
  window, against today (no tail window).
- lean: the tracker's `body.lean_column` True vs False (rule 41: window B's column moved by the
  lean of an upright body at half its height, `track.lean`).
- count_twice: counting's `verdicts.twice_pace_heights` 0.57 vs 0 (rule 37 in the batch
  classifier that judges count's tracks, heights from the tracks' v_top).
- twice_edge: the tracker's `size.twice_pace_edge` True vs False (rule 37b: rule 37's height
  reading also counts rows whose motion reaches the image's first row, at the height up to it).
- count_edge: counting's `verdicts.twice_pace_edge` True vs False (rule 37's height reading also
  counts rows whose blobs reach the image's first row, at the height up to it: a lower bound).
- twice_fitted: the tracker's `size.twice_pace_heights` at its fitted 0.57 vs the a priori 0.75
  (`benchmarks/fit_height_threshold.py`); count_twice_fitted: counting's, the same values.
- count_low: counting's `verdicts.min_height_heights` 0.5 vs 0 (rule 26 in count's verdicts:
  a window judged Pedestrian lower than half a walker is refused, too-low).
- across_solo: the tracker's `body.across_candidates` True (the default since the fifty-first
  round) vs False (rule 50b: window B moved 0.1 W left and right as two more candidate windows
  B, deciding only by (13)-(15) at their own peak, never through rule 37). across: the same
  windows deciding as the tracker's own candidates do, rule 37 on them too (rule 50; the option
  and a patch).
- fast_stretch: the tracker's `recheck.fast_stretch` 0.25 vs 0 (rule 52: after a Pedestrian
  track's deciding window, the first stretch of N/4 rows whose filter's ground speed (median) is
  above the fastest walk, 2.57 m/s, cuts the track: a bicycle that took over a walker's track
  for fewer than N rows at its end).
- twice_quantile: the tracker's `size.twice_pace_quantile` 0.25 vs 0.5 (rule 53: rule 37's
  height the lower quartile of its rows' heights, not their median).
- upper_filter: the tracker's `body.column_filter_only` True with `body.column_rows` 0.5 (the
  defaults since decision 55) vs False with None (rule 54: rule 33's upper-body column as the
  filter's measurement only, window B and its candidates on the slice extent's centre, the
  paper's u_p). The OFF sides of the rules built with rules 54 and 55 set the keys of the
  defaults before decision 55 (`TRACKER_WITH_OFF`).
- upper_always: upper_filter on every detection with a predicted body box, not only the wider
  ones (`body.column_everywhere`, rule 54b).
- upper_median: upper_filter with `recheck.median_pace` (rules 54 and 47: the track's pace and
  stride the medians over its Pedestrian windows) vs neither rule, rule 55 off.
- strongest_pace: the tracker's `recheck.strongest_pace` True (the default since decision 55)
  vs False (rule 55: a Pedestrian track's pace and stride those of its Pedestrian window whose
  chosen peak is the strongest).
- upper_strongest: upper_filter with `recheck.strongest_pace` (rules 54 and 55, the defaults)
  vs neither (decision 55).
- stride_peak: the tracker's `size.stride_peak` True (the default since decision 56) vs False
  (rule 56: a window whose strongest peak passes (14) at twice its frequency, a walker's stride
  frequency F/2, judged there on rule 37's height); `rhythm --boxes` gets --[no-]stride-peak.
- twice_refit: the tracker's `size.twice_pace_heights` 0.51 (rule 37's height threshold refitted
  by `fit_height_threshold.py` under the defaults of issue 16's fifty-fifth round) vs 0.57 (the
  earlier fit); rules 46 and 56 read the same test.
- low_refit: the tracker's `size.min_height_heights` 0.47 (rule 26's height threshold refitted
  by the same study) vs 0.5 (the a priori value); count's verdicts keep 0.5.
- count_stride: count's `verdicts.stride_peak` True vs False (the default: rule 56 in count's
  verdicts, off since its screen counted PETS09 27 -> 30).
- still_end: only the still rule's end of a track that stands still (patched off in this
  process), the drop of tracks that never moved kept.
The counting rule needs no second run: every counting run records, per clip, the walkers each
variant of the rule counts (`COUNT_VARIANTS`): the default (tracks not judged non-pedestrian,
less unjudged tracks faster than the walking model allows: the speed cut `too_fast`), no speed
cut (every unjudged track counted), judged only (only tracks judged Pedestrian), every track
(the counting paper's rule, no classifier).

    python benchmarks/eval_rules.py run RULE on|off --only SOURCES [--quick] -d OUTDIR
    python benchmarks/eval_rules.py table -d OUTDIR          # every rule found in OUTDIR
    python benchmarks/eval_rules.py fit -d OUTDIR            # item 2: fit on own seeds 5555, 6666
    python benchmarks/eval_rules.py run fitted on --only synthetic,dev,pets_boxes,ucsd,casia,pets \\
        -d OUTDIR                                            # ... its keys on the other sources

Runs are saved as OUTDIR/RULE-on.json and OUTDIR/RULE-off.json (eval_all.py's layout, plus the
count variants); `default` (`run default on`) is the defaults' run: the table takes a source's
side from it where that side is the source's default (`DEFAULT_ON`; the own scenes run with
sim.presets' half-pace and high-foot rules on), so only the other side needs a run. `--seeds
A,B` runs the own scenes (synthetic, count) on two other seeds (RULE-STATE-seeds-A-B.json, both
sides run). Nothing is chosen here: it only measures. docs/rules.md has the figures and the
exact commands (issue 16 item 3):

    python benchmarks/eval_rules.py run default on -d OUT
    python benchmarks/eval_rules.py run high_foot on --only dev,pets,casia,ucsd -d OUT
    python benchmarks/eval_rules.py run high_foot off --only synthetic -d OUT   # and so on
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path


sys.path.insert(0, str(Path(__file__).resolve().parent))

from eval_rules_fit import fit_rules  # noqa: E402
from eval_rules_table import (  # noqa: E402
    COUNT_VARIANTS,
    RULES,
    TRACKER_WITH,
    TRACKER_WITH_OFF,
    table,
    variant_mask,
)


# ----------------------------------------------------------------------------------------------
# patches: the rule's setting reaches every source


def _patch_tracker(changes: dict) -> None:
    """`rhythmjax.track.track_frames` with `changes` applied to whatever options it is given."""
    import rhythmjax.track as tr
    from rhythmjax.track.options import TrackerOptions, with_changes

    inner = tr.track_frames

    def track_frames(cfg, frames, *a, options=None, **k):
        return inner(cfg, frames, *a, options=with_changes(options or TrackerOptions(), changes),
                     **k)

    tr.track_frames = track_frames


def _patch_tail_window() -> None:
    """Rule 40 as a tracker patch (measured before it is built): when a track ends with no
    Pedestrian window and its last N rows start after its last judged window, those N rows
    are judged too (at most N/4 of them missing), as `track.toolkit.match_window` judges any
    window (`track.tracker` calls it with final=True at a track's end)."""
    import math

    import rhythmjax.track.tracker as trk
    from rhythmjax.model.rhythm import MAX_MISSING_FRACTION

    inner = trk.match_window

    def match_window(cfg, obj, *, final=False, **kw):
        n, hop = cfg.thresholds.n, cfg.thresholds.hop_samples
        k = len(obj.rows) - n
        if final and obj.result is not None and not obj.decided and k > obj.win_start - hop:
            missing = sum(not math.isfinite(r.intensity) for r in obj.rows[k:])
            if missing <= MAX_MISSING_FRACTION * n:
                obj.win_start = k
                inner(cfg, obj, **kw)
            return None
        return inner(cfg, obj, final=final, **kw)

    trk.match_window = match_window


def _patch_across_any() -> None:
    """Rule 50 (`across`) from rule 50b's option (`body.across_candidates`, set by the rule's
    "tracker" kind): the windows moved across decide as the tracker's own candidates do, rule
    37's second look on whichever is strongest (`track.toolkit`'s judgement with each object's
    `across` read as 0). Measured first as a patch of its own (docs/rules.md, rules 50 and 50b),
    whose verdicts this reproduces."""
    import rhythmjax.track.toolkit as tk

    inner = tk._judged

    def judged(cfg, obj, window, sigs, rest, candidates):
        across = getattr(obj, "across", 0)
        obj.across = 0
        try:
            return inner(cfg, obj, window, sigs, rest, candidates)
        finally:
            obj.across = across

    tk._judged = judged


def _patch_count(changes: dict) -> None:
    import rhythmjax.count as cnt
    from rhythmjax.count.options import CountOptions
    from rhythmjax.track.options import with_changes

    inner = cnt.count_frames

    def count_frames(cfg, frames, *a, options=None, **k):
        return inner(cfg, frames, *a, options=with_changes(options or CountOptions(), changes),
                     **k)

    cnt.count_frames = count_frames


def _patch_hop_n(divisor: int = 1) -> None:
    """Windows every N // divisor samples everywhere in this process (1: back-to-back, the
    paper; 4: rule 39), and `rhythm --boxes` (a subprocess) given that hop as a number."""
    import eval_all as ea

    from rhythmjax.model.params import Thresholds, config_from_dict

    Thresholds.hop_samples = property(lambda self: max(1, self.n // divisor))
    base = ea.apply_set

    def apply_set(d, s):
        out = base(d, s)
        if "fps" in out.get("camera", {}):  # PETS's Tsai section and the dev clips carry it
            out.setdefault("thresholds", {})["window_hop_samples"] = max(
                1, config_from_dict(out).thresholds.n // divisor)
        return out

    ea.apply_set = apply_set


def count_clip(cfg, frames, truth, kinds, offset) -> dict:
    """eval_all.count_clip plus, per count variant, the walkers counted and the non-walkers
    among them."""
    import eval_count as ec
    import numpy as np

    import rhythmjax.count as cnt
    from rhythmjax.evaluation.motscore import score_mot

    res = cnt.count_frames(cfg, iter(frames), n_frames=len(frames))
    v = res.verdicts
    ids = [int(i) for i in v["track_id"]]
    verdict = [str(x) for x in v["verdict"]]
    fast = [bool(f) for f in np.asarray(v.get("too_fast", np.zeros(len(ids), bool)))]
    walk = ec.walking_ids(res)
    seen = set(np.asarray(truth["id"]).tolist())
    twalk = [t for t in seen if kinds.get(t) == "pedestrian"]
    s = score_mot(truth, res.mot, frame_offset=offset, walking_ids=walk, truth_walking_ids=twalk)
    own = ec.owner_of_tracks(truth, res.mot, offset)
    pick = {k: [i for i, c in zip(ids, variant_mask(verdict, fast, k)) if c]
            for k in COUNT_VARIANTS}
    variants = {k: {"counted": len(h), "others_counted": sum(
        1 for t in h if own.get(t) and kinds.get(own[t]) != "pedestrian")}
        for k, h in pick.items()}
    assert variants["default"]["counted"] == len(walk), "COUNT_RULE changed: update the variants"
    return {"counted": len(walk), "true": len(twalk), "mota": s.mota, "idf1": s.idf1,
            "id_switches": s.id_switches, "counts": res.counts,
            "others_counted": variants["default"]["others_counted"], "variants": variants,
            "verdicts": verdict, "too_fast": fast,
            "speed_mps": [float(x) for x in np.asarray(v.get("track_speed_mps", []))],
            "owner_kind": [kinds.get(own.get(t)) if own.get(t) else None for t in ids]}


def run(rule: str, state: str, only, quick: bool, outdir: Path, seeds=None) -> Path:
    import eval_all as ea
    import eval_count as ec
    import eval_synthetic as es

    if seeds:  # own scenes of other seeds (synthetic and count: the runners' two seeds)
        es.SEED, ec.SEED, ea.FRESH_SEED = seeds[0], seeds[0], seeds[-1]

    from rhythmjax.evaluation import datasets  # noqa: F401  (fail early)

    ea.count_clip = count_clip  # the runners look it up at call time
    sets = []
    if rule == "fitted":
        sets = [tuple(x) for x in json.loads((outdir / "fitted_sets.json").read_text())["sets"]]
    elif rule != "default":
        kind, key, on, off, _, _ = RULES[rule]
        val = on if state == "on" else off
        if kind == "config":
            sets = [(key[0], key[1], val)]
        elif kind == "tracker":
            with_keys = (TRACKER_WITH if state == "on" else TRACKER_WITH_OFF).get(rule, {})
            _patch_tracker({key: val, **with_keys})
            if key == "body.window_candidates":  # `rhythm --boxes` runs in a subprocess
                ea.RHYTHM_FLAGS.append(f"--{'' if val else 'no-'}window-candidates")
            if key == "size.stride_peak":
                ea.RHYTHM_FLAGS.append(f"--{'' if val else 'no-'}stride-peak")
        elif kind == "count":
            _patch_count({key: val})
        elif kind == "patch" and state == "off":
            # only the ending of a track that stands still (its patch copied into the
            # background); the drop of tracks that never moved (`counting.ghost`) stays
            from rhythmjax.count.pedestrian_level import PedestrianLevel

            PedestrianLevel._still = lambda self, p: False
        elif kind == "hop" and state == "off":
            _patch_hop_n(1)
        elif kind == "hop4" and state == "on":
            _patch_hop_n(4)
        elif kind == "tail" and state == "on":
            _patch_tail_window()
        if rule == "across" and state == "on":
            _patch_across_any()
    names = only or (RULES[rule][4] if rule in RULES else ea.SOURCES)
    log = lambda s: print(s, file=sys.stderr, flush=True)  # noqa: E731
    path = outdir / (f"{rule}-{state}.json" if not seeds else
                     f"{rule}-{state}-seeds-{'-'.join(map(str, seeds))}.json")
    out = json.loads(path.read_text()) if path.is_file() else {"sources": {}}
    out.update({"rule": rule, "state": state, "quick": quick})
    for n in names:
        why = ea.available(n)
        t0 = time.perf_counter()
        try:
            out["sources"][n] = {"skipped": why} if why else ea.RUNNERS[n](sets, quick, log)
        except Exception as e:  # noqa: BLE001
            out["sources"][n] = {"skipped": f"failed: {type(e).__name__}: {e}"}
            log(f"{n} failed: {e!r}")
        out.setdefault("seconds", {})[n] = time.perf_counter() - t0
        log(f"{rule}-{state} {n}: {out['seconds'][n]:.0f} s")
        path.write_text(json.dumps(out, indent=1, default=float))
    return path


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = p.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("run")
    r.add_argument("rule", choices=("default", "fitted") + tuple(RULES))
    r.add_argument("state", choices=("on", "off"))
    r.add_argument("--only", help="comma-separated sources (default: those the rule touches)")
    r.add_argument("--quick", action="store_true")
    r.add_argument("--seeds", help="two comma-separated own-scene seeds instead of the runners' "
                   "(synthetic, count); saved as RULE-STATE-seeds-A-B.json")
    r.add_argument("-d", "--dir", default="eval_rules")
    fp = sub.add_parser("fit")
    fp.add_argument("--scenes", type=int, default=10, help="scenes per seed")
    fp.add_argument("-d", "--dir", default="eval_rules")
    t = sub.add_parser("table")
    t.add_argument("-d", "--dir", default="eval_rules")
    a = p.parse_args(argv)
    outdir = Path(a.dir)
    outdir.mkdir(parents=True, exist_ok=True)
    if a.cmd == "table":
        table(outdir)
        return 0
    if a.cmd == "fit":
        fit_rules(outdir, a.scenes, lambda s: print(s, file=sys.stderr, flush=True))
        return 0
    only = tuple(s.strip() for s in a.only.split(",")) if a.only else None
    seeds = tuple(int(x) for x in a.seeds.split(",")) if a.seeds else None
    print(run(a.rule, a.state, only, a.quick, outdir, seeds))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
