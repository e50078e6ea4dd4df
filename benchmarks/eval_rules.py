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
- split_shared: the tracker's `body.split_shared` True vs False (the default): a shared blob
  is split between its sharers, each re-detected in a window as wide as its predicted body box
  (`track/split.py`; docs/rules.md, why walkers are missed).
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
import math
import sys
import time
from pathlib import Path


sys.path.insert(0, str(Path(__file__).resolve().parent))

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
    "count_candidates": ("count", "verdicts.window_candidates", True, False, COUNT_SOURCES,
                         "none: offsets -0.2, -0.1, +0.1 W set a priori (docs/window_b.md)"),
    "reid": ("count", "stitch.reid", True, False, COUNT_SOURCES,
             "own counting seeds (left off: neutral there; 95875e0)"),
    "still_end": ("patch", "PedestrianLevel._still", "on", "off (ghost drop kept)",
                  COUNT_SOURCES, "none: set from geometry (1ad0850, issue 16 item 4)"),
}
# the sources where the rule is ON in the defaults eval_all.py runs with (the own scenes use
# sim.presets' SYNTHETIC_CONFIG and SYNTHETIC_OPTIONS)
ALL = TRACKER_SOURCES + COUNT_SOURCES + ("pets_boxes",)
DEFAULT_ON = {"half_pace": ("synthetic", "count"), "high_foot": ("synthetic",), "hop": ALL,
              "relink": ALL, "stitch": ALL, "parts": ALL, "sample_estimate": (),
              "velocity_jump": ALL, "still": ALL, "still_end": ALL,
              "stabilise": ALL, "reid": (), "candidates": (), "count_candidates": (),
              "shared_overlap": (), "split_shared": ()}
COUNT_VARIANTS = {
    "default": "not judged non-pedestrian, unjudged and too fast not counted (COUNT_RULE)",
    "no_speed_cut": "not judged non-pedestrian (every unjudged track counted)",
    "judged_only": "judged Pedestrian only (walkers_low)",
    "every_track": "every track (the counting paper, no classifier)",
}


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


def _patch_count(changes: dict) -> None:
    import rhythmjax.count as cnt
    from rhythmjax.count.options import CountOptions
    from rhythmjax.track.options import with_changes

    inner = cnt.count_frames

    def count_frames(cfg, frames, *a, options=None, **k):
        return inner(cfg, frames, *a, options=with_changes(options or CountOptions(), changes),
                     **k)

    cnt.count_frames = count_frames


def _patch_hop_n() -> None:
    """Back-to-back windows (the paper) everywhere in this process: hop = N."""
    from rhythmjax.model.params import Thresholds

    Thresholds.hop_samples = property(lambda self: self.n)


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
            _patch_tracker({key: val})
            if key == "body.window_candidates":  # `rhythm --boxes` runs in a subprocess
                ea.RHYTHM_FLAGS.append(f"--{'' if val else 'no-'}window-candidates")
        elif kind == "count":
            _patch_count({key: val})
        elif kind == "patch" and state == "off":
            # only the ending of a track that stands still (its patch copied into the
            # background); the drop of tracks that never moved (`counting.ghost`) stays
            from rhythmjax.count.pedestrian_level import PedestrianLevel

            PedestrianLevel._still = lambda self, p: False
        elif kind == "hop" and state == "off":
            _patch_hop_n()
            # `rhythm --boxes` runs in a subprocess: give it PETS's N as a number
            from rhythmjax.model.params import config_from_dict
            base = ea.apply_set

            def apply_set(d, s):
                out = base(d, s)
                cam = out.get("camera", {})
                if "fps" in cam:  # PETS's Tsai section and the dev clips carry their fps
                    out.setdefault("thresholds", {})["window_hop_samples"] = \
                        config_from_dict(out).thresholds.n
                return out

            ea.apply_set = apply_set
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


# ----------------------------------------------------------------------------------------------
# the table


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


# ----------------------------------------------------------------------------------------------
# item 2: the walking model and (P_thr, R_thr, k_sigma3) fitted from labelled own-scene tracks

TRAIN_SEEDS = (5555, 6666)  # the own training seeds (the project's rules were chosen on them)
HELD_OUT_SEEDS = (20240603, 777_001)  # the own evaluation seed and the fresh seed


