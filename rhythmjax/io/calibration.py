"""Readers of the calibrations a user has: a Tsai XML (PETS / ETISEO), an OpenCV calibration
(what `cv2.FileStorage` writes as YAML, XML or JSON, or a plain JSON object) and a homography
text file (ETH's H.txt). Every problem is one `BadInput` naming the file and the field."""

from __future__ import annotations

import json
import math
import os
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field

import numpy as np

from ..model.camera_from import CameraError, rodrigues
from ..model.lens import OPENCV_COUNTS, TsaiCalibration
from .errors import BadInput, PathLike, read_text


# key spellings accepted in OpenCV files, compared without case; the first is the one we write
KEYS = {
    "K": ("camera_matrix", "K", "cameraMatrix", "camera_matrix_K", "intrinsic_matrix",
          "intrinsics", "intrinsic", "mtx"),
    "dist": ("distortion_coefficients", "dist", "dist_coeffs", "distCoeffs", "distortion",
             "D"),
    "R": ("R", "rotation_matrix", "rmat"),
    "rvec": ("rvec", "rvecs", "rotation_vector"),
    "t": ("t", "tvec", "tvecs", "translation", "translation_vector", "T"),
    "image_size": ("image_size", "imageSize", "image_size_px", "resolution"),
    "image_width": ("image_width", "imageWidth", "width"),
    "image_height": ("image_height", "imageHeight", "height"),
}


def _number(path, key: str, text) -> float:
    try:
        v = float(text)
    except (TypeError, ValueError):
        raise BadInput(path, f"{key}: expected a number, got {text!r}", key=key) from None
    if not math.isfinite(v):
        raise BadInput(path, f"{key}: must be finite, got {text!r}", key=key)
    return v


# ----------------------------------------------------------------------------------------------
# Tsai XML

def read_tsai(path: PathLike) -> TsaiCalibration:
    """The Tsai calibration of a PETS / ETISEO XML: <Camera> with <Geometry width height dpx
    dy>, <Intrinsic focal kappa1 cx cy sx> and <Extrinsic tx ty tz rx ry rz> (mm, px, rad).
    width and height (the calibration's image size) may be absent (None)."""
    p = os.fspath(path)
    text = read_text(p, "calibration file")
    try:
        root = ET.fromstring(text)
    except ET.ParseError as e:
        line, col = e.position
        raise BadInput(p, f"not well-formed XML ({str(e).split(':')[0]})", line=line,
                       column=col + 1) from None
    cam = root if root.tag == "Camera" else root.find(".//Camera")
    if cam is None:
        raise BadInput(p, "no <Camera> element (expected a Tsai calibration, PETS / ETISEO "
                       "format)", key="Camera")
    parts = {}
    for tag in ("Geometry", "Intrinsic", "Extrinsic"):
        el = cam.find(tag)
        if el is None:
            raise BadInput(p, f"Camera.{tag}: missing element", key=f"Camera.{tag}")
        parts[tag] = el

    def num(tag: str, name: str, positive: bool = False) -> float:
        key = f"{tag}.{name}"
        raw = parts[tag].get(name)
        if raw is None:
            raise BadInput(p, f"{key}: missing attribute", key=key)
        v = _number(p, key, raw)
        if positive and not v > 0:
            raise BadInput(p, f"{key}: must be > 0, got {raw}", key=key)
        return v

    size = []
    for name in ("width", "height"):
        raw = parts["Geometry"].get(name)
        v = None if raw is None else num("Geometry", name, positive=True)
        if v is not None and v != int(v):
            raise BadInput(p, f"Geometry.{name}: expected an integer, got {raw}",
                           key=f"Geometry.{name}")
        size.append(None if v is None else int(v))
    return TsaiCalibration(
        focal=num("Intrinsic", "focal", True), kappa1=num("Intrinsic", "kappa1"),
        cx=num("Intrinsic", "cx"), cy=num("Intrinsic", "cy"), sx=num("Intrinsic", "sx", True),
        dpx=num("Geometry", "dpx", True), dy=num("Geometry", "dy", True),
        T=tuple(num("Extrinsic", k) for k in ("tx", "ty", "tz")),
        Rxyz=tuple(num("Extrinsic", k) for k in ("rx", "ry", "rz")),
        width=size[0], height=size[1])


