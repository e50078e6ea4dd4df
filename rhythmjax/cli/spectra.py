"""The spectra gallery: one panel per judged track (every one, on as many pages as needed), the MEM
spectrum of its deciding window (or of the window its pace came from: the tracker's rule 55)
relative to white noise, P_thr, the walking model's pace band, the spectral peak and the verdict
(edge I/O, matplotlib; the numeric core never imports this).

Written as `spectra.pdf` (every page) and `spectra.png` (the first page, which says how many
pages there are); the report embeds every page (`page_images`). The online tracker's objects
are drawn as they are; `count`'s tracks from its tables (`table_windows`: the tracks and, per
track, the first frame of the window the batch classifier decided on)."""

from __future__ import annotations

import contextlib
import functools
import io
import math
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from ..io.files import CANDIDATE_COLUMNS, atomic_path
from ..model.params import Config, walking_pace_band
from ..model.rhythm import window_spectrum as classifier_spectrum
from ..model.status import REASON_LABELS, VERDICT_LABELS
from ..track.toolkit import window_signal


__all__ = ["PER_PAGE", "Sample", "WindowTrack", "gallery_figures", "judged", "page_images",
           "panel_text", "table_windows", "track_spectrum", "window_spectrum", "write_spectra"]

PER_PAGE = 12  # panels per page: 3 columns x 4 rows
COLS = 3
COLOURS = {"pedestrian": "#1f9e3a", "non-pedestrian": "#d62728", "unclassified": "#b8860b"}
NO_GAIT = "not a gait: F, T not meaningful"


def judged(objs) -> list:
    """The online tracker's objects that were judged (have a rhythm window's outcome), in
    track-id order."""
    return sorted((o for o in objs if o.result is not None), key=lambda o: o.track_id)


class Sample(NamedTuple):
    """One row of a rhythm window: frame, t (s), I(k) (NaN: not measured)."""

    frame: int
    t: float
    intensity: float


class WindowTrack(NamedTuple):
    """A judged track as the gallery reads it (the online tracker's objects have the same
    fields): its id, rows (`Sample`s) and result (verdict and reason codes, pace_hz, stride_m,
    window: (first, end) indices into rows)."""

    track_id: int
    rows: list
    result: dict


def table_windows(tracks: dict, verdicts: dict, n: int, fps: float) -> list[WindowTrack]:
    """The judged tracks of a tracks table (columns track_id, frame, t, intensity; the candidate
    windows' `io.files.CANDIDATE_COLUMNS` where present) and its verdicts (track_id, verdict,
    reason labels, pace_hz, stride_m, window_frame: the first frame of the window that decided
    the track, -1 for none, and optionally candidate: the window B that decided; `count` keeps
    both from the batch classifier). Each window holds the n frames from window_frame on (fps
    frames/s); a frame without a row is a NaN sample, as `io.files.to_batch` fills a gap, and
    its t follows the frame grid (t = frame / fps + the track's median offset)."""
    verdict_code = {v: k for k, v in VERDICT_LABELS.items()}
    reason_code = {v: k for k, v in REASON_LABELS.items()}
    tid = np.asarray(tracks["track_id"])
    frame = np.asarray(tracks["frame"], np.int64)
    t = np.asarray(tracks["t"], np.float64)
    signals = [np.asarray(tracks["intensity"], np.float64)]
    if all(c in tracks for c in CANDIDATE_COLUMNS):
        signals += [np.asarray(tracks[c], np.float64) for c in CANDIDATE_COLUMNS]
    out = []
    for i, track in enumerate(verdicts["track_id"]):
        f0 = int(verdicts["window_frame"][i])
        if f0 < 0:
            continue
        # the candidate window B that decided (`verdicts["candidate"]`; 0: window B's own)
        c = int(verdicts["candidate"][i]) if "candidate" in verdicts else 0
        inten = signals[c if c < len(signals) else 0]
        mine = np.flatnonzero(tid == track)
        offset = float(np.median(t[mine] - frame[mine] / fps))
        grid = np.arange(f0, f0 + n)
        at = {int(frame[k]): k for k in mine if f0 <= frame[k] < f0 + n}
        rows = [Sample(int(f), float(t[at[f]]) if f in at else f / fps + offset,
                       float(inten[at[f]]) if f in at else math.nan) for f in grid]
        result = {"verdict": verdict_code[str(verdicts["verdict"][i])],
                  "reason": reason_code[str(verdicts["reason"][i])],
                  "pace_hz": float(verdicts["pace_hz"][i]),
                  "stride_m": float(verdicts["stride_m"][i]), "window": (0, n)}
        out.append(WindowTrack(int(track), rows, result))
    return out


