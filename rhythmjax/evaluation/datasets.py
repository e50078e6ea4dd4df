"""Loaders for the real data sets in ``../shared/data/real`` (see each folder's SOURCE.md).

Nothing here is copied into the repository; every loader takes an optional `root` and the
``*_root()`` functions return None when a folder is absent, so callers (tests) can skip.

- PETS 2009 S2.L1 View 001: CVML boxes (768x576 px, scaled by 0.625 to the 480x360 video),
  TrajNet ground positions (m, the Tsai world frame), the Tsai calibration with radial distortion.
- ETH/EWAP seq_eth, seq_hotel: obsmat (m) and H mapping [row, col, 1] to metres.
- UCSD Ped2: JPEG clip folders and the anomaly boxes (bicycles, cart).
"""

from __future__ import annotations

import csv
import os
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..io.calibration import read_tsai
from ..io.errors import BadInput
from ..model.camera_from import camera_from_tsai
from ..model.lens import TsaiCalibration
from ..model.params import Camera


def default_data_root() -> Path:
    """Where the real data sets are: $RHYTHMJAX_DATA when set; else the first existing
    ``shared/data/real`` beside the checkout this module runs from (an editable install), in
    the working directory, or in its parent (a checkout's root, after a plain ``pip install .``
    whose module lies in the environment); else the parent's, which the messages name."""
    env = os.environ.get("RHYTHMJAX_DATA")
    if env:
        return Path(env)
    tail = Path("shared") / "data" / "real"
    cwd = Path.cwd()
    for base in (Path(__file__).resolve().parents[3], cwd, cwd.parent):
        if (base / tail).is_dir():
            return base / tail
    return cwd.parent / tail


DATA_ROOT: Path = default_data_root()
PETS_FPS = 7.0  # MOTChallenge frameRate (the container's 10 fps is wrong; SOURCE.md)
PETS_SCALE = 0.625  # 768x576 -> 480x360
PETS_SIZE = (480, 360)
UCSD_CLIPS = ("Test002", "Test004", "Test006", "Test010")
ETH_SEQUENCES = ("seq_eth", "seq_hotel")
_ETH_INFO = {"seq_eth": (15.0, (640, 480)), "seq_hotel": (25.0, (720, 576))}  # numbering fps, WxH


def _root(name: str, root) -> Path | None:
    p = Path(root) if root is not None else DATA_ROOT / name
    return p if p.is_dir() else None


def _need(name: str, root) -> Path:
    p = _root(name, root)
    if p is None:
        raise FileNotFoundError(f"data folder {Path(root) if root else DATA_ROOT / name} absent "
                                "(set RHYTHMJAX_DATA to the folder that holds the data sets)")
    return p


# ----------------------------------------------------------------------------------------------
# PETS 2009 S2.L1

def pets_root() -> Path | None:
    """The PETS folder, or None when it is absent (callers skip)."""
    return _root("pets2009_s2l1", None)


def pets_boxes(root=None, *, cropped: bool = False, scale: float = PETS_SCALE
               ) -> dict[str, np.ndarray]:
    """Milan's CVML boxes, scaled to the video (px): frame (0-based), id, bb_left, bb_top,
    bb_width, bb_height, foot_u, foot_v (box bottom centre), sorted by frame then id."""
    r = _need("pets2009_s2l1", root)
    path = r / "annotations" / ("PETS2009-S2L1-cropped.xml" if cropped else "PETS2009-S2L1.xml")
    rows = []
    try:
        tree = ET.parse(path)
    except ET.ParseError as e:
        raise BadInput(path, f"not valid XML: {e}") from None
    for fr in tree.getroot().iter("frame"):
        for ob in fr.iter("object"):
            b = ob.find("box")
            try:
                k, i = int(fr.get("number")), int(ob.get("id"))
                h, w, xc, yc = (float(b.get(a)) for a in ("h", "w", "xc", "yc"))
            except (TypeError, ValueError, AttributeError):
                raise BadInput(path, f"frame {fr.get('number')} object {ob.get('id')}: "
                                     "missing or non-numeric box attribute") from None
            rows.append((k, i, xc, yc, w, h))
    a = np.asarray(rows, np.float64).reshape(-1, 6)
    a = a[np.lexsort((a[:, 1], a[:, 0]))]
    xc, yc, w, h = (a[:, j] * scale for j in range(2, 6))
    return {"frame": a[:, 0].astype(np.int64), "id": a[:, 1].astype(np.int64),
            "bb_left": xc - w / 2, "bb_top": yc - h / 2, "bb_width": w, "bb_height": h,
            "foot_u": xc, "foot_v": yc + h / 2}