# ----------------------------------------------------------------------------------------------
# OpenCV calibration

@dataclass(frozen=True)
class OpenCVCalibration:
    """K (3x3 px), the pose as R (3x3) or rvec (3, rad), t (3, world units), dist (OpenCV's
    coefficients or None), image_size (w, h px) or None, and `keys`: field -> the key read."""

    K: np.ndarray
    t: np.ndarray
    R: np.ndarray | None = None
    rvec: np.ndarray | None = None
    dist: np.ndarray | None = None
    image_size: tuple[int, int] | None = None
    keys: dict = field(default_factory=dict)


def _from_json_object(obj):
    """A parsed value with OpenCV's matrices ({rows, cols, data} of "opencv-matrix", {sizes,
    data} of "opencv-nd-matrix") as arrays."""
    if isinstance(obj, dict):
        shape = ([obj.get("rows"), obj.get("cols")] if {"rows", "cols"} <= obj.keys() else
                 obj.get("sizes"))
        if "data" in obj and shape is not None:
            try:
                return np.asarray(obj["data"], np.float64).reshape(np.asarray(shape, int))
            except (TypeError, ValueError):
                return obj
        return {k: _from_json_object(v) for k, v in obj.items()}
    if isinstance(obj, list):
        return [_from_json_object(v) for v in obj]
    return obj


def _from_node(node):
    """A cv2.FileNode as Python: maps, sequences, numbers, strings (matrices are maps here;
    `_from_json_object` turns them into arrays)."""
    if node.isMap():
        return {k: _from_node(node.getNode(k)) for k in node.keys()}
    if node.isSeq():
        return [_from_node(node.at(i)) for i in range(node.size())]
    if node.isInt() or node.isReal():
        return node.real()
    if node.isString():
        return node.string()
    return None


def _load_opencv(p: str) -> dict:
    text = read_text(p, "calibration file")
    if p.lower().endswith(".json") or text.lstrip().startswith("{"):
        try:
            obj = json.loads(text)
        except json.JSONDecodeError as e:
            raise BadInput(p, e.msg, line=e.lineno, column=e.colno) from None
    else:
        import cv2

        try:
            fs = cv2.FileStorage(p, cv2.FILE_STORAGE_READ)
            obj = _from_node(fs.root()) if fs.isOpened() else None
        except (cv2.error, SystemError) as e:
            err = e.__cause__ if isinstance(e, SystemError) and e.__cause__ else e
            m = re.search(r"\((\d+)\): ([^\n]*)", str(err))
            if m:
                raise BadInput(p, f"unreadable ({m.group(2).strip()})",
                               line=int(m.group(1))) from None
            raise BadInput(p, "unreadable: not OpenCV YAML / XML / JSON") from None
        if obj is None:
            raise BadInput(p, "unreadable: not OpenCV YAML / XML / JSON")
    if not isinstance(obj, dict):
        raise BadInput(p, "expected a map of named matrices at the top level")
    return _from_json_object(obj)


def _find(p: str, d: dict, what: str):
    """(key, value) of the field `what` under any of its spellings; (None, None) if absent."""
    low = {}
    for k in d:
        low.setdefault(str(k).lower(), []).append(k)
    hits = [k for name in KEYS[what] for k in low.get(name.lower(), [])]
    hits = list(dict.fromkeys(hits))
    if len(hits) > 1:
        raise BadInput(p, f"{hits[0]}, {hits[1]}: two keys for {what}; keep one", key=hits[1])
    return (hits[0], d[hits[0]]) if hits else (None, None)


def _array(p: str, key: str, v, sizes: tuple[int, ...] | None) -> np.ndarray:
    """The numbers of field `key` as float64: `sizes` the counts allowed (None: a multiple of
    3, several 3-vectors)."""
    try:
        a = np.asarray(v, np.float64)
    except (TypeError, ValueError):
        raise BadInput(p, f"{key}: expected numbers, got {str(v)[:60]}", key=key) from None
    ok = a.size in sizes if sizes else a.size > 0 and a.size % 3 == 0
    if not ok or a.ndim > (2 if sizes else 3):
        want = " or ".join(map(str, sizes)) if sizes else "3"
        raise BadInput(p, f"{key}: expected {want} numbers, got shape {list(a.shape)}", key=key)
    if not np.all(np.isfinite(a)):
        raise BadInput(p, f"{key}: non-finite number", key=key)
    return a


