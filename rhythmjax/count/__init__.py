"""Multi-pedestrian tracking and counting (Masoud & Papanikolopoulos): the pedestrians level
(`pedestrian_level`, patches sized by the camera in `patches`), stitching of fragments
(`stitch`) and the counting rule (`counting`)."""

from .counting import (
    COUNT_RULE as COUNT_RULE,
    CountResult as CountResult,
    count_frames as count_frames,
    count_walkers as count_walkers,
    counted as counted,
    points_speed as points_speed,
    track_speed as track_speed,
    walker_ids as walker_ids,
    walking_top_speed as walking_top_speed,
)
from .options import CountOptions as CountOptions
from .pedestrian_level import Pedestrian as Pedestrian, PedestrianLevel as PedestrianLevel
from .stitch import Piece as Piece, stitch_pieces as stitch_pieces