@functools.partial(jax.jit, static_argnames=("order",))
def window_spectrum(inten, dt, order: int):
    """(frequencies, PSD) of one window of I(k) (NaN where unmeasured) as the classifier
    sees it (`rhythm.window_spectrum`: gaps handled, normalised, MEM of `order`; jitted: one
    compilation per window length)."""
    spec, _ = classifier_spectrum(inten, dt, order)
    return spec.freqs, spec.psd


def track_spectrum(cfg: Config, o) -> tuple[np.ndarray, np.ndarray]:
    """(frequencies Hz, P / white-noise level) of the MEM spectrum of the window `o`'s pace F
    came from: its deciding window (rows `result["window"]`, the I(k) of the candidate window B
    that decided, `result["candidate"]`, `track.toolkit.window_signal`; window B's own without
    candidates), or, where the tracker's rule 55 read the pace from a later window, that one
    (`result["pace_window"]`, `result["pace_candidate"]`), so the panel's F is its peak."""
    a, b = o.result.get("pace_window", o.result["window"])
    candidate = o.result.get("pace_candidate", o.result.get("candidate", 0))
    t = np.asarray([r.t for r in o.rows[a:b]], np.float64)
    inten = window_signal(o, a, b, int(candidate)).astype(np.float32)
    dt = float(np.median(np.diff(t))) if len(t) > 1 else 1.0 / float(cfg.camera.fps)
    freqs, psd = window_spectrum(jnp.asarray(inten), jnp.float32(dt), int(cfg.thresholds.m))
    return np.asarray(freqs), np.maximum(np.asarray(psd) / dt, 1e-3)


def panel_text(result: dict) -> tuple[str, str, str]:
    """(verdict, reason, measures) of a track's outcome, in words: measures are "F 1.92 Hz,
    T 0.72 m" for a walker, "no peak above P_thr" when there is none (an unusable window says
    so), and for a non-pedestrian's peak the figures marked as meaningless for it
    (`NO_GAIT`)."""
    verdict = VERDICT_LABELS[int(result["verdict"])]
    reason = REASON_LABELS[int(result["reason"])]
    pace, stride = float(result["pace_hz"]), float(result["stride_m"])
    if reason in ("bad-signal", "no-measurements"):
        return verdict, reason, "rhythm window unusable: no F, T"
    if reason == "no-peak" or not math.isfinite(pace):
        return verdict, reason, "no peak above P_thr"
    measures = f"F {pace:.2f} Hz, T {stride:.2f} m"
    if verdict != "pedestrian":
        measures += f"\n({NO_GAIT})"
    return verdict, reason, measures