def read_opencv(path: PathLike) -> OpenCVCalibration:
    """K, the pose (R or rvec, t), the distortion and the image size of an OpenCV calibration
    file (module doc); the accepted key spellings are `KEYS` (case ignored). A file with several
    poses (calibrateCamera's rvecs / tvecs, one per view) is refused: it does not say which is
    the camera at work."""
    p = os.fspath(path)
    d = _load_opencv(p)
    keys = {}
    got = {}
    for what in KEYS:
        k, v = _find(p, d, what)
        if k is not None:
            keys[what], got[what] = k, v
    for need, alts in (("K", ("K",)), ("pose", ("R", "rvec")), ("t", ("t",))):
        if not any(a in got for a in alts):
            names = ", ".join(n for a in alts for n in KEYS[a][:3])
            raise BadInput(p, f"{need}: missing (looked for {names}, ...)", key=need)
    K = _array(p, keys["K"], got["K"], (9,)).reshape(3, 3)
    t = _array(p, keys["t"], got["t"], None).reshape(-1, 3)
    rvec = R = None
    if "rvec" in got:
        rvec = _array(p, keys["rvec"], got["rvec"], None).reshape(-1, 3)
        if rvec.shape[0] > 1:
            raise BadInput(p, f"{keys['rvec']}: {rvec.shape[0]} poses (one per calibration "
                           "view); give the pose of the camera at work", key=keys["rvec"])
        rvec = rvec[0]
    if t.shape[0] > 1:
        raise BadInput(p, f"{keys['t']}: {t.shape[0]} translations; give one",
                       key=keys["t"])
    if "R" in got:
        R = _array(p, keys["R"], got["R"], (9,)).reshape(3, 3)
        if rvec is not None and np.abs(rodrigues(rvec) - R).max() > 1e-6:
            raise BadInput(p, f"{keys['R']}, {keys['rvec']}: the rotation matrix and the "
                           "rotation vector disagree; keep one", key=keys["R"])
    dist = None
    if "dist" in got:
        dist = _array(p, keys["dist"], got["dist"], OPENCV_COUNTS).ravel()
    size = None
    if "image_size" in got:
        size = tuple(_array(p, keys["image_size"], got["image_size"], (2,)).ravel())
    elif "image_width" in got and "image_height" in got:
        size = (_number(p, keys["image_width"], got["image_width"]),
                _number(p, keys["image_height"], got["image_height"]))
    if size is not None:
        if not all(s > 0 and s == int(s) for s in size):
            raise BadInput(p, f"{keys.get('image_size', keys.get('image_width'))}: expected "
                           f"two positive integers (w, h), got {size}", key="image_size")
        size = (int(size[0]), int(size[1]))
    return OpenCVCalibration(K, t[0], R, rvec, dist, size, keys)


# ----------------------------------------------------------------------------------------------
# homography text

def read_homography(path: PathLike) -> np.ndarray:
    """A 3x3 matrix from a text file: three lines of three numbers (whitespace or commas;
    blank lines and # comments skipped), as ETH's H.txt."""
    p = os.fspath(path)
    rows = []
    for n, line in enumerate(read_text(p, "calibration file").splitlines(), 1):
        line = line.split("#")[0].replace(",", " ").strip()
        if not line:
            continue
        vals = []
        for tok in line.split():
            try:
                vals.append(float(tok))
            except ValueError:
                raise BadInput(p, f"H: non-numeric value {tok!r}", line=n, key="H") from None
        if len(vals) != 3:
            raise BadInput(p, f"H: expected 3 numbers on a row, got {len(vals)}", line=n,
                           key="H")
        if not all(math.isfinite(v) for v in vals):
            raise BadInput(p, "H: non-finite number", line=n, key="H")
        rows.append(vals)
    if len(rows) != 3:
        raise BadInput(p, f"H: expected 3 rows of 3 numbers, got {len(rows)} rows", key="H")
    return np.asarray(rows, np.float64)


def bad_camera(path: PathLike, err: CameraError) -> BadInput:
    """A `CameraError` of the model as the one-line `BadInput` naming `path` and the field."""
    return BadInput(path, str(err), key=err.key)
