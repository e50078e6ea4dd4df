"""What a person looks at: annotated frames and per-track spectrum figures (edge I/O, OpenCV and
matplotlib; the numeric core never imports this)."""

from __future__ import annotations

import math

import cv2
import jax.numpy as jnp
import numpy as np

from ..io.files import atomic_path
from ..model import mem
from ..model.params import Config, WidthModel
from ..model.rhythm import N_FREQS, fill_gaps, normalise_window


_COLOURS = {"pedestrian": (60, 200, 60), "non-pedestrian": (40, 40, 230),
            "unclassified": (200, 200, 200)}


def draw_frame(gray: np.ndarray, objects: list[dict], index: int, *,
               height_per_width: float | None = None) -> np.ndarray:
    """BGR copy of a grey frame with each object's foot point, window, id, state and verdict.

    `objects`: dicts with track_id, u, v, width (px), state, verdict (label or None); each box
    is `height_per_width` times its width tall (the config's `width.height_per_width()`; None:
    the default config's, 1.7 m / 0.5 m)."""
    if height_per_width is None:
        height_per_width = WidthModel().height_per_width()
    img = cv2.cvtColor(gray, cv2.COLOR_GRAY2BGR)
    for o in objects:
        if not (math.isfinite(o["u"]) and math.isfinite(o["v"])):
            continue
        verdict = o.get("verdict") or "unclassified"
        c = _COLOURS.get(verdict, (200, 200, 200))
        W = o["width"] if math.isfinite(o["width"]) else 20.0
        H = W * height_per_width
        u, v = int(round(o["u"])), int(round(o["v"]))
        cv2.rectangle(img, (int(u - W / 2), int(v - H)), (int(u + W / 2), v), c, 1)
        cv2.circle(img, (u, v), 3, c, -1)
        label = f"{o['track_id']} {o['state'][:3]}" + (f" {verdict[:3]}" if o.get("verdict")
                                                       else "")
        cv2.putText(img, label, (int(u - W / 2), max(10, int(v - H) - 3)),
                    cv2.FONT_HERSHEY_SIMPLEX, 0.4, c, 1, cv2.LINE_AA)
    # bottom left: the labels of far objects sit at the top of the image
    cv2.putText(img, f"frame {index}", (5, img.shape[0] - 6), cv2.FONT_HERSHEY_SIMPLEX, 0.45,
                (255, 255, 0), 1, cv2.LINE_AA)
    return img


def spectrum_figure(path, cfg: Config, tracks: dict, verdicts: dict, objs, *,
                    max_tracks: int = 12) -> None:
    """One panel per track: the MEM spectrum (P relative to white noise) of its deciding window,
    P_thr, the walking-model pace band (mean +/- k_sigma3 sd) and the verdict; written
    atomically."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    chosen = [o for o in objs if o.result is not None][:max_tracks]
    n = max(1, len(chosen))
    cols = min(3, n)
    rows = math.ceil(n / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(4.2 * cols, 2.8 * rows), squeeze=False)
    walk, thr = cfg.walking, cfg.thresholds
    lo = float(walk.pace_mean - thr.k_sigma3 * walk.pace_std)
    hi = float(walk.pace_mean + thr.k_sigma3 * walk.pace_std)
    for ax, o in zip(axes.ravel(), chosen):
        a, b = o.result["window"]
        t = np.asarray([r.t for r in o.rows[a:b]], np.float64)
        inten = np.asarray([r.intensity for r in o.rows[a:b]], np.float64)
        dt = float(np.median(np.diff(t)))
        x, _ = normalise_window(fill_gaps(jnp.asarray(inten, jnp.float32),
                                          jnp.isfinite(jnp.asarray(inten))))
        spec = mem.spectrum(x, dt, thr.m, n_freqs=N_FREQS)
        ax.semilogy(np.asarray(spec.freqs), np.maximum(np.asarray(spec.psd) / dt, 1e-3), lw=1)
        ax.axhline(float(thr.p_thr), color="k", ls=":", lw=0.8)
        ax.axvspan(lo, hi, color="g", alpha=0.1)
        ax.set_title(f"track {o.track_id}: {_label(o)}", fontsize=9)
        ax.set_xlabel("frequency (Hz)", fontsize=8)
        ax.set_ylabel("P / white level", fontsize=8)
    for ax in axes.ravel()[len(chosen):]:
        ax.axis("off")
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=90)
    plt.close(fig)


def _label(o) -> str:
    from ..model.status import REASON_LABELS, VERDICT_LABELS

    r = o.result
    pace = float(r["pace_hz"])
    extra = f", F={pace:.2f} Hz, T={float(r['stride_m']):.2f} m" if math.isfinite(pace) else ""
    return f"{VERDICT_LABELS[int(r['verdict'])]} ({REASON_LABELS[int(r['reason'])]}{extra})"


def draw_count_frame(gray: np.ndarray, pedestrians: list[dict], index: int) -> np.ndarray:
    """BGR copy of a grey frame with each pedestrian's patch (`rhythmjax count`): box (left, top,
    w, h) px, id ("new" while tentative), solid when measured and thin grey-edged when
    predicted, coloured by its online verdict; plus the frame index and the count in view.

    `pedestrians`: dicts with track_id (0 = tentative), box, measured, verdict (label or None)."""
    img = cv2.cvtColor(gray, cv2.COLOR_GRAY2BGR)
    shown = 0
    for p in pedestrians:
        left, top, w, h = p["box"]
        if not all(math.isfinite(q) for q in (left, top, w, h)):
            continue
        c = _COLOURS.get(p.get("verdict") or "unclassified", (200, 200, 200))
        if p["track_id"] == 0:
            c = (150, 150, 150)
        x0, y0 = int(round(left)), int(round(top))
        x1, y1 = int(round(left + w)), int(round(top + h))
        cv2.rectangle(img, (x0, y0), (x1, y1), c, 2 if p["measured"] else 1)
        label = str(p["track_id"]) if p["track_id"] else "new"
        if p.get("verdict"):
            label += " " + p["verdict"][:3]
        cv2.putText(img, label, (x0, max(10, y0 - 3)), cv2.FONT_HERSHEY_SIMPLEX, 0.4, c, 1,
                    cv2.LINE_AA)
        shown += p["track_id"] != 0
    cv2.putText(img, f"frame {index}  in view {shown}", (5, img.shape[0] - 6),
                cv2.FONT_HERSHEY_SIMPLEX, 0.45, (255, 255, 0), 1, cv2.LINE_AA)
    return img
