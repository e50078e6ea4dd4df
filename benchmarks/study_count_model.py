"""A counting rule fitted from labelled tracks (issue 16, counting; a study: it measures, it
changes no default): a logistic model of whether a track is a distinct walker, fitted on
counting runs saved by `benchmarks/count_dump.py`, applied to others.

Per track of a saved clip, the features `track_features` (the verdict and its reason, the
measured time, the speed against the walking model's top speed, the width, how much of it a
longer track covers within 1 m on the ground, whether it continues or precedes a longer track,
whether it starts or ends with the clip or at the image's border; `--cap-samples`: the
measured time capped at one rhythm window) and the label, `--labels owned` (`track_labels`: 1
for the track with the most rows among those a true walker owns, `eval_count.owner_of_tracks`;
0 for every other track: a second track on a walker, a non-walker, nothing) or `--labels
distinct` (`distinct_labels`: 1 for the tracks of a maximum-weight matching of tracks to the
walkers they are on, so a track that switched walkers can stand for either). The model
p = sigmoid(w . x + c) on standardised features is fitted by optimistix (BFGS, an L2 penalty
`--l2` on w) on the --train runs. A clip's count is the number of its tracks with p >= 0.5
(`--estimator threshold`) or the sum of p rounded (`--estimator sum`). `--judged-verdict`:
the tracks the classifier judged keep the paper's verdict (Pedestrian counted, Non-pedestrian
not), and the model is fitted on, and decides, only the tracks too short to judge.

Per run and pooled: walkers counted / true and per-clip |errors| summed, for the run's own `counted`
(the defaults' COUNT_RULE) and for the model, the paired change with its 95 % bootstrap interval
over clips (`paired_count.paired_change`), non-walkers counted, the balanced accuracy of both rules
and the model's ROC AUC on the labels; and two bounds: "labelled", the count of a perfect rule for
the labels (the walkers that own a track with `owned`), and "distinct", the most tracks that stand
for distinct walkers (`distinct_walkers`), beyond which no rule that keeps or drops tracks can count
without counting a walker twice.

    python benchmarks/study_count_model.py --train A.pkl B.pkl ... --test C.pkl D.pkl ... \\
        [--l2 0.01] [--estimator threshold|sum] [--labels owned|distinct] \\
        [--cap-samples 64] [--judged-verdict] [--json OUT.json]
    python benchmarks/study_count_model.py --unowned RUN.pkl ...   # why walkers own no track
"""

from __future__ import annotations

import argparse
import json
import os
import pickle
import sys

import numpy as np


sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from count_bounds import distinct_labels, distinct_walkers  # noqa: E402
from eval_count import owner_of_tracks  # noqa: E402
from paired_count import paired_change  # noqa: E402


FEATURES = ("pedestrian", "no_peak", "non_pedestrian_other", "log_seconds", "measured_fraction",
            "speed_ratio", "speed_missing", "too_fast", "width_ratio", "width_missing",
            "covered_1m", "continues", "precedes", "starts_with_clip", "ends_with_clip",
            "starts_at_border", "ends_at_border")


def table1_scales() -> tuple[float, float]:
    """(the walking model's top speed m/s, `count.walking_top_speed`; the mean body width m)
    of Table 1's config: the features' scales, the same for every source."""
    from rhythmjax.count import walking_top_speed
    from rhythmjax.model.params import Config

    cfg = Config()
    return walking_top_speed(cfg), float(cfg.width.mean)


