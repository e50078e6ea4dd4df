"""Checks on the geometry of a self-calibration fit (`fit.selfcal`) that refuse it.

- Same depth: the walkers' median foot rows (10-90 %) span less than a fraction of the image
  height (`fit.selfcal_data.row_spread`): nothing foreshortens, so neither strides nor heights
  fix the horizon.
- Pinned horizon: the fit keeps every used foot point at least `HORIZON_MARGIN_PX` below the
  horizon by a hinge (`fit.selfcal.raw_cues`), a constraint, not a cue. When a used foot point
  lies within `PINNED_CLEARANCE_PX` of the fitted horizon the hinge is active: the camera is
  where that one foot point (often a spurious one, above the true horizon) stops it, not where
  the cues put it, and the Gauss-Newton standard errors, which treat the hinge as a smooth
  residual, do not describe its error. A fit whose horizon clears every foot point by more
  ends where the hinge exerts no force (a spurious point can still steer the grid of starts,
  whose costs include the hinge, to another minimum: docs/selfcal.md).
"""

from __future__ import annotations

import numpy as np

from fit.selfcal_data import row_spread
from rhythmjax.model.camera import horizon_v
from rhythmjax.model.params import Camera


HORIZON_MARGIN_PX = 2.0  # the hinge's margin (px) below the horizon (`fit.selfcal`)
PINNED_CLEARANCE_PX = 2 * HORIZON_MARGIN_PX  # twice the margin, set a priori (module doc);
# the default's fits clear their foot points by at least 84 px on the development seeds 0-5


def horizon_clearance(camera: Camera, batch, used: np.ndarray) -> tuple[float, int]:
    """(px, index into the used tracks) of the used tracks' measured foot point nearest to the
    camera's horizon line (roll included): its row minus the horizon's row at its column,
    negative above the horizon; (inf, -1) without a measured foot point."""
    z = np.asarray(batch.z, np.float64)[used]
    ok = np.asarray(batch.present)[used] & np.all(np.isfinite(z), -1)
    if not ok.any():
        return float("inf"), -1
    horizon = float(horizon_v(camera)) + np.tan(float(camera.roll)) * (z[..., 0]
                                                                       - float(camera.uc))
    clear = np.where(ok, z[..., 1] - horizon, np.inf)
    k = int(np.argmin(np.min(clear, 1)))
    return float(np.min(clear[k])), k


def geometry_reasons(camera: Camera, batch, used: np.ndarray, min_row_spread: float,
                     ids=None) -> list[str]:
    """The refusal reasons of the checks (module doc) for a fitted `camera` and the used
    tracks (`used` mask over the batch; `ids` their ids, for the message)."""
    out = []
    if (spread := row_spread(batch, used, camera.image_height)) < min_row_spread:
        out.append(f"every walker stands at about the same depth (foot rows within "
                   f"{100 * spread:.1f} % of the image height): nothing foreshortens")
    clear, k = horizon_clearance(camera, batch, used)
    if clear < PINNED_CLEARANCE_PX:
        who = f" (track {ids[k]})" if ids is not None and k >= 0 else ""
        out.append(f"the fitted horizon is pinned by a foot point {clear:.1f} px below it{who}: "
                   "the camera is where the horizon constraint stops it, not where the cues "
                   "put it, and its standard errors do not hold")
    return out
