"""Paired comparison of two counting runs of `eval_count_options.py -o` on the same clips: the
change in the per-clip count errors, with a bootstrap confidence interval over clips.

Per clip i the count error is e_i = counted_i - true_i; a source's figure is the per-clip
errors summed, sum |e_i| / sum true_i (eval_all's column). For two runs A (before) and B (after)
of the same clips, the change is

    delta = (sum |e_B,i| - sum |e_A,i|) / sum true_i        (negative: B counts better)

and its 95 % interval is the percentile interval of delta over `--resamples` bootstrap draws of
the clips with replacement (the same draw for A and B: a paired bootstrap; fixed seed). Also
the change in non-walkers counted ("others"), summed. One row per pair of files (all its
sources' clips together), and with several pairs a row of all their clips pooled.

    python benchmarks/paired_count.py A.json B.json [A2.json B2.json ...] [--resamples 10000]
                                      [--json OUT.json]

Pairs are given as consecutive files (before, after); their sources must match clip for clip.
A row is named by its "before" file.
Nothing is chosen here: it measures.
"""

from __future__ import annotations

import argparse
import json
import sys

import numpy as np


def clip_rows(run: dict) -> dict[str, list[dict]]:
    """{source: its clips} of one `eval_count_options.py -o` file (`changes`, `clothing` and
    `focal_px` left out)."""
    return {k: v["clips"] for k, v in run.items() if isinstance(v, dict) and "clips" in v}


def paired_arrays(before: dict, after: dict, label: str) -> dict[str, np.ndarray]:
    """Per clip of matching sources: true walkers, |errors| before and after, others counted
    before and after. A source or clip count that differs is an error naming `label`."""
    a, b = clip_rows(before), clip_rows(after)
    if set(a) != set(b):
        raise SystemExit(f"{label}: sources differ: {sorted(a)} against {sorted(b)}")
    cols: dict[str, list] = {"true": [], "err_a": [], "err_b": [], "oth_a": [], "oth_b": []}
    for src in sorted(a):
        if len(a[src]) != len(b[src]):
            raise SystemExit(f"{label}: {src} has {len(a[src])} clips against {len(b[src])}")
        for ca, cb in zip(a[src], b[src]):
            if ca["true"] != cb["true"]:
                raise SystemExit(f"{label}: {src}: clips differ (true {ca['true']} against "
                                 f"{cb['true']})")
            cols["true"].append(ca["true"])
            cols["err_a"].append(abs(ca["counted"] - ca["true"]))
            cols["err_b"].append(abs(cb["counted"] - cb["true"]))
            cols["oth_a"].append(ca.get("others_counted", 0))
            cols["oth_b"].append(cb.get("others_counted", 0))
    return {k: np.asarray(v, np.float64) for k, v in cols.items()}


def paired_change(cols: dict[str, np.ndarray], resamples: int = 10000,
                  seed: int = 0) -> dict[str, float]:
    """Per-clip errors summed before and after (fractions of the true walkers), their change
    and its 95 % paired-bootstrap percentile interval; others counted before and after."""
    t, ea, eb = cols["true"], cols["err_a"], cols["err_b"]
    n = t.size
    rng = np.random.default_rng(seed)
    idx = rng.integers(0, n, size=(resamples, n))
    tt = np.maximum(t[idx].sum(1), 1.0)
    draws = (eb[idx].sum(1) - ea[idx].sum(1)) / tt
    lo, hi = np.percentile(draws, [2.5, 97.5])
    return {"clips": int(n), "true": int(t.sum()), "before": float(ea.sum() / t.sum()),
            "after": float(eb.sum() / t.sum()), "delta": float((eb.sum() - ea.sum()) / t.sum()),
            "lo": float(lo), "hi": float(hi), "others_before": int(cols["oth_a"].sum()),
            "others_after": int(cols["oth_b"].sum()),
            "clips_better": int(np.sum(eb < ea)), "clips_worse": int(np.sum(eb > ea))}


def line(name: str, r: dict) -> str:
    return (f"| {name} | {r['clips']} | {100 * r['before']:.1f} % | {100 * r['after']:.1f} % | "
            f"{100 * r['delta']:+.1f} [{100 * r['lo']:+.1f}, {100 * r['hi']:+.1f}] | "
            f"{r['clips_better']} / {r['clips_worse']} | {r['others_before']} -> "
            f"{r['others_after']} |")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("files", nargs="+", help="before/after pairs of eval_count_options -o files")
    p.add_argument("--resamples", type=int, default=10000)
    p.add_argument("--json", help="write the rows here")
    a = p.parse_args(argv)
    if len(a.files) % 2:
        print("give the files in before/after pairs", file=sys.stderr)
        return 2
    runs = []
    for name in a.files:
        with open(name) as f:
            runs.append(json.load(f))
    pairs = [(a.files[i], runs[i], runs[i + 1]) for i in range(0, len(runs), 2)]
    out, pooled = {}, []
    print("| pair | clips | before | after | change [95 %] | clips better / worse | others |")
    print("|---|---|---|---|---|---|---|")
    for name, before, after in pairs:
        cols = paired_arrays(before, after, name)
        pooled.append(cols)
        out[name] = paired_change(cols, a.resamples)
        print(line(name, out[name]))
    if len(pooled) > 1:
        cols = {k: np.concatenate([c[k] for c in pooled]) for k in pooled[0]}
        out["pooled"] = paired_change(cols, a.resamples)
        print(line("pooled", out["pooled"]))
    if a.json:
        with open(a.json, "w") as f:
            json.dump(out, f, indent=1)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
