"""What `rhythmjax-fit camera` decides around the fit (`fit_footprints`): which parameters the
config gives (held) and which it leaves out (fitted), the image size the principal point's start
needs, the units check, and the config to write (the detection range derived again from the
fitted camera). The command line (`fit.cli`) reads the files and prints; this works on arrays
and a config dict, so studies (`fit.random_cameras`) run exactly the CLI's defaults."""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np


if TYPE_CHECKING:
    from fit.camera import CameraFit
    from rhythmjax.model.params import Config


UNITS = {"m": 1.0, "cm": 0.01, "mm": 0.001}  # the file's x, y unit -> m
PLAUSIBLE_H_M, PLAUSIBLE_SPAN_M = 30.0, 1000.0  # beyond these the units check warns


@dataclass
class CameraRun:
    """What `fit_footprints` did: the fit, the config it implies and the dict to write (both
    None when the fit failed; the Config None too when no detection range can be derived),
    the fitted camera's report (`rhythmjax.model.view.camera_report`), why each parameter not
    fitted was held (`held`), what the user is told (`notes`) and warned about (`warnings`)."""

    fit: CameraFit
    config: Config | None
    config_dict: dict | None
    report: dict
    principal_point: str
    held: dict[str, str] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)

    def to_dict(self) -> dict:
        return {**self.fit.to_dict(), "principal_point": self.principal_point,
                "held": self.held, "notes": self.notes, "warnings": self.warnings,
                "camera_report": self.report, "config": self.config_dict}


def units_warning(x, y, h_m: float) -> str | None:
    """One line when x, y look like centimetres or millimetres (a fitted h above 30 m, or a
    ground span above 1000), naming the likely unit and the fix; else None."""
    span = float(max(np.ptp(x), np.ptp(y))) if np.size(x) else 0.0
    if h_m > PLAUSIBLE_H_M:  # the likelier unit: h nearer a typical 4 m (log scale)
        names = {"cm": "centimetres", "mm": "millimetres"}
        ok = sorted((u for u in names if 0.5 <= h_m * UNITS[u] <= PLAUSIBLE_H_M),
                    key=lambda u: abs(math.log(h_m * UNITS[u] / 4.0)))
        what = " or ".join(f"{names[u]} (h {h_m * UNITS[u]:.3g} m)" for u in ok)
        return (f"fitted h {h_m:.4g} m over a ground span of {span:.4g}: " + (
            f"x, y look like {what}; rerun with --units {ok[0]}" if ok else
            "if x, y are not in metres, rerun with --units cm or --units mm"))
    if span > PLAUSIBLE_SPAN_M:
        return (f"the footprints span {span:.4g} m on the ground: if x, y are in centimetres or "
                "millimetres, rerun with --units cm or --units mm")
    return None