def track_features(row: dict) -> tuple[np.ndarray, list[int]]:
    """(features (B, len(FEATURES)), track ids) of one saved clip (`count_dump.py`)."""
    from rhythmjax.count.explain import measured_points

    v, tr = row["verdicts"], row["tracks"]
    top_speed, width_m = table1_scales()
    ids = [int(i) for i in v["track_id"]]
    pts = measured_points(tr, ids)
    fps = float(row["fps"])
    n_frames = int(row["summary"]["n_frames"])
    w_img, h_img = row.get("image_size", (512, 512))
    tid = np.asarray(tr["track_id"])
    out = []
    for k, i in enumerate(ids):
        verdict, reason = str(v["verdict"][k]), str(v["reason"][k])
        fr, p = pts[k]
        rows_i = tid == i
        n_meas = len(fr)
        speed = float(v["track_speed_mps"][k])
        width = float(v["width_m"][k])
        # ground cover by a longer track within 1 m in this track's measured frames
        covered = 0.0
        cont = prec = 0.0
        for j, (fj, pj) in enumerate(pts):
            if j == k or len(fj) <= n_meas or not len(fr):
                continue
            _, ia, ib = np.intersect1d(fj, fr, assume_unique=True, return_indices=True)
            if len(ia):
                covered = max(covered, float(np.mean(
                    np.hypot(*(pj[ia] - p[ib]).T) <= 1.0) * len(ia) / n_meas))
            for (f_end, p_end, f_start, p_start), slot in (
                    ((fj[-1], pj[-1], fr[0], p[0]), "c"), ((fr[-1], p[-1], fj[0], pj[0]), "p")):
                g = (f_start - f_end) / fps
                if 0 < g <= 3.0 and np.hypot(*(p_start - p_end)) <= 1.0 + top_speed * g:
                    if slot == "c":
                        cont = 1.0
                    else:
                        prec = 1.0
        uu, vv = np.asarray(tr["u"])[rows_i], np.asarray(tr["v"])[rows_i]
        ok = np.isfinite(uu) & np.isfinite(vv)
        frames = np.asarray(tr["frame"])[rows_i]

        def at_border(u, vrow):
            return float(min(u, w_img - u, h_img - vrow) <= 0.05 * w_img)

        first_f = int(frames.min()) if len(frames) else 0
        last_f = int(frames.max()) if len(frames) else 0
        out.append([
            float(verdict == "pedestrian"),
            float(verdict == "non-pedestrian" and reason == "no-peak"),
            float(verdict == "non-pedestrian" and reason != "no-peak"),
            float(np.log(max(n_meas, 1) / fps)),
            n_meas / max(1, int(rows_i.sum())),
            min(speed / top_speed, 3.0) if np.isfinite(speed) else 0.0,
            float(not np.isfinite(speed)),
            float(bool(v["too_fast"][k])),
            min(width / width_m, 3.0) if np.isfinite(width) else 0.0,
            float(not np.isfinite(width)),
            covered, cont, prec,
            float(first_f <= fps),
            float(last_f >= n_frames - 1 - fps),
            at_border(uu[ok][0], vv[ok][0]) if ok.any() else 0.0,
            at_border(uu[ok][-1], vv[ok][-1]) if ok.any() else 0.0,
        ])
    return np.asarray(out, np.float64).reshape(-1, len(FEATURES)), ids


def track_labels(row: dict, ids: list[int]) -> tuple[np.ndarray, np.ndarray]:
    """(label (B,): 1 for the longest track on each true walker, non-walker (B,) bool: the
    track's owner is a truth object that is no walker)."""
    own = owner_of_tracks(row["truth"], row["mot"], row["offset"])
    tid = np.asarray(row["tracks"]["track_id"])
    n = {i: int((tid == i).sum()) for i in ids}
    best: dict[int, int] = {}
    for i in ids:
        o = own.get(i)
        if o is not None and row["kinds"].get(o) == "pedestrian":
            if o not in best or n[i] > n[best[o]]:
                best[o] = i
    lab = np.asarray([float(best.get(own.get(i), -1) == i) for i in ids])
    other = np.asarray([own.get(i) is not None and row["kinds"].get(own.get(i)) != "pedestrian"
                        for i in ids], bool)
    return lab, other


