"""Why walkers are missed on the own synthetic scenes and the dev clips (issue 16; a study).

The complement of `study_false_positives.py`: the same tracks (rendered and tracked as
`eval_synthetic.evaluate` does, cached under ``-d DIR`` by `study_false_positives.track_scene`
and `dev_scenes`; the dev clips as `eval_all.run_dev` tracks them), scored by track as eval_all
and eval_rules score them (`sim.evaluate.score`: an object's verdict is that of its longest
judged assigned track). Every walker not judged Pedestrian that counts against a target (the
classifiable ones, and any judged one: the dev clips' truth's `classifiable`, the own scenes'
`sim.clean.classifiable`, the same convention; every own walker before issue 16's forty-first
round) gets one cause:
- (a) `no track`: no track is assigned to it (`match_tracks`); sub-cause `never detected` (no
  tracked row within the scoring limit of its foot point, max(15 px, 0.35 x its width)) or
  `rows only in others' tracks` (tracks whose rows were nearest it, assigned elsewhere);
- (b) `unclassified tracks`: its assigned tracks are all unclassified: fewer than N rows, or
  N or more with over N/4 of every N rows unsampled (`fewest_missing`: shared blobs); each
  fragment (and each other track with >= 5 rows nearest it) is listed with its length, the
  rows nearest it, and why it ended (`end_reason`: PREDICT time-out, split by what the timed-out
  rows held: a measurement the gates refused, a blob shared with another track, no detection;
  the range left; the clip's end; else merged into an older track, `MergeOptions`);
- (c) `judged Non-ped.`: the longest judged track said Non-pedestrian; every rhythm window of
  it is replayed (`fp_replay.replay`, all windows): reason code, P of the strongest peak
  against P_thr, pace F / stride T against the truth, the object the window followed
  (`window_objects`; another one: an identity switch) and the nearest truth foot point per row;
- (d) `scored elsewhere`: a deciding window that followed it said Pedestrian (eval_synthetic's
  "by window" score) but the by-track score does not (the Pedestrian track is assigned to
  another object, or a longer assigned track said Non-pedestrian).
Each also gets the tracking mechanism behind it: `shared blobs` (a track on it timed out in
frames whose blob it shared, or has over N/4 unsampled in every N rows) and/or `switch` (a track
of >= N rows with >= 5 rows on it is assigned to another object, or its window followed one).
And `P_true`: window B on its TRUE foot point (W from the walker width model at the ground
point under it; the tracker's difference images, `eval_window_b.differences`), the best P from
its first to its last visible frame (N rows, one window every hop, `study_window_offsets.
judge_window`) and whether a window then says Pedestrian; for (c) also in the judged track's
windows' own frames. Nothing in the library changes; it only measures. ``--option`` tracks the
own scenes with a tracker option changed (a cache of its own), to try a rule on them.

    python benchmarks/study_missed_walkers.py 5555 6666 20240603 777001 dev [--scenes 10]
        [-d /tmp/study_fp] [--no-true-foot]
    python benchmarks/study_missed_walkers.py 5555 6666 --no-true-foot \
        --option body.shared_overlap=0.8

Seeds 5555 and 6666 are the training seeds (a rule's constant may be chosen there); 20240603,
777001 and the dev clips are reported only.
"""

from __future__ import annotations

import argparse
import collections
import json
import math
import sys
import types
from pathlib import Path

import numpy as np


sys.path.insert(0, str(Path(__file__).parent))

import eval_window_b as ew  # noqa: E402
from eval_synthetic import RECOMMENDED, scene_specs  # noqa: E402
from fp_replay import replay  # noqa: E402
from study_tracks import dev_scenes, nearest_per_row, track_scene  # noqa: E402
from study_window_offsets import judge_window  # noqa: E402

from rhythmjax.model.camera_np import ground_of_pixels, image_width_of  # noqa: E402
from rhythmjax.model.params import config_from_dict  # noqa: E402
from rhythmjax.model.status import REASON_LABELS, TrackState  # noqa: E402
from rhythmjax.sim.evaluate import deciding_windows, match_tracks, score, window_objects  # noqa: E402,E501
from rhythmjax.sim.presets import synthetic_options  # noqa: E402
from rhythmjax.track.columns import verdict_columns  # noqa: E402
from rhythmjax.track.options import TrackerOptions  # noqa: E402
from rhythmjax.vision.detect import window_b_intensity  # noqa: E402


CATEGORIES = ("a no track", "b unclassified tracks", "c judged Non-ped.", "d scored elsewhere")