def _page(plt, cfg: Config, chosen: list, first: int, n_all: int, page: int, pages: int,
          truth_ids: dict | None):
    lo, hi = walking_pace_band(cfg)
    rows = math.ceil(len(chosen) / COLS)
    height = 2.9 * rows + 1.3
    fig, axes = plt.subplots(rows, COLS, figsize=(4.4 * COLS, height), squeeze=False)
    # fixed margins (a constrained layout costs seconds a page): room for two-line titles
    fig.subplots_adjust(left=0.06, right=0.985, top=1 - 0.85 / height,
                        bottom=0.8 / height, hspace=0.62, wspace=0.22)
    handles = None
    for ax, o in zip(axes.ravel(), chosen):
        f, p = track_spectrum(cfg, o)
        verdict, reason, measures = panel_text(o.result)
        colour = COLOURS.get(verdict, "k")
        line, = ax.semilogy(f, p, lw=1.1, color="#1f4e9a", label="MEM spectrum / white level")
        thr_line = ax.axhline(float(cfg.thresholds.p_thr), color="k", ls=":", lw=0.9, label="P_thr")
        band = ax.axvspan(lo, hi, color="g", alpha=0.12,
                          label=f"walking pace band {lo:.2f}-{hi:.2f} Hz")
        pace = float(o.result["pace_hz"])
        if reason != "no-peak" and math.isfinite(pace):
            ax.axvline(pace, color=colour, lw=0.9, ls="--")
        handles = [line, thr_line, band]
        who = f"track #{o.track_id}"
        if truth_ids and o.track_id in truth_ids:
            who += f" = {truth_ids[o.track_id]}"
        ax.set_title(f"{who}: {verdict}\n{reason}", fontsize=8.5, color=colour, loc="left")
        ax.text(0.98, 0.95, measures, transform=ax.transAxes, ha="right", va="top", fontsize=7.5,
                bbox={"boxstyle": "round,pad=0.25", "fc": "white", "ec": colour, "alpha": 0.85})
        ax.tick_params(labelsize=7)
        ax.set_xlabel("frequency (Hz)", fontsize=7.5)
        ax.set_ylabel("P / white level", fontsize=7.5)
    for ax in axes.ravel()[len(chosen):]:
        ax.axis("off")
    if handles:
        fig.legend(handles=handles, loc="lower center", ncols=3, fontsize=8, frameon=False)
    last = first + len(chosen)
    fig.suptitle(f"rhythm spectra, page {page} of {pages}: tracks {first + 1}-{last} of "
                 f"{n_all} judged" + ("" if pages == 1 else "  (every page: spectra.pdf, "
                                                            "report.html)"), fontsize=10,
                 y=1 - 0.12 / height, va="top")
    return fig


def gallery_figures(cfg: Config, objs, truth_ids: dict | None = None,
                    per_page: int = PER_PAGE):
    """(pyplot, figure) of each page of the gallery: every judged track (`judged`), `per_page`
    panels a page; one page saying so when none was judged. Close each figure when done."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    chosen = judged(objs)
    pages = max(1, math.ceil(len(chosen) / per_page))
    for k in range(pages):
        part = chosen[k * per_page:(k + 1) * per_page]
        if part:
            fig = _page(plt, cfg, part, k * per_page, len(chosen), k + 1, pages, truth_ids)
        else:
            fig = plt.figure(figsize=(6, 1.5))
            fig.text(0.5, 0.5, "no track was judged (every track shorter than the rhythm "
                     "window)", ha="center", va="center", fontsize=10)
        yield plt, fig


def write_spectra(png_path, pdf_path, cfg: Config, objs, *, truth_ids: dict | None = None,
                  per_page: int = PER_PAGE) -> list[bytes]:
    """Write the gallery: every page into the PDF at `pdf_path` (None: no PDF) and the first
    page as the PNG at `png_path`, each atomically; the PNG bytes of every page (for the
    report). `truth_ids`: {track id: the object it followed} where known (the demo)."""
    from matplotlib.backends.backend_pdf import PdfPages

    images = []
    with atomic_path(pdf_path) if pdf_path else contextlib.nullcontext() as pdf_tmp:
        pdf = PdfPages(pdf_tmp) if pdf_tmp else None
        try:
            for plt, fig in gallery_figures(cfg, objs, truth_ids, per_page):
                buf = io.BytesIO()
                fig.savefig(buf, format="png", dpi=80)
                images.append(buf.getvalue())
                if pdf is not None:
                    pdf.savefig(fig)
                plt.close(fig)
        finally:
            if pdf is not None:
                pdf.close()
    with atomic_path(png_path) as tmp, open(tmp, "wb") as f:
        f.write(images[0])
    return images


def page_images(cfg: Config, objs, *, truth_ids: dict | None = None,
                per_page: int = PER_PAGE) -> list[bytes]:
    """The gallery's pages as PNG bytes, nothing written."""
    images = []
    for plt, fig in gallery_figures(cfg, objs, truth_ids, per_page):
        buf = io.BytesIO()
        fig.savefig(buf, format="png", dpi=80)
        images.append(buf.getvalue())
        plt.close(fig)
    return images