def load(paths, labels: str = "owned", cap_samples: int = 0) -> list[dict]:
    """Per clip of every run: name, run, features, ids, labels (`labels` "owned":
    `track_labels`; "distinct": `distinct_labels`), non-walker flags, the defaults' counted
    flags, true walkers, the distinct bound. `cap_samples` > 0: the measured time capped at
    that many samples (one rhythm window, N / fps s)."""
    clips = []
    for path in paths:
        with open(path, "rb") as f:
            for row in pickle.load(f):
                x, ids = track_features(row)
                if cap_samples > 0:
                    k = FEATURES.index("log_seconds")
                    x[:, k] = np.minimum(x[:, k], np.log(cap_samples / float(row["fps"])))
                y, other = track_labels(row, ids)
                if labels == "distinct":
                    y = distinct_labels(row, ids)
                clips.append({"run": os.path.basename(path), "clip": row["clip"], "x": x,
                              "y": y, "other": other, "true": int(row["true"]),
                              "matchable": distinct_walkers(row, ids),
                              "default": np.asarray(row["verdicts"]["counted"], bool)})
    return clips


def fit_logistic(x: np.ndarray, y: np.ndarray, l2: float) -> tuple:
    """(mean (F,), scale (F,), weights (F + 1,), the intercept last) of a logistic regression
    fitted by optimistix BFGS on standardised features: minimises the mean log loss
    + l2 |w|^2 (the intercept free)."""
    import jax
    import jax.numpy as jnp
    import optimistix as optx

    mu, sd = x.mean(axis=0), x.std(axis=0)
    sd = np.where(sd > 0, sd, 1.0)
    with jax.enable_x64(True):
        xs, yj = jnp.asarray((x - mu) / sd), jnp.asarray(y)

        def loss(w, _):
            z = xs @ w[:-1] + w[-1]
            return jnp.mean(jnp.logaddexp(0.0, z) - yj * z) + l2 * jnp.sum(w[:-1] ** 2)

        sol = optx.minimise(loss, optx.BFGS(rtol=1e-9, atol=1e-9),
                            jnp.zeros(x.shape[1] + 1, jnp.float64), max_steps=2000)
        return mu, sd, np.asarray(sol.value)


def unjudged(x: np.ndarray) -> np.ndarray:
    """(B,) bool: the tracks the classifier did not judge (no verdict feature set)."""
    k = [FEATURES.index(n) for n in ("pedestrian", "no_peak", "non_pedestrian_other")]
    return ~x[:, k].astype(bool).any(axis=1)


def predict(model, x: np.ndarray, judged_verdict: bool = False) -> np.ndarray:
    """p = sigmoid(w . (x - mean) / scale + c) per row of `x`. `judged_verdict`: a judged
    track's p is its verdict (1 Pedestrian, 0 Non-pedestrian); the model decides the rest."""
    mu, sd, w = model
    z = ((x - mu) / sd) @ w[:-1] + w[-1]
    p = 1.0 / (1.0 + np.exp(-z))
    if judged_verdict:
        p = np.where(unjudged(x), p, x[:, FEATURES.index("pedestrian")])
    return p


def auc(score: np.ndarray, y: np.ndarray) -> float:
    """ROC AUC by the rank-sum (ties half)."""
    pos, neg = score[y == 1], score[y == 0]
    if not len(pos) or not len(neg):
        return float("nan")
    d = pos[:, None] - neg[None, :]
    return float(np.mean((d > 0) + 0.5 * (d == 0)))


