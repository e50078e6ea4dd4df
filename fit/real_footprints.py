"""Camera of (3) fitted to real footprints (issue 5): ETH seq_eth / seq_hotel and PETS 2009.

Pairs (image point px, world point m):
- ETH: world positions of obsmat with their clicked pixels from H^-1 (SOURCE.md);
- PETS "trajnet": box bottom centres against TrajNet ground positions, matched per frame to the
  nearest box whose Tsai back-projection lies within `gate_m` (Tsai is used only to match);
- PETS "tsai": every box bottom centre with its Tsai back-projection (distortion included).

Each set is fitted in its own world frame (``world=True``: a planar rigid transform to the ground
frame of (3) is fitted with the camera), the principal point held at the image centre (or the
Tsai one) and b/a held at 1 (PETS: Tsai's), without and with roll; the reference is
``cv2.findHomography`` (least squares, method 0) on the same pairs.

``python -m fit.real_footprints`` prints the table of the README.
"""

from __future__ import annotations

import math
import sys

import cv2
import numpy as np

from fit.camera import CameraFit, fit_camera
from rhythmjax.evaluation import datasets as D
from rhythmjax.model.params import Camera


def eth_pairs(name: str):
    """(u, v, X, Y, camera0) for an ETH sequence: camera0 has the image size, Uc, Vc at the
    image centre and a = b."""
    s = D.eth_sequence(name)
    u, v = s.image_points()
    w, h = s.image_size
    return u, v, s.obs["x"], s.obs["y"], Camera(uc=w / 2, vc=h / 2, image_width=w,
                                                   image_height=h, fps=s.fps)


def pets_pairs(kind: str = "trajnet", *, gate_m: float = 1.0, tsai_centre: bool = False):
    """(u, v, X, Y, camera0) for PETS (`kind` "trajnet" or "tsai", see the module doc). camera0:
    480x360, b/a of Tsai, principal point at the image centre or (`tsai_centre`) Tsai's."""
    t, b = D.pets_tsai(), D.pets_boxes()
    gx, gy = t.ground_of_image(b["foot_u"], b["foot_v"])
    if kind == "tsai":
        u, v, X, Y = b["foot_u"], b["foot_v"], gx, gy
    elif kind == "trajnet":
        w = D.pets_world()
        rows = []
        for i in range(w["frame"].size):
            m = np.flatnonzero(b["frame"] == w["frame"][i])
            if m.size:
                d = np.hypot(gx[m] - w["x"][i], gy[m] - w["y"][i])
                if d.min() < gate_m:
                    j = m[np.argmin(d)]
                    rows.append((b["foot_u"][j], b["foot_v"][j], w["x"][i], w["y"][i]))
        u, v, X, Y = np.asarray(rows).T
    else:
        raise ValueError(f"kind must be 'trajnet' or 'tsai', not {kind!r}")
    fu, fv = t.focal_px()
    uc, vc = (t.cx * D.PETS_SCALE, t.cy * D.PETS_SCALE) if tsai_centre else (240.0, 180.0)
    cam0 = Camera(f=0.008, a=1e5, b=1e5 * fv / fu, uc=uc, vc=vc, image_width=480,
                  image_height=360, fps=D.PETS_FPS)
    return u, v, X, Y, cam0


def homography_rms(u, v, X, Y) -> float:
    """RMS (px, u and v together) of ``cv2.findHomography`` (method 0: least squares)."""
    src = np.stack([X, Y], 1).astype(np.float64)
    M, _ = cv2.findHomography(src, np.stack([u, v], 1).astype(np.float64), 0)
    p = np.concatenate([src, np.ones((len(X), 1))], 1) @ M.T
    r = np.concatenate([p[:, 0] / p[:, 2] - u, p[:, 1] / p[:, 2] - v])
    return float(np.sqrt(np.mean(r**2)))


def fit_pairs(u, v, X, Y, camera0: Camera, *, roll: bool, loss: str = "l2") -> CameraFit:
    """The camera of (3) (plus roll if `roll`) and the world-to-ground transform, b/a held."""
    fit = ("af", "h", "theta") + (("roll",) if roll else ())
    return fit_camera(u, v, X, Y, camera0, fit=fit, world=True, loss=loss, max_steps=400)


def evaluate(sets=None) -> list[dict]:
    """One row per (data set, roll): n, h, theta, roll, RMS, homography RMS, verdict."""
    sets = sets if sets is not None else all_sets()
    rows = []
    for name, (u, v, X, Y, cam0) in sets.items():
        ref = homography_rms(u, v, X, Y)
        for roll in (False, True):
            r = fit_pairs(u, v, X, Y, cam0, roll=roll)
            rows.append({"set": name, "roll_fitted": roll, "n": int(u.size),
                         "h_m": r.values["h"], "se_h_m": r.se["h"],
                         "theta_deg": r.values["theta"], "se_theta_deg": r.se["theta"],
                         "roll_deg": r.values["roll"], "af_px": r.values["af"],
                         "rms_px": r.rms_px, "homography_rms_px": ref, "cond": r.cond,
                         "ill_determined": r.ill_determined, "reasons": r.reasons})
    return rows


def all_sets() -> dict:
    """Every pair set whose data is present."""
    out = {}
    if D.eth_root() is not None:
        for name in D.ETH_SEQUENCES:
            out[name] = eth_pairs(name)
    if D.pets_root() is not None:
        out["PETS trajnet"] = pets_pairs("trajnet")
        out["PETS trajnet, Tsai centre"] = pets_pairs("trajnet", tsai_centre=True)
        out["PETS tsai"] = pets_pairs("tsai", tsai_centre=True)
    return out


def table(rows: list[dict]) -> str:
    """Markdown table of `evaluate`'s rows."""
    head = ("| pairs | n | roll | h (m) | theta (deg) | roll (deg) | a f (px) | RMS (px) | "
            "homography RMS (px) | verdict |\n|---|---|---|---|---|---|---|---|---|---|")
    lines = [head]
    for r in rows:
        verdict = "ill-determined: " + "; ".join(r["reasons"]) if r["ill_determined"] else "ok"
        lines.append(
            f"| {r['set']} | {r['n']} | {'fitted' if r['roll_fitted'] else '0 (paper)'} | "
            f"{r['h_m']:.3f} +- {r['se_h_m']:.3f} | {r['theta_deg']:.2f} +- "
            f"{r['se_theta_deg']:.2f} | {r['roll_deg']:.2f} | {r['af_px']:.0f} | "
            f"{r['rms_px']:.2f} | {r['homography_rms_px']:.2f} | {verdict} |")
    return "\n".join(lines)


if __name__ == "__main__":  # pragma: no cover
    sets = all_sets()
    if not sets:
        print(f"no real data under {D.DATA_ROOT}", file=sys.stderr)
        sys.exit(1)
    t = D.pets_tsai() if D.pets_root() is not None else None
    if t is not None:
        print(f"Tsai (PETS): h {t.h_m:.3f} m, theta {math.degrees(t.theta_rad):.2f} deg, roll "
              f"{math.degrees(t.roll_rad):.2f} deg, a f {t.focal_px()[0]:.1f} px")
    print(table(evaluate(sets)))