# ----------------------------------------------------------------------------------------------
# geometry and the rhythm at the true foot point


def limit_px(x, f: int) -> float:
    """The scoring limit (px) of `sim.evaluate.match_tracks` at frame f: max(15, 0.35 W_img)."""
    w = x.width_px[f]
    return max(15.0, 0.35 * w) if math.isfinite(w) else 15.0


def true_geometry(cfg, x):
    """Per frame of object x: ground (x, y) m under its true foot point, W px (the walker width
    model `width.mean` at that y, as the tracker's window B) and ok (visible, finite)."""
    u, v = np.asarray(x.u, float), np.asarray(x.v, float)
    fin = np.isfinite(u) & np.isfinite(v)
    gx, gy, ok = ground_of_pixels(cfg.camera, np.where(fin, u, 0.0), np.where(fin, v, 0.0))
    ok = np.asarray(ok) & fin & np.asarray(x.visible, bool)
    W = np.where(ok, image_width_of(cfg.camera, float(cfg.width.mean), np.where(ok, gy, 1.0)),
                 np.nan)
    return np.stack([gx, gy], 1), W, ok


def true_p(cfg, D, x, frames) -> tuple[float, bool, int]:
    """(best P, any window Pedestrian, windows judged) of window B at x's true foot point over
    `frames` (consecutive frame indices), N rows, one window every hop; P of a window is its
    strongest peak's power (13); 0 where it has no peak."""
    xy, W, ok = true_geometry(cfg, x)
    frames = np.asarray(frames, int)
    sig = np.array([window_b_intensity(D[f], x.u[f], x.v[f], W[f])
                    if ok[f] and D[f] is not None else math.nan for f in frames])
    t = frames / float(cfg.camera.fps)
    n, hop = int(cfg.thresholds.n), int(cfg.thresholds.hop_samples)
    best, ped, cnt = math.nan, False, 0
    for k in range(0, len(frames) - n + 1, hop):
        r = judge_window(cfg, t, sig, np.nan_to_num(xy[frames]), k)
        if r is None:
            continue
        cnt += 1
        best = r[0] if not math.isfinite(best) else max(best, r[0])
        ped |= r[1]
    return best, ped, cnt


# ----------------------------------------------------------------------------------------------
# tracks against the truth


def nearest_rows(objs, truth) -> dict[int, collections.Counter]:
    """{track_id: Counter(object id -> rows whose measured foot point is nearest that object's
    true one and within its scoring limit, `limit_px`)}."""
    out = {}
    for o in objs:
        c = collections.Counter()
        for r in o.rows:
            if not math.isfinite(r.u):
                continue
            f, best, bd = int(r.frame), None, math.inf
            for x in truth:
                if f < len(x.u) and x.visible[f]:
                    d = math.hypot(r.u - x.u[f], r.v - x.v[f])
                    if d < bd:
                        best, bd = x, d
            if best is not None and bd <= limit_px(best, f):
                c[best.track_id] += 1
        out[o.track_id] = c
    return out


def end_reason(cfg, o, x, n_frames: int) -> tuple[str, str]:
    """Why track o ended, read from its rows (the tracker records no reason): the clip's end,
    the detection range left (filtered ground y), a PREDICT time-out (the trailing PREDICT
    rows: 'gate' a measurement the gates (10)/(11) refused, 'shared' a blob shared with another
    track, 'none' no detection; 'walker gone' when x was no longer visible after it), else
    merged into an older track (the only other way a track ends: `MergeOptions`). Returns (a
    short label: a time-out by what most of its rows held, the text)."""
    last = o.rows[-1]
    if int(last.frame) >= n_frames - 1:
        return "clip end", "clip end"
    thr = cfg.thresholds
    if not float(thr.range_min) <= last.y_est <= float(thr.range_max):
        return "left range", f"left range (y {last.y_est:.1f} m)"
    if last.state == TrackState.PREDICT:
        trail = []
        for r in reversed(o.rows):
            if r.state != TrackState.PREDICT:
                break
            trail.append(r)
        gate = sum(math.isfinite(r.u) for r in trail)
        shared = sum(not math.isfinite(r.u) and not math.isfinite(r.intensity) for r in trail)
        gone = x is not None and not x.visible[min(int(last.frame) + 1, n_frames - 1)]
        none = len(trail) - gate - shared
        most = max((shared, "shared"), (gate, "gate"), (none, "none"))[1]
        return ("walker gone" if gone else f"time-out: {most}",
                f"PREDICT time-out ({len(trail)} rows: gate {gate}, shared {shared}, none "
                f"{none}{'; walker gone' if gone else ''})")
    return "merged", "merged into an older track"