def summarise(clips: list[dict], model, resamples: int = 10000,
              estimator: str = "threshold", judged_verdict: bool = False) -> dict:
    """Counted / true, per-clip |errors| summed (%), non-walkers counted, for the defaults and
    the model, the paired change with its 95 % bootstrap interval, balanced accuracy and AUC."""
    true = np.asarray([c["true"] for c in clips], np.float64)
    n_def = np.asarray([c["default"].sum() for c in clips], np.float64)
    probs = [predict(model, c["x"], judged_verdict) for c in clips]
    n_mod = np.asarray([(p >= 0.5).sum() if estimator == "threshold" else np.round(p.sum())
                        for p in probs], np.float64)
    n_orc = np.asarray([c["y"].sum() for c in clips], np.float64)
    n_mat = np.asarray([c["matchable"] for c in clips], np.float64)
    e_def, e_mod, e_orc = np.abs(n_def - true), np.abs(n_mod - true), np.abs(n_orc - true)
    oth_def = sum(int((c["default"] & c["other"]).sum()) for c in clips)
    oth_mod = sum(int(((p >= 0.5) & c["other"]).sum()) for c, p in zip(clips, probs))
    paired = paired_change({"true": true, "err_a": e_def, "err_b": e_mod,
                            "oth_a": np.asarray([oth_def]), "oth_b": np.asarray([oth_mod])},
                           resamples)
    y = np.concatenate([c["y"] for c in clips])
    s = np.concatenate(probs)
    d = np.concatenate([c["default"] for c in clips]).astype(float)
    bal = lambda pred: 0.5 * (np.mean(pred[y == 1]) + np.mean(1 - pred[y == 0]))  # noqa: E731
    return {"clips": len(clips), "true": int(true.sum()),
            "default": {"counted": int(n_def.sum()), "error_pct": 100 * e_def.sum() / true.sum(),
                        "others": oth_def, "balanced_accuracy": bal(d)},
            "model": {"counted": int(n_mod.sum()), "error_pct": 100 * e_mod.sum() / true.sum(),
                      "others": oth_mod, "balanced_accuracy": bal((s >= 0.5).astype(float)),
                      "auc": auc(s, y)},
            "labelled": {"counted": int(n_orc.sum()), "error_pct": 100 * e_orc.sum() / true.sum()},
            "distinct": {"counted": int(n_mat.sum()),
                         "error_pct": 100 * np.abs(n_mat - true).sum() / true.sum()},
            "change": 100 * paired["delta"],
            "interval": [100 * paired["lo"], 100 * paired["hi"]]}


def line(name: str, r: dict) -> str:
    d, m = r["default"], r["model"]
    return (f"{name:28s} true {r['true']:4d}  default {d['counted']:4d} {d['error_pct']:5.1f} % "
            f"oth {d['others']:3d} bal {d['balanced_accuracy']:.3f} | model {m['counted']:4d} "
            f"{m['error_pct']:5.1f} % oth {m['others']:3d} bal {m['balanced_accuracy']:.3f} "
            f"auc {m['auc']:.3f} | change {r['change']:+.1f} "
            f"[{r['interval'][0]:+.1f}, {r['interval'][1]:+.1f}] | labelled "
            f"{r['labelled']['counted']:4d} {r['labelled']['error_pct']:5.1f} % | distinct "
            f"{r['distinct']['counted']:4d} {r['distinct']['error_pct']:5.1f} %")


def long_runs(seq: list, min_len: int = 5) -> list:
    """The values of the runs of at least `min_len` equal consecutive items of `seq`, a run
    equal to the previous kept run merged into it (a track's walkers, blips of fewer frames
    left out)."""
    out: list = []
    k = 0
    while k < len(seq):
        j = k
        while j < len(seq) and seq[j] == seq[k]:
            j += 1
        if j - k >= min_len and (not out or out[-1] != seq[k]):
            out.append(seq[k])
        k = j
    return out


