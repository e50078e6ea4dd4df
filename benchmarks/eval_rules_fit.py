"""Item 2 of issue 16 for `eval_rules.py fit`: the walking model and (P_thr, R_thr, k_sigma3)
fitted from labelled own-scene tracks (the fitting layer, `fit.walking`) on the training seeds,
scored on the held-out seeds' labelled tracks; `ba_cells` formats a verdict row's balanced
accuracy for `eval_rules.py table`."""

from __future__ import annotations

import json
import math
from pathlib import Path


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