def labelled_batch(cfg, seeds, n_scenes, log):
    """The tracker's tracks on own scenes of `seeds` (eval_synthetic's scenes and tracker
    options), each labelled with the kind of the object it follows (`sim.evaluate.match_tracks`;
    a track that follows none is unlabelled and left out of the fit)."""
    import eval_synthetic as es
    import numpy as np

    from fit.walking import batch_of
    from rhythmjax.sim.evaluate import match_tracks

    keys = ("track_id", "frame", "t", "u", "v", "width_px", "intensity")
    cols = {k: [] for k in keys + ("label",)}
    for seed in seeds:
        for s, spec in es.scene_specs(seed, n_scenes, camera=cfg.camera):
            _, tracks, _, scene, _ = es.run_scene(cfg, s, spec)
            own = match_tracks(tracks, scene.truth)
            tid = np.asarray(tracks["track_id"])
            fr = np.asarray(tracks["frame"])
            for t in np.unique(tid):
                m = tid == t
                first = np.zeros_like(m)  # one row per frame (a re-linked track can hold two)
                first[np.flatnonzero(m)[np.unique(fr[m], return_index=True)[1]]] = True
                m = first
                for k in keys[1:]:
                    cols[k].append(np.asarray(tracks[k])[m])
                cols["track_id"].append(np.full(m.sum(), f"{s}-{int(t)}", dtype=object))
                lab = own[int(t)].kind if int(t) in own else ""
                cols["label"].append(np.full(m.sum(), lab, dtype=object))
        log(f"labelled tracks of seed {seed}")
    cols = {k: np.concatenate(v) for k, v in cols.items()}
    return batch_of(cols, cfg)


def fit_rules(outdir: Path, n_scenes: int, log) -> dict:
    """Fit on the training seeds (the fitting layer's own stratified 30 % held out), score the
    start and the fitted config on the held-out seeds' labelled tracks; write the fitted keys
    as `--set` items (OUTDIR/fitted_sets.json) for `run fitted on`."""
    import eval_synthetic as es
    import numpy as np

    from fit.walking import balanced_accuracy, decide, features, fit_walking
    from rhythmjax.model.params import config_from_dict

    d = json.loads(json.dumps(es.RECOMMENDED))
    d.setdefault("thresholds", {})["harmonic_max_ratio"] = 0.0  # the paper's (13)-(15)
    cfg = config_from_dict(d)
    train = labelled_batch(cfg, TRAIN_SEEDS, n_scenes, log)
    r = fit_walking(cfg, train, test_fraction=0.3, seed=0)
    log(r.summary())
    out = {"fit": r.to_dict(), "held_out_seeds": {}}
    for seed in HELD_OUT_SEEDS:
        b = labelled_batch(cfg, (seed,), n_scenes, log)
        lab = np.asarray(b.labels, dtype=object)
        pos, use = lab == "pedestrian", lab != ""
        row = {}
        for name, c in (("start", cfg), ("fitted", r.config), ("fitted_no_width", cfg.__class__(
                cfg.camera, cfg.noise, cfg.width, r.config.walking, r.config.thresholds))):
            f = features(c, b)
            v = np.asarray(decide(c.walking, c.thresholds, f)[0])
            ba, tpr, tnr = balanced_accuracy(v, pos, use)
            row[name] = {"ba": float(ba), "tpr": float(tpr), "tnr": float(tnr),
                         "judged": int(np.sum(use & (v != 0))), "labelled": int(use.sum())}
        out["held_out_seeds"][str(seed)] = row
        log(f"held-out seed {seed}: {row}")
    w, t = r.config.walking, r.config.thresholds
    out["sets"] = [["walking", "pace_mean_hz", float(w.pace_mean)],
                   ["walking", "pace_std_hz", float(w.pace_std)],
                   ["walking", "stride_mean_m", float(w.stride_mean)],
                   ["walking", "stride_std_m", float(w.stride_std)],
                   ["thresholds", "p_thr", float(t.p_thr)],
                   ["thresholds", "r_thr", float(t.r_thr)],
                   ["thresholds", "k_sigma3", float(t.k_sigma3)]]
    (outdir / "fitted_sets.json").write_text(json.dumps(out, indent=1, default=float))
    return out


def ba_cells(v: dict) -> str:
    """Balanced accuracy over the judged objects of a verdict row: TPR = walkers Pedestrian /
    walkers judged, TNR = non-walkers not Pedestrian / non-walkers judged."""
    if not v:
        return "-"
    wj, oj = v.get("walkers_judged", 0), v.get("others_judged", 0)
    tpr = v.get("walkers_pedestrian", 0) / wj if wj else math.nan
    tnr = (oj - v.get("others_pedestrian", 0)) / oj if oj else math.nan
    ba = 0.5 * (tpr + tnr) if wj and oj else math.nan
    f = lambda x: "-" if not math.isfinite(x) else f"{x:.3f}"  # noqa: E731
    return f"BA {f(ba)} (TPR {f(tpr)}, TNR {f(tnr)})"


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
