"""Footprints files (u, v px; x, y m; optional track_id, frame) made from what a user has, the
input of `rhythmjax-fit camera` (`rhythmjax-fit footprints`).

Two sources:
- boxes + world positions: boxes as MOTChallenge text (frame, id, left, top, width, height, ...)
  or CVML XML (PETS: <frame number><object id><box h w xc yc>), the foot point the box's bottom
  centre, times `box_scale` for boxes given at another resolution; world positions per frame
  and id in the TrajNet layout (``frame id x y`` per line, m). A world row's frame is a box
  frame + `frame_offset`. Pairs are matched by id (the same id and frame), or by geometry when
  the ids differ (TrajNet's ids are 20-step chunks, not people): a RANSAC homography (OpenCV)
  over every same-frame (box, position) pair, then per frame a one-to-one assignment (Hungarian,
  SciPy) of the positions mapped into the image to the nearest foot points within `gate_px`,
  the homography refitted by least squares on the pairs and the assignment repeated. A MOT
  file whose x, y columns hold the world position (not -1) needs no positions file.
- image points + an image-to-ground homography H (m): points from a MOT file (foot points), a
  u, v table, or a grid over the image; H maps [row, col, 1] (ETH's H.txt, the default) or
  [u, v, 1] to the ground [x, y, w]. Points H sends behind the camera (the side of the horizon
  away from most of them; for the grid, away from the bottom centre) are dropped, and the grid
  keeps the points whose depth is at most `depth_ratio` times the nearest grid point's
  (|w| is proportional to 1 / depth).

Every problem with an input is a `BadInput` naming the file and the line or field.
"""

from __future__ import annotations

import math
import os
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field

import cv2
import numpy as np

from rhythmjax.io import BadInput, read_table, write_table
from rhythmjax.io.errors import read_text
from rhythmjax.io.mot import read_mot


UNIT_SCALE = {"m": 1.0, "cm": 0.01, "mm": 0.001}


@dataclass
class Made:
    """A footprints table: `columns` (u, v px; x, y m; track_id, frame where known) in `order`,
    how it was made (`source`, `match`), what it dropped (`notes`), and the RMS (px, per
    coordinate) of a least-squares homography ground -> image over the pairs: the floor any
    camera without lens distortion can reach (0 for pairs made through a homography)."""

    columns: dict[str, np.ndarray]
    order: tuple[str, ...]
    source: str
    match: str = ""
    notes: list[str] = field(default_factory=list)
    homography_rms_px: float = math.nan

    def __len__(self) -> int:
        return int(self.columns["u"].size)

    def summary(self) -> str:
        how = f", matched by {self.match}" if self.match else ""
        lines = [f"{len(self)} footprints from {self.source}{how}"] + self.notes
        if math.isfinite(self.homography_rms_px):
            lines.append(f"least-squares homography ground -> image over them: RMS "
                         f"{self.homography_rms_px:.3f} px per coordinate (the floor for a "
                         "camera without lens distortion)")
        return "\n".join(lines)

    def to_dict(self) -> dict:
        return {"n": len(self), "source": self.source, "match": self.match or None,
                "notes": self.notes, "homography_rms_px": self.homography_rms_px,
                "columns": list(self.order)}


# ----------------------------------------------------------------------------------------------
# Readers

def read_boxes(path, *, scale: float = 1.0) -> dict[str, np.ndarray]:
    """Boxes of a MOT text file or a CVML XML file (by the extension .xml): frame, id (int64),
    foot_u, foot_v (px, the bottom centre times `scale`) and, from MOT, the world x, y columns
    (NaN where -1 or absent; CVML: NaN)."""
    p = os.fspath(path)
    if p.lower().endswith(".xml"):
        frame, ids, xc, yc, h = _read_cvml(p)
        x = y = np.full(frame.size, np.nan)
        foot_u, foot_v = xc, yc + h / 2
    else:
        m = read_mot(p)
        frame, ids = m["frame"], m["id"]
        foot_u, foot_v = m["bb_left"] + m["bb_width"] / 2, m["bb_top"] + m["bb_height"]
        none = (m["x"] == -1) & (m["y"] == -1)
        x, y = np.where(none, np.nan, m["x"]), np.where(none, np.nan, m["y"])
    if not frame.size:
        raise BadInput(p, "no boxes in the file")
    return {"frame": frame, "id": ids, "foot_u": foot_u * scale, "foot_v": foot_v * scale,
            "x": x, "y": y}


