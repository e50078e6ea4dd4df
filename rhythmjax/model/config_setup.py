"""A config for a given video: the facts the video holds (image size, frame rate) fill what the
config leaves out, and the detection range follows the camera.

Precedence: a key the config gives wins over the video's fact (the command line's `--fps` is
written into the dict by the caller, so it wins over both). What the config leaves out:
- `camera.image_width_px`, `image_height_px`, `fps`: the video's;
- `camera.uc_px`, `vc_px`: the centre of the image (`params.config_from_dict`);
- `thresholds.n_samples`: round(window_s x fps), window_s = 64/15 s by default (Table 1's N = 64
  at 15 fps);
- `thresholds.range_min_m`, `range_max_m`: the ground the image sees (`view.visible_range`),
  except for the paper's own camera and image (no camera geometry given, 512 x 512), which keep
  Table 1's 3-20 m.
"""

from __future__ import annotations

import copy
from typing import Any

from .params import Config, ConfigError, config_from_dict, host_float
from .view import visible_range


GEOMETRY_KEYS = ("f_m", "h_m", "theta_deg", "a_px_per_m", "b_px_per_m", "uc_px", "vc_px",
                 "roll_deg", "image_width_px", "image_height_px")
PAPER_IMAGE = (512, 512)


def with_video_facts(d: Any, *, image_size: tuple[int, int] | None = None,
                     fps: float | None = None) -> dict:
    """A copy of the config dict `d` with the video's image size (w, h px) and frame rate filled
    in where `d` leaves them out."""
    out = copy.deepcopy(d) if isinstance(d, dict) else d
    if not isinstance(out, dict):
        return out
    cam = out.setdefault("camera", {})
    if not isinstance(cam, dict):
        return out
    if image_size is not None:
        cam.setdefault("image_width_px", int(image_size[0]))
        cam.setdefault("image_height_px", int(image_size[1]))
    if fps is not None:
        cam.setdefault("fps", float(fps))
    return out


def range_is_derived(d: dict) -> bool:
    """True when the detection range is to come from the camera (module doc)."""
    cam, thr = d.get("camera", {}), d.get("thresholds", {})
    if "range_min_m" in thr and "range_max_m" in thr:
        return False
    size = (cam.get("image_width_px", PAPER_IMAGE[0]), cam.get("image_height_px", PAPER_IMAGE[1]))
    return any(k in cam for k in GEOMETRY_KEYS if not k.startswith("image_")) or (
        tuple(size) != PAPER_IMAGE)


def config_for(d: Any, *, image_size: tuple[int, int] | None = None,
               fps: float | None = None) -> Config:
    """The Config of the dict `d` (partial; `params.config_from_dict`'s checks) for a video of
    `image_size` (w, h px) at `fps`, with the defaults of the module doc. Raises `ConfigError`
    naming the key; `thresholds` when the camera sees no usable ground to derive a range from."""
    d = with_video_facts(d, image_size=image_size, fps=fps)
    cfg = config_from_dict(d)
    if not range_is_derived(d):
        return cfg
    try:
        near, far = visible_range(cfg.camera, host_float(cfg.width.height))
    except ValueError as e:
        raise ConfigError("thresholds.range_min_m", f"no detection range can be derived from "
                          f"the camera ({e}); give range_min_m and range_max_m or fix the "
                          "camera (`rhythmjax camera`)") from None
    thr = d.get("thresholds", {})
    near = thr.get("range_min_m", near)
    far = thr.get("range_max_m", far)
    d["thresholds"] = {**thr, "range_min_m": float(near), "range_max_m": float(far)}
    return config_from_dict(d)