def fit_footprints(u, v, x, y, d: dict, *, path: str = "footprints",
                   config_path: str | None = None,
                   image_size=None, fit_center: bool = False, image_center: bool = False,
                   fit_roll: bool = False, world: bool = False, loss: str = "l2",
                   max_steps: int = 256) -> CameraRun:
    """`rhythmjax-fit camera` on arrays: footprints (u, v px; x, y m) and the config FILE's dict
    `d` ({} for none). What the config gives is held, what it leaves out is fitted: the principal
    point (uc_px, vc_px; its start the image centre, so the image size must be known: the
    config's or `image_size` (w, h px), which wins) unless `image_center` holds it there; the roll
    (roll_deg). a f, h, theta are always fitted, b f too unless the principal point is (b/a held)
    or `world`. The dict to write is `d` with its camera section replaced by the fitted camera
    (fps and image size as `d` gives them, or `image_size`): what `d` leaves out (fps, the
    window's N, the detection range) stays to be derived for the video it is used with (its
    `config` here: for `d`'s own fps and image size, the range from the fitted camera). Raises
    `BadInput` (the config or the data)."""
    from fit.camera import fit_camera
    from rhythmjax.io import BadInput, config_or_bad_input
    from rhythmjax.model.params import Config, config_to_dict
    from rhythmjax.model.view import camera_report

    d = copy.deepcopy(d)
    cam = d.setdefault("camera", {})
    cpath = config_path or "config"
    if not isinstance(cam, dict):
        raise BadInput(cpath, "expected an object", key="camera")
    notes, held = [], {}
    if image_size is not None:
        old = (cam.get("image_width_px"), cam.get("image_height_px"))
        if None not in old and tuple(old) != tuple(image_size):
            notes.append(f"--image-size {image_size[0]}x{image_size[1]} replaces the config's "
                         f"{old[0]}x{old[1]}")
        cam["image_width_px"], cam["image_height_px"] = int(image_size[0]), int(image_size[1])
    given = [k for k in ("uc_px", "vc_px") if k in cam]
    if len(given) == 1:
        raise BadInput(cpath, "give both uc_px and vc_px, or neither (then the principal "
                       "point is fitted)", key=f"camera.{given[0]}")
    size_known = "image_width_px" in cam and "image_height_px" in cam
    pp = ("fitted" if fit_center or not (given or image_center) else
          "config" if given else "image centre")
    if pp != "config" and not size_known:
        raise BadInput(config_path or path, "the principal point is not in "
                       "the config and the image size is unknown: give --image-size WxH (or "
                       "camera.image_width_px and image_height_px in the config)")
    if world and pp == "fitted":
        raise BadInput(path, ("--world and --fit-center together" if fit_center else
                              "the principal point is not in the config and with --world it")
                       + " cannot be determined from ground footprints (the world frame's "
                       "shift trades with it): give camera.uc_px and vc_px in the config, or "
                       "--image-center to hold it at the image centre")
    roll_fitted = fit_roll or "roll_deg" not in cam
    fit = (("af", "h", "theta", "uc", "vc") if pp == "fitted" else
           ("af", "h", "theta") if world else ("af", "bf", "h", "theta"))
    fit += ("roll",) if roll_fitted else ()
    thr = d.get("thresholds", {}) if isinstance(d.get("thresholds"), dict) else {}
    start = {**d, "thresholds": {**thr, "range_min_m": thr.get("range_min_m", 3.0),
                                 "range_max_m": thr.get("range_max_m", 20.0)}}
    cfg0 = config_or_bad_input(start, cpath)  # a fixed range: the start needs none
    notes.append({"fitted": "principal point not in the config: fitted",
                  "config": "principal point held at the config's",
                  "image centre": "principal point not in the config: held at the image "
                  "centre (--image-center)"}[pp] + (" (--fit-center)" if fit_center else ""))
    c0 = cfg0.camera
    if pp != "fitted":
        where = "the config's" if pp == "config" else "the image centre"
        held["uc"], held["vc"] = (f"at {where} {float(q):.1f} px" for q in (c0.uc, c0.vc))
    if pp == "fitted" or world:
        held["bf"] = (f"b/a at the config's {float(c0.b / c0.a):.4g}: "
                      "ground footprints fix only five combinations of a f, b f, h, theta, Uc, "
                      "Vc" + (" (and the world frame's shift trades with b f)" if world else ""))
    if roll_fitted:
        notes.append("roll not in the config: fitted" if "roll_deg" not in cam else
                     "roll fitted (--fit-roll)")
    else:
        held["roll"] = f"at the config's {math.degrees(float(c0.roll)):.2f} deg"
    try:
        r = fit_camera(u, v, x, y, cfg0.camera, fit=fit, loss=loss, max_steps=max_steps,
                       world=world)
    except ValueError as e:
        raise BadInput(path, str(e)) from None
    warnings = [w for w in (units_warning(x, y, r.values["h"]),) if w]
    out = written = None
    if r.success and not r.ill_determined:  # d with the fitted camera; the rest as given
        fitted = config_to_dict(Config(camera=r.camera))["camera"]
        facts = ("fps", "image_width_px", "image_height_px")
        d["camera"] = {**{k: q for k, q in fitted.items() if k not in facts},
                       **{k: cam[k] for k in facts if k in cam}}
        written = d
        if "range_min_m" in thr or "range_max_m" in thr:
            notes.append("the config gives thresholds.range_*_m, kept; delete them to derive "
                         "the detection range from the fitted camera")
        try:
            out = config_or_bad_input(d, cpath)
        except BadInput as e:
            if not (e.key or "").startswith("thresholds"):
                raise
            warnings.append(f"{e.message} (the config is written without a range)")
    report = camera_report(r.camera, float(cfg0.width.height))
    return CameraRun(r, out, written, report, pp, held, notes, warnings)
