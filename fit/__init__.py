"""fit: estimation of rhythmjax's parameters with optimistix (camera, noise, walking model).

Depends on `rhythmjax`; `rhythmjax` never imports `fit`.
"""

from fit.camera import (
    CameraFit as CameraFit,
    CameraParams as CameraParams,
    fit_camera as fit_camera,
    reprojection_rms as reprojection_rms,
)
from fit.noise import NoiseFit as NoiseFit, fit_noise as fit_noise, simulate as simulate
from fit.walking import WalkingFit as WalkingFit, fit_walking as fit_walking


__all__ = ["CameraFit", "CameraParams", "NoiseFit", "WalkingFit", "fit_camera", "fit_noise",
           "fit_walking", "reprojection_rms", "simulate"]
