"""Multi-object tracking scores (issue 4, "Scoring") with py-motmetrics.

Both tables are MOT-style column dicts: ``frame`` (int), ``id`` (int), ``bb_left``, ``bb_top``,
``bb_width``, ``bb_height`` (px). Both must use the same frame numbering (`CountResult.mot` is
1-based, `datasets.pets_boxes` 0-based: pass ``frame_offset``). Truth and hypothesis boxes pair
when their intersection over union is >= ``iou_threshold`` (0.5 by default, the MOTChallenge
convention); the distance given to motmetrics is 1 - IoU (NaN = may not pair), so MOTP is the
mean 1 - IoU of the matched pairs.

motmetrics (``pip install 'rhythmjax[score]'``, tested with 1.4.0) is imported lazily: the rest
of the package does not need it. Its ``distances.iou_matrix`` calls ``np.asfarray``, removed in
NumPy 2, so the IoU is computed here. The calls into motmetrics run under a warnings filter that
silences only ``DeprecationWarning`` / ``FutureWarning`` raised from motmetrics or pandas modules
(pandas deprecations triggered by motmetrics 1.4.0's event frames); any other warning still
propagates (and fails a ``filterwarnings=error`` test run).

Metrics (Bernardin & Stiefelhagen 2008 CLEAR MOT; Ristani et al. 2016 IDF1): MOTA = 1 - (FN +
FP + IDSW) / n_truth_boxes; IDF1 = 2 IDTP / (n_truth_boxes + n_hyp_boxes) under the best
one-to-one truth-id / hypothesis-id matching; MT / ML = truth ids covered >= 80 % / < 20 % of
their frames. Count error = counted ids - true ids, where counted ids are ``walking_ids`` when
given (the ids judged Pedestrian) and all hypothesis ids otherwise, and true ids are
``truth_walking_ids`` when given and all distinct truth ids otherwise.
"""

from __future__ import annotations

import warnings
from collections.abc import Iterable, Mapping
from contextlib import contextmanager
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np


MOT_BOX_COLUMNS = ("frame", "id", "bb_left", "bb_top", "bb_width", "bb_height")
_QUIET_MODULES = r"(motmetrics|pandas)(\..*)?"


@dataclass(frozen=True)
class MotScore:
    """Scores of one sequence. Rates in [0, 1] (MOTA may be negative); counts are integers."""

    mota: float
    motp: float
    idf1: float
    idp: float
    idr: float
    precision: float
    recall: float
    id_switches: int
    fragmentations: int
    false_positives: int
    misses: int
    mostly_tracked: int
    partially_tracked: int
    mostly_lost: int
    n_frames: int
    n_truth_boxes: int
    n_hyp_boxes: int
    n_truth_ids: int
    n_hyp_ids: int
    count: int
    count_error: int
    count_rel_error: float
    iou_threshold: float
    motmetrics_version: str

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)


@contextmanager
def _quiet_motmetrics():
    """Silence only motmetrics' / pandas' own Deprecation/FutureWarnings (see module doc)."""
    with warnings.catch_warnings():
        for cat in (DeprecationWarning, FutureWarning):
            warnings.filterwarnings("ignore", category=cat, module=_QUIET_MODULES)
        yield


def _motmetrics():
    try:
        with _quiet_motmetrics():
            import motmetrics
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise ImportError("scoring needs py-motmetrics: pip install 'rhythmjax[score]' "
                          "(motmetrics>=1.4)") from e
    return motmetrics


def motmetrics_version() -> str:
    """The installed py-motmetrics version (raises ImportError when it is missing)."""
    return str(_motmetrics().__version__)