def _read_cvml(p: str):
    try:
        root = ET.parse(p).getroot()
    except FileNotFoundError:
        raise BadInput(p, "no such file") from None
    except ET.ParseError as e:
        raise BadInput(p, f"not valid XML: {e}", line=e.position[0]) from None
    except OSError as e:
        raise BadInput(p, f"cannot read: {e.strerror}") from None
    rows = []
    for fr in root.iter("frame"):
        for ob in fr.iter("object"):
            box = ob.find("box")
            where = f"frame {fr.get('number')!r} object {ob.get('id')!r}"
            try:
                k, i = int(fr.get("number")), int(ob.get("id"))
            except (TypeError, ValueError):
                raise BadInput(p, f"{where}: frame number and object id must be integers",
                               key="frame.number/object.id") from None
            vals = []
            for a in ("xc", "yc", "w", "h"):
                try:
                    vals.append(float(box.get(a)))
                except (AttributeError, TypeError, ValueError):
                    raise BadInput(p, f"{where}: box attribute {a!r} missing or not a number",
                                   key=f"box.{a}") from None
            rows.append((k, i, *vals))
    if not rows:
        raise BadInput(p, "no <frame><objectlist><object><box> elements (not CVML?)")
    a = np.asarray(rows, np.float64)
    return a[:, 0].astype(np.int64), a[:, 1].astype(np.int64), a[:, 2], a[:, 3], a[:, 5]


def read_positions(path) -> dict[str, np.ndarray]:
    """World positions in the TrajNet layout: ``frame id x y`` per line (spaces, tabs or commas;
    further columns ignored; blank lines and lines starting with # skipped): frame, id (int64),
    x, y (float64, the file's units), line."""
    p = os.fspath(path)
    rows, lines = [], []
    for k, text in enumerate(read_text(p).splitlines(), 1):
        s = text.strip()
        if not s or s.startswith("#"):
            continue
        parts = s.replace(",", " ").split()
        if len(parts) < 4:
            raise BadInput(p, f"expected 4 fields (frame id x y), got {len(parts)}", line=k)
        vals = []
        for name, tok in zip(("frame", "id", "x", "y"), parts[:4]):
            try:
                q = float(tok)
            except ValueError:
                raise BadInput(p, f"{tok!r} is not a number", line=k, column=name) from None
            whole = name in ("frame", "id")
            if not math.isfinite(q) or (whole and q != int(q)):
                raise BadInput(p, f"{tok!r} is not a finite {'integer' if whole else 'number'}",
                               line=k, column=name)
            vals.append(q)
        rows.append(vals)
        lines.append(k)
    if not rows:
        raise BadInput(p, "no positions in the file (expected lines 'frame id x y')")
    a = np.asarray(rows)
    return {"frame": a[:, 0].astype(np.int64), "id": a[:, 1].astype(np.int64), "x": a[:, 2],
            "y": a[:, 3], "line": np.asarray(lines)}


def read_points(path, *, scale: float = 1.0) -> dict[str, np.ndarray]:
    """Image points: a .csv/.parquet table with u, v (px) and optional track_id, frame, or a MOT
    text file (the boxes' foot points). u, v times `scale`; rows with an empty u or v dropped."""
    p = os.fspath(path)
    if os.path.splitext(p)[1].lower() in (".csv", ".parquet"):
        tab = read_table(p, ("u", "v"), ("track_id", "frame"),
                         types={"u": "float", "v": "float", "track_id": "id", "frame": "int"})
        out = {k: tab[k] for k in ("u", "v", "track_id", "frame") if k in tab}
        for c in ("u", "v"):
            i = np.flatnonzero(np.isinf(tab[c]))
            if i.size:
                raise tab.where(p, int(i[0]), c, "inf is not a pixel coordinate")
    else:
        b = read_boxes(p)
        out = {"u": b["foot_u"], "v": b["foot_v"], "track_id": b["id"], "frame": b["frame"]}
    ok = np.isfinite(out["u"]) & np.isfinite(out["v"])
    out = {k: np.asarray(a)[ok] for k, a in out.items()}
    out["u"], out["v"] = out["u"] * scale, out["v"] * scale
    if not out["u"].size:
        raise BadInput(p, "no image point with finite u and v")
    return out


def read_homography(path) -> np.ndarray:
    """A 3x3 matrix of numbers, one row per line (spaces, tabs or commas). Raises `BadInput`
    for another shape, a non-number, a non-finite value or a singular matrix."""
    p = os.fspath(path)
    rows = []
    for k, text in enumerate(read_text(p).splitlines(), 1):
        parts = text.replace(",", " ").split()
        if not parts or parts[0].startswith("#"):
            continue
        try:
            vals = [float(t) for t in parts]
        except ValueError:
            raise BadInput(p, "a homography row must hold 3 numbers", line=k) from None
        if len(vals) != 3 or not all(map(math.isfinite, vals)):
            raise BadInput(p, f"a homography row must hold 3 finite numbers, got {len(vals)}",
                           line=k)
        rows.append(vals)
    if len(rows) != 3:
        raise BadInput(p, f"expected a 3x3 matrix (3 rows), got {len(rows)} rows")
    H = np.asarray(rows)
    s = np.linalg.svd(H, compute_uv=False)
    if s[-1] <= 1e-12 * s[0]:
        raise BadInput(p, f"the homography is singular (singular values {s[0]:.3g} ... "
                       f"{s[-1]:.3g}): it maps the image onto a line, not the ground")
    return H