def window_text(cfg, o, w, tracks, truth, x, D) -> str:
    """One replayed rhythm window of track o: rows, frames, reason, P vs P_thr, F, T, the
    object it followed, P at x's true foot point in the same frames, nearest truth per row."""
    n, out = cfg.thresholds.n, w["out"]
    k = w["k"]
    f0, f1 = int(o.rows[k].frame), int(o.rows[k + n - 1].frame)
    p = np.asarray(out["peak_power"])[np.asarray(out["peak_mask"])]
    follow = window_objects(tracks, truth, {o.track_id: (f0, f1)}).get(o.track_id)
    pt = "" if D is None else f" P_true {true_p(cfg, D, x, range(f0, f1 + 1))[0]:.1f}"
    return (f"    rows {k}-{k + n - 1} frames {f0}-{f1} cand {w['cand']}: "
            f"{REASON_LABELS[int(out['reason'])]}, P {p.max() if p.size else 0:.1f} (P_thr "
            f"{float(cfg.thresholds.p_thr):g}){pt}, F {float(out['pace_hz']):.2f} T "
            f"{float(out['stride_m']):.2f} R {float(out['ratio']):.2f} v "
            f"{float(out['speed_mps']):.2f}; followed {getattr(follow, 'track_id', 'none')}; "
            f"nearest {nearest_per_row(o, k, k + n, truth)}")


def fewest_missing(o, n: int) -> int:
    """The fewest rows without a rhythm sample (NaN I(k): a shared blob or a glitch frame) in
    any N rows of track o (more than N/4: no window is judged; -1: fewer than N rows)."""
    bad = np.array([not math.isfinite(r.intensity) for r in o.rows])
    if len(bad) < n:
        return -1
    c = np.concatenate([[0], np.cumsum(bad)])
    return int(np.min(c[n:] - c[:-n]))


def missing_text(o, n: int) -> str:
    """Rows of track o without a rhythm sample, and the fewest in any N rows."""
    bad = sum(not math.isfinite(r.intensity) for r in o.rows)
    m = fewest_missing(o, n)
    return f"{bad} rows unsampled" + (f", >= {m} in any N rows" if m >= 0 else "")


def crowding(cfg, x, truth) -> str:
    """Frames x was visible, and of them those with another visible object's true foot point
    within 1 W of its own (a close pass: merges, shared blobs, switches)."""
    _, W, ok = true_geometry(cfg, x)
    close = 0
    for f in np.flatnonzero(ok):
        close += any(y is not x and f < len(y.u) and y.visible[f]
                     and math.hypot(y.u[f] - x.u[f], y.v[f] - x.v[f]) < W[f] for y in truth)
    return f"visible {int(ok.sum())} frames, {close} within 1 W of another object"


# ----------------------------------------------------------------------------------------------
# one scene