def unowned_report(path: str) -> list[str]:
    """Why walkers own no track, in one saved run: per walker without a track of its own, how
    often some track's box is on it (`diag_count_unjudged.frame_owners`: IoU >= 0.3) and whose
    that track is (another walker's, or nobody's: no majority owner), with `diag_count.
    free_fraction` for those never boxed; then the tracks whose box is on such a walker for
    >= 5 frames (each once), by how often they switch walkers (`long_runs`: runs of >= 5
    frames on one truth object)."""
    from diag_count import free_fraction
    from diag_count_unjudged import frame_owners

    with open(path, "rb") as f:
        rows = pickle.load(f)
    kinds_of: dict[str, int] = {}
    switches: dict[str, int] = {}
    seen: set = set()  # (clip, track) counted once
    for r in rows:
        tr = r["truth"]
        own = owner_of_tracks(tr, r["mot"], r["offset"])
        fo = frame_owners(tr, r["mot"], r["offset"])
        owned = set(own.values())
        lost = [int(t) for t in np.unique(tr["id"])
                if r["kinds"].get(int(t)) == "pedestrian" and int(t) not in owned]
        for t in lost:
            n_vis = int((tr["id"] == t).sum())
            on = {h: sum(o == t for o in d.values()) for h, d in fo.items()}
            by = [h for h, n in on.items() if n]
            frames_on = len({f for h in by for f, o in fo[h].items() if o == t})
            if not by:
                key = "never in a track's box (apart in >= half its frames: %s)" % (
                    "yes" if free_fraction(tr, t) >= 0.5 else "no")
            else:
                whose = "another walker's" if all(own.get(h) is not None for h in by) \
                    else "nobody's (or mixed)"
                share = ">=" if frames_on >= 0.25 * n_vis else "<"
                key = f"in a track's box in {share} 1/4 of its frames, the track {whose}"
            kinds_of[key] = kinds_of.get(key, 0) + 1
            for h, n in on.items():
                if n >= 5 and (r["clip"], h) not in seen:
                    seen.add((r["clip"], h))
                    k = len(long_runs([fo[h][f] for f in sorted(fo[h])])) - 1
                    key = "back and forth (>= 2 switches)" if k >= 2 else \
                        ("one switch" if k == 1 else "no switch")
                    switches[key] = switches.get(key, 0) + 1
    out = [f"{os.path.basename(path)}: {sum(kinds_of.values())} walkers own no track"]
    out += [f"  {n:4d} {k}" for k, n in sorted(kinds_of.items(), key=lambda q: -q[1])]
    out += ["  tracks on them: " + ", ".join(f"{n} {k}" for k, n in sorted(switches.items()))]
    return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--train", nargs="+", default=[])
    p.add_argument("--test", nargs="+", default=[])
    p.add_argument("--l2", type=float, default=0.01)
    p.add_argument("--estimator", default="threshold", choices=("threshold", "sum"))
    p.add_argument("--labels", default="owned", choices=("owned", "distinct"))
    p.add_argument("--cap-samples", type=int, default=0,
                   help="cap the measured time at this many samples (64: one window)")
    p.add_argument("--judged-verdict", action="store_true",
                   help="judged tracks keep the verdict; the model is fitted on, and decides, "
                        "the unjudged tracks only")
    p.add_argument("--unowned", nargs="+", default=[], metavar="RUN.pkl",
                   help="only report why walkers own no track in these runs")
    p.add_argument("--json")
    a = p.parse_args(argv)
    if a.unowned:
        for path in a.unowned:
            print("\n".join(unowned_report(path)))
        return 0
    if not a.train:
        p.error("--train is required (or --unowned)")
    train = load(a.train, a.labels, a.cap_samples)
    x = np.concatenate([c["x"] for c in train])
    y = np.concatenate([c["y"] for c in train])
    if a.judged_verdict:
        x, y = x[unjudged(x)], y[unjudged(x)]
    model = fit_logistic(x, y, a.l2)
    print("weights (standardised):", ", ".join(
        f"{n} {w:+.2f}" for n, w in zip(FEATURES + ("intercept",), model[2])))
    out = {"features": FEATURES, "mean": model[0].tolist(), "scale": model[1].tolist(),
           "weights": model[2].tolist(), "rows": {}}
    for tag, paths in (("train", a.train), ("test", a.test)):
        pooled = []
        for path in paths:
            clips = train if tag == "train" else load([path], a.labels, a.cap_samples)
            clips = [c for c in clips if c["run"] == os.path.basename(path)]
            pooled += clips
            out["rows"][path] = r = summarise(clips, model, estimator=a.estimator,
                                                  judged_verdict=a.judged_verdict)
            print(line(f"{tag} {os.path.basename(path)}", r))
        if len(paths) > 1:
            out["rows"][f"{tag} pooled"] = r = summarise(pooled, model, estimator=a.estimator,
                                                           judged_verdict=a.judged_verdict)
            print(line(f"{tag} pooled", r))
    if a.json:
        with open(a.json, "w") as f:
            json.dump(out, f, indent=1)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
