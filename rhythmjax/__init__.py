"""rhythmjax: pedestrians told apart from other moving objects by the rhythm of walking.

The numeric core (camera, EKF, gates, MEM spectrum, rhythm matching) is pure JAX and imports no
OpenCV; video and detection live in `rhythmjax.video` and `rhythmjax.detect`.
"""

from importlib.metadata import PackageNotFoundError, version as _version

from .params import (
    Camera as Camera,
    Config as Config,
    ConfigError as ConfigError,
    Noise as Noise,
    Thresholds as Thresholds,
    WalkingModel as WalkingModel,
    WidthModel as WidthModel,
)
from .status import Reason as Reason, TrackState as TrackState, Verdict as Verdict


try:
    __version__ = _version("rhythmjax")
except PackageNotFoundError:  # running from a source tree
    __version__ = "0.0.0+unknown"
