"""The rhythm paper's online tracker: per object the Fig. 3 state machine around the model's EKF
and gates, window B and the rhythm windows (`tracker`), re-acquisition (`relink`), options and
output tables."""

from .columns import TRACK_COLUMNS as TRACK_COLUMNS
from .driver import track_frames as track_frames
from .options import TrackerOptions as TrackerOptions
from .tracker import OnlineTracker as OnlineTracker