def pets_world(root=None) -> dict[str, np.ndarray]:
    """TrajNet ground positions: frame (0-based video frame), id (a 20-step chunk, not a
    person), x, y (m, the Tsai world frame)."""
    r = _need("pets2009_s2l1", root)
    path = r / "world" / "PETS09-S2L1_trajnet.txt"
    a = _read_floats(path, 4)
    return {"frame": a[:, 0].astype(np.int64), "id": a[:, 1].astype(np.int64),
            "x": a[:, 2], "y": a[:, 3]}


def pets_video(root=None) -> Path:
    """The 480x360 video (795 frames; use `PETS_FPS`, not the container's 10 fps)."""
    return _need("pets2009_s2l1", root) / "video" / "vtest_480x360.avi"


def _read_floats(path: Path, ncol: int) -> np.ndarray:
    out = []
    with open(path) as fh:
        for n, line in enumerate(fh, 1):
            if not line.strip():
                continue
            try:
                vals = [float(t) for t in line.split()]
            except ValueError:
                raise BadInput(path, "non-numeric value", line=n) from None
            if len(vals) < ncol:
                raise BadInput(path, f"expected {ncol} columns, got {len(vals)}", line=n)
            out.append(vals[:ncol])
    return np.asarray(out, np.float64).reshape(-1, ncol)


@dataclass(frozen=True)
class TsaiCamera(TsaiCalibration):
    """PETS' View_001.xml: the library's Tsai model (`model.lens.TsaiCalibration`, world m,
    R = Rz Ry Rx, radial kappa1) with the pixel `scale` defaulting to 0.625, the 480x360 video."""

    def focal_px(self, scale: float = PETS_SCALE) -> tuple[float, float]:
        return super().focal_px(scale)

    def world_to_image(self, x, y, z=0.0, scale: float = PETS_SCALE):
        return super().world_to_image(x, y, z, scale)

    def ground_of_image(self, u, v, scale: float = PETS_SCALE):
        return super().ground_of_image(u, v, scale)


def pets_tsai(root=None) -> TsaiCamera:
    """The Tsai calibration of View 001 (calibration/View_001.xml, `io.calibration.read_tsai`)."""
    path = _need("pets2009_s2l1", root) / "calibration" / "View_001.xml"
    return TsaiCamera(**read_tsai(path).__dict__)


def pets_camera(root=None, *, scale: float = PETS_SCALE) -> Camera:
    """The camera of (3) of the Tsai calibration (`model.camera_from.camera_from_tsai`, what
    `rhythmjax camera --tsai` writes) for the 480x360 video at 7 fps: exact but for the lens
    distortion (2-3 % at the corners) and a f != b f with roll; its ground frame is the
    camera's (y along the optical axis), so map world points with `pets_ground`."""
    return pets_camera_from(root, scale).camera()


def pets_camera_from(root=None, scale: float = PETS_SCALE):
    """`model.camera_from.camera_from_tsai` of the Tsai calibration for the video scaled by
    `scale` (7 fps): the camera of (3) and the world -> ground transform (`pets_camera`,
    `pets_ground`)."""
    t = pets_tsai(root)
    size = PETS_SIZE if scale == PETS_SCALE else (round(t.width * scale), round(t.height * scale))
    return camera_from_tsai(t, image_size=size, fps=PETS_FPS)


def pets_ground(x, y, root=None) -> tuple[np.ndarray, np.ndarray]:
    """World (TrajNet/Tsai, m) -> the ground frame of `pets_camera` (m): x right, y ahead."""
    return pets_camera_from(root, PETS_SCALE).transform.apply(x, y)