def iou_matrix(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """IoU of boxes a (n, 4) and b (m, 4), each row (left, top, width, height) px -> (n, m)
    float64. Zero-area boxes have IoU 0 with everything."""
    a = np.asarray(a, np.float64).reshape(-1, 4)
    b = np.asarray(b, np.float64).reshape(-1, 4)
    ax1, ay1 = a[:, 0] + a[:, 2], a[:, 1] + a[:, 3]
    bx1, by1 = b[:, 0] + b[:, 2], b[:, 1] + b[:, 3]
    iw = np.minimum(ax1[:, None], bx1[None]) - np.maximum(a[:, 0][:, None], b[:, 0][None])
    ih = np.minimum(ay1[:, None], by1[None]) - np.maximum(a[:, 1][:, None], b[:, 1][None])
    inter = np.clip(iw, 0.0, None) * np.clip(ih, 0.0, None)
    union = (a[:, 2] * a[:, 3])[:, None] + (b[:, 2] * b[:, 3])[None] - inter
    with np.errstate(invalid="ignore", divide="ignore"):
        out = np.where(union > 0, inter / np.where(union > 0, union, 1.0), 0.0)
    return out


def check_mot_boxes(cols: Mapping[str, Any], what: str = "boxes") -> dict[str, np.ndarray]:
    """Validate and normalise a MOT-style box table; ValueError names the table, column and row
    (0-based) or the (frame, id) that is wrong."""
    missing = [c for c in MOT_BOX_COLUMNS if c not in cols]
    if missing:
        raise ValueError(f"{what}: missing column(s) {missing}; need {list(MOT_BOX_COLUMNS)}")
    out: dict[str, np.ndarray] = {}
    n = None
    for c in MOT_BOX_COLUMNS:
        v = np.asarray(cols[c]).reshape(-1)
        if n is not None and v.shape[0] != n:
            raise ValueError(f"{what}: column '{c}' has {v.shape[0]} rows, 'frame' has {n}")
        n = v.shape[0]
        if c in ("frame", "id"):
            if v.size and not np.issubdtype(v.dtype, np.integer):
                fv = np.asarray(v, np.float64)
                bad = np.flatnonzero(~np.isfinite(fv) | (fv != np.round(fv)))
                if bad.size:
                    raise ValueError(f"{what}: column '{c}' row {bad[0]}: {v[bad[0]]!r} is not "
                                     "an integer")
            out[c] = v.astype(np.int64)
        else:
            fv = np.asarray(v, np.float64)
            bad = np.flatnonzero(~np.isfinite(fv) | ((fv < 0) & (c in ("bb_width", "bb_height"))))
            if bad.size:
                raise ValueError(f"{what}: column '{c}' row {bad[0]}: {v[bad[0]]!r} is not a "
                                 "finite" + (" non-negative" if c in ("bb_width", "bb_height")
                                             else "") + " number")
            out[c] = fv
    if n:  # duplicate (frame, id) pairs make the scoring meaningless
        order = np.lexsort((out["id"], out["frame"]))
        f, i = out["frame"][order], out["id"][order]
        dup = np.flatnonzero((f[1:] == f[:-1]) & (i[1:] == i[:-1]))
        if dup.size:
            raise ValueError(f"{what}: id {i[dup[0]]} appears twice in frame {f[dup[0]]} "
                             f"(rows {order[dup[0]]} and {order[dup[0] + 1]})")
    return out


def _by_frame(cols: dict[str, np.ndarray]) -> dict[int, tuple[np.ndarray, np.ndarray]]:
    boxes = np.stack([cols[c] for c in MOT_BOX_COLUMNS[2:]], axis=1) if cols["frame"].size \
        else np.zeros((0, 4))
    out: dict[int, tuple[np.ndarray, np.ndarray]] = {}
    for f in np.unique(cols["frame"]):
        k = np.flatnonzero(cols["frame"] == f)
        out[int(f)] = (cols["id"][k], boxes[k])
    return out


def accumulate(truth: Mapping[str, Any], hyp: Mapping[str, Any], *, iou_threshold: float = 0.5,
               frame_offset: int = 0, frames: Iterable[int] | None = None):
    """A filled ``motmetrics.MOTAccumulator`` (frame ids = truth frame numbers). ``frames``: the
    frames to score (default: every frame in either table); hypothesis frames are shifted by
    ``frame_offset`` first (hyp frame + offset = truth frame)."""
    if not 0.0 < iou_threshold <= 1.0:
        raise ValueError(f"iou_threshold must be in (0, 1], got {iou_threshold}")
    mm = _motmetrics()
    t = check_mot_boxes(truth, "truth")
    h = check_mot_boxes(hyp, "hypotheses")
    h["frame"] = h["frame"] + int(frame_offset)
    tf, hf = _by_frame(t), _by_frame(h)
    if frames is None:
        frames = sorted(set(tf) | set(hf))
    empty = (np.zeros(0, np.int64), np.zeros((0, 4)))
    with _quiet_motmetrics():
        acc = mm.MOTAccumulator(auto_id=False)
        for f in frames:
            oid, obox = tf.get(int(f), empty)
            hid, hbox = hf.get(int(f), empty)
            iou = iou_matrix(obox, hbox)
            dist = np.where(iou >= iou_threshold, 1.0 - iou, np.nan)
            acc.update(oid, hid, dist, frameid=int(f))
    return acc


def score_mot(truth: Mapping[str, Any], hyp: Mapping[str, Any], *, iou_threshold: float = 0.5,
              frame_offset: int = 0, frames: Iterable[int] | None = None,
              walking_ids: Iterable[int] | None = None,
              truth_walking_ids: Iterable[int] | None = None) -> MotScore:
    """Score hypotheses against truth (see the module doc for the definitions and conventions).
    ``walking_ids``: hypothesis ids judged walking, for the count (default: all hypothesis ids);
    ``truth_walking_ids``: the truth ids the count should equal (default: all truth ids), e.g.
    the walkers only when the truth also has bicycles. MOTA / IDF1 always use every truth box.
    """
    mm = _motmetrics()
    acc = accumulate(truth, hyp, iou_threshold=iou_threshold, frame_offset=frame_offset,
                     frames=frames)
    names = ["mota", "motp", "idf1", "idp", "idr", "precision", "recall", "num_switches",
             "num_fragmentations", "num_false_positives", "num_misses", "mostly_tracked",
             "partially_tracked", "mostly_lost", "num_frames", "num_objects", "num_predictions",
             "num_unique_objects"]
    with _quiet_motmetrics():
        row = mm.metrics.create().compute(acc, metrics=names, name="seq").iloc[0]
    n_truth_ids = int(np.unique(np.asarray(truth["id"])).size)
    n_hyp_ids = int(np.unique(np.asarray(hyp["id"])).size)
    count = n_hyp_ids if walking_ids is None else len(set(int(i) for i in walking_ids))
    n_true = n_truth_ids if truth_walking_ids is None else len(set(int(i) for i in
                                                                    truth_walking_ids))

    def fl(k: str) -> float:
        v = float(row[k])
        return v if np.isfinite(v) else float("nan")

    return MotScore(
        mota=fl("mota"), motp=fl("motp"), idf1=fl("idf1"), idp=fl("idp"), idr=fl("idr"),
        precision=fl("precision"), recall=fl("recall"), id_switches=int(row["num_switches"]),
        fragmentations=int(row["num_fragmentations"]),
        false_positives=int(row["num_false_positives"]), misses=int(row["num_misses"]),
        mostly_tracked=int(row["mostly_tracked"]), partially_tracked=int(row["partially_tracked"]),
        mostly_lost=int(row["mostly_lost"]), n_frames=int(row["num_frames"]),
        n_truth_boxes=int(row["num_objects"]), n_hyp_boxes=int(row["num_predictions"]),
        n_truth_ids=n_truth_ids, n_hyp_ids=n_hyp_ids, count=count,
        count_error=count - n_true,
        count_rel_error=(count - n_true) / n_true if n_true else float("nan"),
        iou_threshold=float(iou_threshold), motmetrics_version=str(mm.__version__))


__all__ = ["MOT_BOX_COLUMNS", "MotScore", "accumulate", "check_mot_boxes", "iou_matrix",
           "motmetrics_version", "score_mot"]