# ----------------------------------------------------------------------------------------------
# Footprints through a homography

def image_to_ground(H: np.ndarray, u, v, order: str = "rowcol"):
    """(x, y, w): the ground point (m) of image points (u, v) px through the image-to-ground
    homography H, which maps [row, col, 1] (`order` "rowcol", ETH) or [u, v, 1] ("uv") to
    [x w, y w, w]; w is the homogeneous scale (proportional to 1 / depth, its sign the side
    of the horizon)."""
    u, v = np.asarray(u, np.float64), np.asarray(v, np.float64)
    a, b = (v, u) if order == "rowcol" else (u, v)
    p = np.stack([a, b, np.ones_like(a)], -1) @ H.T
    w = p[..., 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        return p[..., 0] / w, p[..., 1] / w, w


def grid_points(H: np.ndarray, image_size: tuple[int, int], n: int, order: str = "rowcol",
                depth_ratio: float = 10.0) -> tuple[np.ndarray, np.ndarray]:
    """Image points (px) on an n x n grid over the image (cell centres) that H maps in front of
    the camera (the bottom centre's side of the horizon) at most `depth_ratio` times as deep as
    the nearest grid point."""
    w, h = image_size
    uu, vv = np.meshgrid((np.arange(n) + 0.5) * w / n, (np.arange(n) + 0.5) * h / n)
    u, v = uu.ravel(), vv.ravel()
    sign = np.sign(image_to_ground(H, w / 2, h - 0.5, order)[2])
    s = sign * image_to_ground(H, u, v, order)[2]
    keep = (s > 0) & (s >= s.max() / depth_ratio)
    return u[keep], v[keep]


def through_homography(pts: dict[str, np.ndarray], H: np.ndarray, order: str, *,
                       source: str, front_sign: float | None = None) -> Made:
    """Footprints of image points `pts` (u, v [, track_id, frame]) through H; points on the
    other side of the horizon than most of them (or than `front_sign`) are dropped (noted)."""
    x, y, w = image_to_ground(H, pts["u"], pts["v"], order)
    sign = front_sign if front_sign is not None else (1.0 if np.sum(w > 0) >= np.sum(w < 0)
                                                      else -1.0)
    keep = (sign * w > 0) & np.isfinite(x) & np.isfinite(y)
    notes = []
    if not keep.all():
        notes.append(f"{int((~keep).sum())} image point(s) dropped: on or above the horizon "
                     "of the homography")
    if not keep.any():
        raise BadInput(source, "no image point maps onto the ground in front of the camera "
                       "(check --homography-convention)")
    cols = {k: np.asarray(a)[keep] for k, a in pts.items()}
    cols["x"], cols["y"] = x[keep], y[keep]
    return Made(cols, _order(cols), source=source, notes=notes, homography_rms_px=0.0)


def _order(cols) -> tuple[str, ...]:
    return ("u", "v", "x", "y") + tuple(k for k in ("track_id", "frame") if k in cols)


# ----------------------------------------------------------------------------------------------
# Footprints from boxes and world positions

def homography_rms(u, v, x, y) -> tuple[np.ndarray, float]:
    """Least-squares homography ground -> image (``cv2.findHomography``, method 0) and its RMS
    (px per coordinate) over the pairs."""
    src = np.stack([x, y], 1).astype(np.float64)
    M, _ = cv2.findHomography(src, np.stack([u, v], 1).astype(np.float64), 0)
    if M is None:
        return np.full((3, 3), np.nan), math.nan
    pu, pv = _apply(M, x, y)
    return M, float(np.sqrt(np.mean(np.concatenate([pu - u, pv - v]) ** 2)))


def _apply(M, x, y):
    p = np.stack([x, y, np.ones_like(x)], -1) @ M.T
    return p[..., 0] / p[..., 2], p[..., 1] / p[..., 2]


def match_by_id(boxes, pos, frame_offset: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Indices (box, position) of the rows with the same id and frame (box frame + offset)."""
    key = {(int(f) + frame_offset, int(i)): k for k, (f, i) in
           enumerate(zip(boxes["frame"], boxes["id"]))}
    pairs = [(key[(int(f), int(i))], j) for j, (f, i) in enumerate(zip(pos["frame"], pos["id"]))
             if (int(f), int(i)) in key]
    a = np.asarray(pairs, np.int64).reshape(-1, 2)
    return a[:, 0], a[:, 1]


def match_by_geometry(boxes, pos, frame_offset: int = 0, gate_px: float = 12.0, seed: int = 0
                      ) -> tuple[np.ndarray, np.ndarray]:
    """Indices (box, position) matched by geometry (module doc): RANSAC homography over the
    same-frame pairs, then a gated Hungarian assignment per frame, twice. Raises ValueError
    when fewer than 4 pairs share a frame or no homography is found."""
    from scipy.optimize import linear_sum_assignment

    bf = boxes["frame"] + frame_offset
    by_frame = {f: np.flatnonzero(bf == f) for f in np.unique(bf)}
    cand = [(i, j) for j, f in enumerate(pos["frame"]) for i in by_frame.get(int(f), ())]
    if len(cand) < 4:
        raise ValueError("fewer than 4 (box, position) pairs share a frame: check "
                         "--frame-offset (world frame = box frame + offset)")
    ci, cj = np.asarray(cand).T
    cv2.setRNGSeed(seed)
    M, _ = cv2.findHomography(np.stack([pos["x"][cj], pos["y"][cj]], 1),
                              np.stack([boxes["foot_u"][ci], boxes["foot_v"][ci]], 1),
                              cv2.RANSAC, gate_px, maxIters=20000, confidence=0.9999)
    if M is None:
        raise ValueError("no homography found between the boxes and the positions")
    for _ in range(2):
        pu, pv = _apply(M, pos["x"], pos["y"])
        bi, pj = [], []
        for f in np.unique(pos["frame"]):
            js, is_ = np.flatnonzero(pos["frame"] == f), by_frame.get(int(f), np.zeros(0, int))
            if not is_.size:
                continue
            d = np.hypot(pu[js, None] - boxes["foot_u"][is_], pv[js, None] - boxes["foot_v"][is_])
            d = np.where(np.isfinite(d), d, 1e9)
            r, c = linear_sum_assignment(np.where(d <= gate_px, d, 1e6))
            ok = d[r, c] <= gate_px
            pj += list(js[r[ok]])
            bi += list(is_[c[ok]])
        bi, pj = np.asarray(bi, np.int64), np.asarray(pj, np.int64)
        if bi.size < 4:
            raise ValueError(f"fewer than 4 pairs within {gate_px:g} px: raise --gate-px or "
                             "check --frame-offset and --box-scale")
        M, _ = homography_rms(boxes["foot_u"][bi], boxes["foot_v"][bi], pos["x"][pj],
                              pos["y"][pj])
    return bi, pj


def from_boxes(boxes, pos=None, *, match: str = "auto", frame_offset: int = 0,
               gate_px: float = 12.0, source: str = "boxes") -> Made:
    """Footprints of boxes and world positions (`pos`; None: the boxes' own world x, y)."""
    notes = []
    if pos is None:
        ok = np.isfinite(boxes["x"]) & np.isfinite(boxes["y"])
        if not ok.any():
            raise BadInput(source, "the boxes carry no world position (MOT x, y columns are -1): "
                           "give --positions or --homography")
        bi = np.flatnonzero(ok)
        x, y, how = boxes["x"][bi], boxes["y"][bi], ""
    else:
        if match == "auto":
            bi, pj = match_by_id(boxes, pos, frame_offset)
            match = "id" if bi.size >= 0.5 * pos["frame"].size else "geometry"
        if match == "id":
            bi, pj = match_by_id(boxes, pos, frame_offset)
            if bi.size < 4:
                raise BadInput(source, f"only {bi.size} positions share a frame and id with a "
                               "box: use --match geometry or check --frame-offset")
        else:
            try:
                bi, pj = match_by_geometry(boxes, pos, frame_offset, gate_px)
            except ValueError as e:
                raise BadInput(source, str(e)) from None
        x, y, how = pos["x"][pj], pos["y"][pj], match
        notes.append(f"{pos['frame'].size - bi.size} of {pos['frame'].size} positions without "
                     f"a box (gate {gate_px:g} px)" if match == "geometry" else
                     f"{pos['frame'].size - bi.size} of {pos['frame'].size} positions without a "
                     "box of the same id and frame")
    cols = {"u": boxes["foot_u"][bi], "v": boxes["foot_v"][bi], "x": x, "y": y,
            "track_id": boxes["id"][bi], "frame": boxes["frame"][bi]}
    order = np.lexsort((cols["frame"], cols["track_id"]))
    cols = {k: a[order] for k, a in cols.items()}
    rms = homography_rms(cols["u"], cols["v"], cols["x"], cols["y"])[1] if bi.size >= 4 else \
        math.nan
    return Made(cols, _order(cols), source=source, match=how, notes=notes,
                homography_rms_px=rms)


def write_footprints(path, made: Made) -> None:
    """Write the footprints table (.csv or .parquet, atomically)."""
    write_table(path, made.columns, made.order)