# ----------------------------------------------------------------------------------------------
# UCSD Ped2

def ucsd_root() -> Path | None:
    return _root("ucsd_ped2", None)


def ucsd_clip(clip: str, root=None) -> tuple[Path, dict[str, np.ndarray]]:
    """(frames folder of NNN.jpg, anomaly boxes: frame (0-based), x, y, w, h (px), area)."""
    if clip not in UCSD_CLIPS:
        raise ValueError(f"unknown UCSD clip {clip!r}; choose from {UCSD_CLIPS}")
    r = _need("ucsd_ped2", root)
    path = r / "anomaly_boxes.csv"
    rows = []
    with open(path, newline="") as fh:
        for n, rec in enumerate(csv.DictReader(fh), 2):
            if rec.get("clip") != clip:
                continue
            try:
                rows.append([float(rec[k]) for k in ("frame_index", "x", "y", "w", "h",
                                                     "area_px")])
            except (KeyError, TypeError, ValueError):
                raise BadInput(path, "missing or non-numeric box value", line=n) from None
    a = np.asarray(rows, np.float64).reshape(-1, 6)
    return r / clip, {"frame": a[:, 0].astype(np.int64), "x": a[:, 1], "y": a[:, 2],
                      "w": a[:, 3], "h": a[:, 4], "area": a[:, 5]}


# ----------------------------------------------------------------------------------------------
# ETH / EWAP

def eth_root() -> Path | None:
    return _root("eth_ewap", None)


@dataclass(frozen=True)
class EthSequence:
    """One ETH sequence. `H` maps [row, col, 1] (px) to world [x, y, w] (m after dividing by
    w); `obs` columns frame (video numbering), id, x, y (m), vx, vy (m/s); annotations every
    `dt` = 1 / `fps` s (2.5 fps); `frame_fps` is the frame numbering rate; `video` is None
    (not in the snapshot); `image_size` = (width, height) px of reference.png."""

    name: str
    H: np.ndarray
    obs: dict[str, np.ndarray]
    video: Path | None
    reference: Path
    fps: float
    frame_fps: float
    image_size: tuple[int, int]

    def image_points(self, x=None, y=None) -> tuple[np.ndarray, np.ndarray]:
        """(u, v) px (column, row) of world points (m) through H^-1 (default: every obs)."""
        x = self.obs["x"] if x is None else np.asarray(x, np.float64)
        y = self.obs["y"] if y is None else np.asarray(y, np.float64)
        p = np.stack([x, y, np.ones_like(x)], -1) @ np.linalg.inv(self.H).T
        return p[..., 1] / p[..., 2], p[..., 0] / p[..., 2]

    def world_of_image(self, u, v) -> tuple[np.ndarray, np.ndarray]:
        """World (x, y) m of image points (u = column, v = row) through H."""
        u, v = np.asarray(u, np.float64), np.asarray(v, np.float64)
        p = np.stack([v, u, np.ones_like(u)], -1) @ self.H.T
        return p[..., 0] / p[..., 2], p[..., 1] / p[..., 2]


def eth_sequence(name: str, root=None) -> EthSequence:
    """Load `seq_eth` or `seq_hotel` (H.txt, obsmat.txt) from the eth_ewap folder."""
    if name not in ETH_SEQUENCES:
        raise ValueError(f"unknown ETH sequence {name!r}; choose from {ETH_SEQUENCES}")
    d = _need("eth_ewap", root) / name
    H = _read_floats(d / "H.txt", 3)
    if H.shape != (3, 3) or abs(np.linalg.det(H)) < 1e-15:
        raise BadInput(d / "H.txt", "expected an invertible 3x3 matrix")
    a = _read_floats(d / "obsmat.txt", 8)
    obs = {"frame": a[:, 0].astype(np.int64), "id": a[:, 1].astype(np.int64), "x": a[:, 2],
           "y": a[:, 4], "vx": a[:, 5], "vy": a[:, 7]}
    video = d / "video.avi"
    frame_fps, size = _ETH_INFO[name]
    return EthSequence(name, H, obs, video if video.is_file() else None, d / "reference.png",
                       2.5, frame_fps, size)