def missed_walkers(name, cfg, tracks, objs, truth, D) -> tuple[list[dict], dict]:
    """(one record per walker that counts and is not judged Pedestrian by track, the scene's
    tallies: walkers that count, judged, Pedestrian, non-walkers Pedestrian)."""
    n = cfg.thresholds.n
    n_frames = len(truth[0].u)
    verdicts = verdict_columns(objs, n)
    by_t = score(tracks, verdicts, truth)["objects"]
    by_w = score(tracks, verdicts, truth, windows=deciding_windows(objs))["objects"]
    assigned = match_tracks(tracks, truth)
    looked = window_objects(tracks, truth, deciding_windows(objs))
    near = nearest_rows(objs, truth)
    by_id = {o.track_id: o for o in objs}
    vd = {int(t): str(v) for t, v in zip(verdicts["track_id"], verdicts["verdict"])}
    rs = {int(t): str(v) for t, v in zip(verdicts["track_id"], verdicts["reason"])}
    owner = lambda t: getattr(assigned.get(t), "track_id", "none")  # noqa: E731
    recs, tally = [], collections.Counter()
    for rt, rw, x in zip(by_t, by_w, truth):
        judged = rt["verdict"] in ("pedestrian", "non-pedestrian")
        if x.kind != "pedestrian":
            tally["others_ped"] += rt["verdict"] == "pedestrian"
            continue
        counts = getattr(x, "classifiable", True)
        ped = rt["verdict"] == "pedestrian"
        tally.update(walkers=counts, judged=judged, ped=ped, ped_all=counts and ped)
        if ped or not (counts or judged):
            continue
        mine = sorted((t for t, o in assigned.items() if o is x), key=lambda t: -len(
            by_id[t].rows))
        followers = sorted((t for t, c in near.items() if c[x.track_id] >= 5),
                           key=lambda t: -near[t][x.track_id])
        rel = list(dict.fromkeys(mine + followers))
        lines = [f"  {crowding(cfg, x, truth)}"]
        if rw["verdict"] == "pedestrian":
            cat = CATEGORIES[3]
            for t, o in looked.items():
                if o is x and vd[t] == "pedestrian":
                    lines.append(f"  track {t} ({len(by_id[t].rows)} rows) said Pedestrian in "
                                 f"a window on it; assigned to {owner(t)}")
            sub = ("Ped. track assigned elsewhere" if any(
                owner(t) != x.track_id for t, o in looked.items() if o is x and vd[t] ==
                "pedestrian") else "a longer assigned track Non-ped.")
        elif rt["verdict"] == "missed":
            cat = CATEGORIES[0]
            sub = "rows only in others' tracks" if followers else "never detected"
        elif rt["verdict"] == "unclassified":
            cat = CATEGORIES[1]
            ends = [end_reason(cfg, by_id[t], x, n_frames)[0] for t in mine]
            long = sum(len(by_id[t].rows) >= n for t in mine)
            sub = (f"{len(mine) - long} fragment(s) < N, {long} >= N unusable; ends: "
                   + ", ".join(sorted(set(ends))))
        else:
            cat = CATEGORIES[2]
            t = next(t for t in mine if vd[t] != "unclassified")
            o = by_id[t]
            wins = replay(cfg, o, stop=False)
            best = max(wins, key=lambda w: float(np.max(np.where(
                np.asarray(w["out"]["peak_mask"]), np.asarray(w["out"]["peak_power"]), 0))))
            f0, f1 = int(o.rows[best["k"]].frame), int(o.rows[best["k"] + n - 1].frame)
            follow = window_objects(tracks, truth, {t: (f0, f1)}).get(t)
            sub = REASON_LABELS[int(best["out"]["reason"])] + (
                "" if follow is x else f", switch (on {getattr(follow, 'track_id', 'none')})")
            lines.append(f"  judged track {t} ({len(o.rows)} rows, assigned {owner(t)}), "
                         f"{len(wins)} windows; truth pace {x.pace_hz:.2f} Hz, step "
                         f"{x.step_length_m:.2f} m")
            lines += [window_text(cfg, o, w, tracks, truth, x, D) for w in wins]
        for t in rel:
            o = by_id[t]
            lines.append(f"  track {t}: {len(o.rows)} rows (frames {int(o.rows[0].frame)}-"
                         f"{int(o.rows[-1].frame)}), {near[t][x.track_id]} nearest it, "
                         f"assigned {owner(t)}, {vd[t]} ({rs[t]}), {missing_text(o, n)}; end: "
                         f"{end_reason(cfg, o, x, n_frames)[1]}")
        # the tracking mechanism behind it: blobs shared with another track (a time-out in
        # them, or every N rows with over N/4 unsampled) and identity switches (a track of
        # >= N rows with rows on it assigned to another object, or a window on another)
        shared = any(end_reason(cfg, by_id[t], x, n_frames)[0] == "time-out: shared" or
                     fewest_missing(by_id[t], n) > n // 4 for t in rel)
        switch = ("switch" in sub or sub == "Ped. track assigned elsewhere" or any(
            len(by_id[t].rows) >= n and owner(t) != x.track_id for t in followers))
        mech = " + ".join(m for m, on in (("shared blobs", shared), ("switch", switch))
                          if on) or "neither"
        vis = np.flatnonzero(x.visible)
        pt = ((math.nan, False, 0) if D is None or not vis.size
              else true_p(cfg, D, x, range(int(vis[0]), int(vis[-1]) + 1)))
        recs.append({"scene": name, "object": x.track_id, "verdict": rt["verdict"],
                     "cat": cat, "sub": sub, "mech": mech, "P_true": pt[0],
                     "ped_true": pt[1], "lines": lines})
    return recs, tally


# ----------------------------------------------------------------------------------------------
# sources


def own_source(cfg, seed: int, n_scenes: int, cache: Path, true_foot: bool, changes=None):
    """(scene name, cfg, tracks, objs, truth, D or None) of one seed's own scenes; `changes`:
    tracker options changed from the scenes' (`synthetic_options`), tracked into their own
    cache directory."""
    from rhythmjax.sim.clean import classifiable
    from rhythmjax.sim.scene import render_scene
    from rhythmjax.track.options import with_changes

    opt = with_changes(synthetic_options(), changes or {})
    for i, (s, spec) in enumerate(scene_specs(seed, n_scenes, camera=cfg.camera)):
        tracks, _, objs, truth = track_scene(cfg, s, spec, cache / str(seed), opt)
        scene = render_scene(s, spec)
        flags = classifiable(scene, n=int(cfg.thresholds.n))
        truth = [types.SimpleNamespace(**vars(x), classifiable=flags[x.track_id][1])
                 for x in truth]  # the dev convention (sim.clean), as the dev clips' truth
        D = ew.differences(list(scene.frames), synthetic_options()) if true_foot else None
        yield f"{seed}:{i}", cfg, tracks, objs, truth, D


def dev_source(cache: Path, true_foot: bool):
    """The same for the dev clips with single objects (report only)."""
    frames = {name: f for name, _, f, _ in ew.dev_clips()} if true_foot else {}
    for clip, cfg, tracks, objs, truth in dev_scenes(cache):
        D = ew.differences(frames[clip], TrackerOptions()) if true_foot else None
        yield clip, cfg, tracks, objs, truth, D


def run_source(label: str, scenes) -> tuple[list[dict], collections.Counter]:
    recs, tally = [], collections.Counter()
    for name, cfg, tracks, objs, truth, D in scenes:
        r, t = missed_walkers(name, cfg, tracks, objs, truth, D)
        recs += r
        tally.update(t)
    print(f"=== {label}: walkers Pedestrian {tally['ped']} of {tally['judged']} judged, "
          f"{tally['ped_all']} of {tally['walkers']} classifiable; non-walkers Pedestrian "
          f"{tally['others_ped']}", flush=True)
    for r in recs:
        pt = ("" if not math.isfinite(r["P_true"]) else
              f"; P_true {r['P_true']:.1f} ({'Ped.' if r['ped_true'] else 'not Ped.'})")
        print(f"{r['scene']} {r['object']}: {r['verdict']} -> {r['cat']}: {r['sub']}{pt}; "
              f"tracking: {r['mech']}")
        print("\n".join(r["lines"]), flush=True)
    return recs, tally


def table(results: dict) -> None:
    """Markdown: per source the causes and the tracking mechanisms; then per walker."""
    mechs = ("shared blobs", "switch", "shared blobs + switch", "neither")
    print("\n| source | walkers Ped. / judged | Ped. / classifiable | " + " | ".join(
        CATEGORIES + mechs) + " |\n|---|---|---|" + "---|" * (len(CATEGORIES) + len(mechs)))
    for label, (recs, tally) in results.items():
        c = collections.Counter(r["cat"] for r in recs) + collections.Counter(
            r["mech"] for r in recs)
        print(f"| {label} | {tally['ped']}/{tally['judged']} | {tally['ped_all']}/"
              f"{tally['walkers']} | " + " | ".join(str(c[k]) for k in CATEGORIES + mechs) + " |")
    print("\n| source | walker | cause | detail | tracking | P_true (Ped.?) |\n"
          "|---|---|---|---|---|---|")
    for label, (recs, _) in results.items():
        for r in recs:
            pt = "-" if not math.isfinite(r["P_true"]) else (
                f"{r['P_true']:.1f} ({'yes' if r['ped_true'] else 'no'})")
            print(f"| {label} | {r['scene']} {r['object']} | {r['cat']} | {r['sub']} | "
                  f"{r['mech']} | {pt} |")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("sources", nargs="+", help="own scene seeds and/or 'dev'")
    p.add_argument("--scenes", type=int, default=10)
    p.add_argument("-d", "--cache", default="/tmp/study_fp")
    p.add_argument("--no-true-foot", action="store_true",
                   help="skip P at the true foot point (no rendering, no video decoding)")
    p.add_argument("--option", action="append", default=[], metavar="GROUP.KEY=JSON",
                   help="own scenes: track with this tracker option changed (a cache of its "
                        "own under -d), e.g. body.shared_overlap=0.8")
    a = p.parse_args(argv)
    cache, tf = Path(a.cache), not a.no_true_foot
    changes = {k: json.loads(v) for k, _, v in (o.partition("=") for o in a.option)}
    if changes:
        cache = cache / "_".join(f"{k}={v}" for k, v in sorted(changes.items()))
    cfg = config_from_dict(RECOMMENDED)
    results = {}
    for src in a.sources:
        scenes = (dev_source(cache, tf) if src == "dev"
                  else own_source(cfg, int(src), a.scenes, cache, tf, changes))
        results[src] = run_source(src, scenes)
    table(results)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
