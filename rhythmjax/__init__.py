"""rhythmjax: pedestrians told apart from other moving objects by the rhythm of walking.

Subpackages along the data flow, each importing only those below it:

- `rhythmjax.model`: pure JAX, no I/O: parameters, camera (3), EKF (4)-(9), gates (10) (11)
  (14), MEM spectrum, rhythm (12)-(15), batch classification of stored tracks.
- `rhythmjax.io`: tracks / footprints / verdicts / config / MOT files, atomic writes, errors.
- `rhythmjax.vision`: pixels (NumPy/OpenCV): video I/O, frame-difference detection, window B,
  background model, blobs, blob graph.
- `rhythmjax.track`: the rhythm paper's online tracker (Fig. 3 state machine per object).
- `rhythmjax.count`: the tracking paper's pedestrians level, stitching and counting.
- `rhythmjax.sim`: synthetic scenes and tracks with truth, scoring against it, presets.
- `rhythmjax.cli`: the command line, overlays and figures (nothing else imports it).

`rhythmjax.evaluation` (MOT scoring, the SORT baseline, real-data loaders) serves benchmarks,
tests and studies; the library never imports it.
"""

from importlib.metadata import PackageNotFoundError, version as _version

from .model.params import (
    Camera as Camera,
    Config as Config,
    ConfigError as ConfigError,
    Noise as Noise,
    Thresholds as Thresholds,
    WalkingModel as WalkingModel,
    WidthModel as WidthModel,
)
from .model.status import Reason as Reason, TrackState as TrackState, Verdict as Verdict


try:
    __version__ = _version("rhythmjax")
except PackageNotFoundError:  # running from a source tree
    __version__ = "0.0.0+unknown"
