"""The grouped, frozen options of the tracker and of counting: every default of the flat classes
they replace kept at its new place (the table below is the old classes' source, by hand), the
removed knobs gone, `with_changes`, and the synthetic preset."""

import dataclasses
import math

import pytest

from rhythmjax.count.options import CountOptions, StitchOptions, VerdictOptions
from rhythmjax.sim.presets import SYNTHETIC_OPTIONS, synthetic_options
from rhythmjax.track.options import BodyOptions, TrackerOptions, with_changes


# (old flat name, new dotted place, the old default)
TRACKER_DEFAULTS = [
    ("diff_threshold", "motion.diff_threshold", 15.0),
    ("global_change_fraction", "motion.global_change_fraction", 0.5),
    ("(new: issue 16 item 2)", "motion.stabilise", True),
    ("(new: issue 16 item 2)", "motion.stabilise_min_shift_px", 0.3),
    ("(new: issue 16 item 2)", "motion.stabilise_screen_px", 0.2),
    ("window_widths", "window.widths", 2.5),
    ("window_heights", "window.heights", 1.45),
    ("window_raise", "window.raise_heights", 0.42),
    ("core_widths", "body.core_widths", 1.2),
    ("core_heights", "body.core_heights", 1.1),
    ("body_widths", "body.parts_widths", 1.8),
    ("fraction", "body.slice_fraction", 0.1),
    ("(new: issue 16, rule 32b)", "body.column_fraction", None),  # the body core's column, off
    ("(new: issue 16, rule 33)", "body.column_rows", 0.5),  # the upper body's column (rule 54)
    ("(new: issue 16, rule 54)", "body.column_filter_only", True),  # the filter's only
    # (False: rule 33, window B and the box moved too)
    ("(new: issue 16, rule 54b)", "body.column_everywhere", False),  # only wider detections
    ("shared_overlap", "body.shared_overlap", 0.5),
    ("(new: issue 16, missed walkers)", "body.split_shared", True),
    ("(new: issue 16, missed walkers)", "body.split_near_widths", 0.3),
    ("(new: issue 16, missed walkers)", "body.split_depth_widths", 0.5),
    ("(new: issue 16, missed walkers)", "body.split_depth_margin_widths", 0.1),
    ("sample_estimate", "body.sample_estimate", False),
    ("high_foot_widths", "body.high_foot_widths", 0.0),
    ("(new: issue 16, rule 16)", "body.side_anchor", False),  # a side-cut detection, off
    ("(new: issue 16, rule 41)", "body.lean_column", False),  # window B under the body, off
    ("(new: issue 16, rule 48)", "body.mass_column", False),  # window B at the motion's mass
    ("(new: issue 16, rule 48b)", "body.mass_crossing", 0.0),  # ... only across the view
    ("(new: issue 16, rule 50b)", "body.across_candidates", True),  # window B moved across
    ("high_foot_frames", "body.high_foot_frames", 3),
    ("(new: issue 16 item 2)", "body.window_candidates", True),
    ("(new: issue 16, rule 34)", "body.pace_window_widths", 0.0),
    ("(new: issue 16, rule 35)", "body.window_per_pixel", False),  # I(k) per pixel of B
    ("(new: issue 16, rule 35b)", "body.window_mean_refused", True),  # per pixel, refused
    ("(new: issue 16, rule 44)", "recheck.halves_around", False),  # halves around the verdict
    ("(new: issue 16, rule 35c)", "body.mean_refused_gate", True),  # rule 35b's gate
    ("min_area", "new.min_area", 40),
    ("outside_margin_px", "new.outside_margin_px", 8),
    ("near_widths", "new.near_widths", 1.0),
    ("downscale", "new.downscale", 4),
    ("merge_widths", "merge.widths", 0.5),
    ("merge_frames", "merge.frames", 2),
    ("merge_speed_mps", "merge.speed_mps", 0.6),
    ("merge_young", "settled_frames", 10),
    ("relink_s", "relink.within_s", 3.0),
    ("relink_gate_w", "relink.gate_w", 1.0),
    ("relink_gate_h", "relink.gate_h", 0.25),
    ("relink_gate_per_s", "relink.gate_per_s", 0.5),
    ("(new: issue 16, rule 57)", "relink.side_rows", 0.25),  # a fast relink undone
    ("max_objects", "max_objects", 8),
    ("(new: issue 16, rule 26)", "size.min_height_heights", 0.5),  # a too-low Pedestrian
    ("(new: issue 16, rule 26)", "size.min_height_rows", 10),
    ("(new: issue 16, rule 26c)", "size.min_height_scope", "window"),
    ("(new: issue 16, rule 45)", "size.every_window", True),  # rule 26 on every window
    ("(new: issue 16, rule 36)", "size.top_inside_heights", 0.1),  # a top seen inside the image
    ("(new: issue 16, rule 37)", "size.twice_pace_heights", 0.57),  # a walker at twice its pace
    ("(new: issue 16, rule 37b)", "size.twice_pace_edge", True),  # ... heads above the view
    ("(new: issue 16, rule 49)", "size.twice_pace_sub", 0.0),  # rule 37 needs f1/2's peak, off
    ("(new: issue 16, rule 53)", "size.twice_pace_quantile", 0.5),  # rule 37 reads the median
    ("(new: issue 16, rule 56)", "size.stride_peak", True),  # a window read at twice f1
    ("(new: issue 16, rule 29)", "recheck.enabled", True),  # later windows re-judged
    ("(new: issue 16, rule 30a)", "recheck.tail", True),  # the last N rows re-judged
    ("(new: issue 16, rule 30d)", "recheck.earlier", "speed-low"),  # windows before the verdict
    ("(new: issue 16, rule 42)", "recheck.halves", False),  # a window's halves read, off
    ("(new: issue 16, rule 43)", "recheck.low", False),  # rule 26 in the rechecked windows, off
    ("(new: issue 16, rule 46)", "recheck.pace_tall", True),  # rule 29's pace test vs tall
    ("(new: issue 16, rule 47)", "recheck.median_pace", False),  # the windows' median pace, off
    ("(new: issue 16, rule 55)", "recheck.strongest_pace", True),  # strongest window's pace
    ("(new: issue 16, rule 52)", "recheck.fast_stretch", 0.0),  # a fast stretch after, off
]
TRACKER_REMOVED = ["max_dv_mps", "dv_window_s"]

COUNT_DEFAULTS = [
    ("dynamics", "dynamics", "3d"),
    ("max_pedestrians", "max_pedestrians", 32),
    ("bg_alpha", "blobs.bg_alpha", 0.05),
    ("bg_threshold", "blobs.bg_threshold", 20.0),
    ("open_px", "blobs.open_px", 1),
    ("close_px", "blobs.close_px", 2),
    ("min_blob_area", "blobs.min_area", 30),
    ("crowd_fraction", "blobs.crowd_fraction", 0.5),
    ("search_widths", "placement.search_widths", 0.75),
    ("shared_search_widths", "placement.shared_search_widths", 0.3),
    ("merge_widths", "placement.merge_widths", 0.75),
    ("min_cover", "placement.min_cover", 0.08),
    ("walker_widths", "new.walker_widths", 1.8),
    ("new_min_widths", "new.min_widths", 0.6),
    ("new_min_fill", "new.min_fill", 0.15),
    ("new_min_height", "new.min_height", 0.5),
    ("new_max_lift", "new.max_lift", 0.25),
    ("new_lifted_height", "new.lifted_height", 0.55),
    ("new_in_range", "new.in_range", True),
    ("confirm_hits", "life.confirm_hits", 3),
    ("tentative_misses", "life.tentative_misses", 2),
    ("duplicate_widths", "life.duplicate_widths", 0.6),
    ("duplicate_frames", "life.duplicate_frames", 3),
    ("max_dv_mps", "life.max_dv_mps", 1.5),
    ("dv_window_s", "life.dv_window_s", 0.5),
    ("stitch", "stitch.enabled", True),
    ("stitch_max_gap_s", "stitch.max_gap_s", 5.0),
    ("stitch_gate_w", "stitch.gate_w", 0.9),
    ("stitch_gate_h", "stitch.gate_h", 0.45),
    ("stitch_gate_per_s", "stitch.gate_per_s", 0.5),
    ("stitch_max_dv_w", "stitch.max_dv_w", 2.0),
    ("stitch_fit_s", "stitch.fit_s", 1.0),
    ("(new: issue 16 item 4)", "stitch.reid", False),
    ("(new: issue 16 item 4)", "stitch.reid_max_dv_w", 2.0),
    ("(new: issue 16 counting)", "stitch.max_dv_mps", math.inf),  # ground-velocity gate, off
    ("min_track_frames", "verdicts.min_track_frames", 10),
    ("online_verdicts", "verdicts.online", True),
    ("classify", "verdicts.classify", True),
    # new in issue 16 (no old flat name): the first seconds' median background (off) and the
    # still rule (`count.still`)
    (None, "blobs.bg_init_s", 0.0),
    (None, "blobs.bg_init_frames", 31),
    # the noise-adaptive foreground threshold (`vision.fg_threshold`), off (docs/rules.md)
    ("(new: issue 16 counting)", "blobs.noise_k", 0.0),
    ("(new: issue 16 counting)", "blobs.noise_floor", 6.0),
    ("(new: issue 16 counting)", "blobs.hysteresis", 0.0),
    ("(new: issue 16 counting)", "blobs.hysteresis_px", 2),
    (None, "life.still_s", 5.0),
    (None, "life.still_widths", 0.15),
    (None, "life.still_heights", 0.04),
    (None, "verdicts.speed_fit", "theil-sen"),  # issue 16, rule 25: Theil-Sen since round 28
    ("(new: issue 16 item 2)", "verdicts.window_candidates", False),  # candidate windows B
    ("(new: issue 16, rule 31)", "verdicts.head_speed", True),  # the speed under the heads
    ("(new: issue 16, rule 37)", "verdicts.twice_pace_heights", 0.57),  # twice the pace
    ("(new: issue 16, rule 37)", "verdicts.twice_pace_edge", True),  # ... heads above the view
    ("(new: issue 16, rule 26)", "verdicts.min_height_heights", 0.5),  # the size rule in count
    ("(new: issue 16, rule 56)", "verdicts.stride_peak", False),  # rule 56 in count, off
    # the foot-point gates of `count.foot_gate` (options a and b), off
    (None, "placement.in_range", False),
    (None, "placement.gate_heights", 0.0),
    (None, "placement.lift_heights", 0.0),
    (None, "placement.lift_keep_u", False),
    ("(new: issue 16 counting)", "placement.outlier_gate", "none"),  # (11) / innovation, off
    ("(new: issue 16 counting)", "placement.depth_order", False),  # nearest placed first, off
    ("(new: issue 16 counting)", "placement.wide_widths", 0.0),  # wide blobs placed as shared, off
    ("(new: issue 16 counting)", "life.max_dv_w", 0.0),  # the velocity jump in W/s, off
    ("(new: issue 16 counting)", "life.jump_sigma", 0.0),  # the jump over the filter's noise, off
    ("(new: issue 16 counting)", "placement.noise", ()),  # the counting filter's own noise, off
    ("(new: issue 16 counting)", "life.jump_rewind", False),  # go on from before a jump, off
    ("(new: issue 16 counting)", "life.rewind_across", False),  # then measured across only, off
    ("(new: issue 16 counting)", "life.rewind_off_rows", False),  # only the off rows go, off
    ("(new: issue 16 counting)", "life.rewind_predict", False),  # then predicts while off, off
    ("(new: issue 16 counting)", "life.merge_hold_s", 0.0),  # a merge holds the time-out, off
    ("(new: issue 16 counting)", "placement.shared_row_gate", False),  # shared off rows refused
    ("(new: issue 16 counting)", "placement.shared_row_unsampled", False),  # ... and no I(k)
    ("(new: issue 16 counting)", "placement.window_column", "measured"),  # window B column
    # unjudged tracks explained by a counted one, and joins by appearance: both off (docs/rules.md)
    ("(new: issue 16 counting)", "explain.enabled", False),
    ("(new: issue 16 counting)", "explain.duplicate_widths", 1.0),
    ("(new: issue 16 counting)", "explain.duplicate_fraction", 0.5),
    ("(new: issue 16 counting)", "explain.continue_widths", 2.0),
    ("(new: issue 16 counting)", "explain.speed_mps", 0.5),
    ("(new: issue 16 counting)", "explain.max_gap_s", 5.0),
    ("(new: issue 16 counting)", "explain.precedes", True),
    ("(new: issue 16 counting)", "appearance.enabled", False),
    ("(new: issue 16 counting)", "appearance.bins", 8),
    ("(new: issue 16 counting)", "appearance.min_fill", 0.1),
    ("(new: issue 16 counting)", "appearance.max_gap_s", 10.0),
    ("(new: issue 16 counting)", "appearance.reach_widths", 2.0),
    ("(new: issue 16 counting)", "appearance.reach_speed_mps", 2.0),
    ("(new: issue 16 counting)", "appearance.max_distance", 0.387),
    ("(new: issue 16 counting)", "appearance.veto_distance", math.inf),
    ("(new: issue 16 counting)", "new.head_feet", 0.0),
    ("(new: issue 16 counting)", "new.head_feet_out_of_range", False),
    ("(new: issue 16 counting)", "new.cover_to_feet", True),  # on since the 26th round
    ("(new: issue 16 counting)", "new.join_gap_widths", 0.0),  # a walker's legs joined, off
    ("(new: issue 16 counting)", "new.fill_exposed", False),  # fill of the part below, off
]
COUNT_REMOVED = ["height_m", "coast_s"]  # the config's width.height_m, thresholds.predict_timeout_s


def _get(options, dotted: str):
    for name in dotted.split("."):
        options = getattr(options, name)
    return options


def _leaves(options, prefix=""):
    """Every dotted leaf field of a grouped options record."""
    out = []
    for f in dataclasses.fields(options):
        value = getattr(options, f.name)
        if dataclasses.is_dataclass(value):
            out += _leaves(value, f"{prefix}{f.name}.")
        else:
            out.append(prefix + f.name)
    return out


@pytest.mark.parametrize("options, table, removed", [
    (TrackerOptions(), TRACKER_DEFAULTS, TRACKER_REMOVED),
    (CountOptions(), COUNT_DEFAULTS, COUNT_REMOVED),
])
def test_every_old_default_kept_at_its_new_place(options, table, removed):
    assert sorted(_leaves(options)) == sorted(new for _, new, _ in table)
    for old, new, value in table:
        got = _get(options, new)
        assert got == value and type(got) is type(value), (old, new, got)
    for name in removed:
        assert name not in _leaves(options) and not hasattr(options, name)


@pytest.mark.parametrize("options", [TrackerOptions(), CountOptions()])
def test_options_and_their_groups_are_frozen(options):
    with pytest.raises(dataclasses.FrozenInstanceError):
        options.max_objects = 3  # type: ignore[misc]
    group = next(getattr(options, f.name) for f in dataclasses.fields(options)
                 if dataclasses.is_dataclass(getattr(options, f.name)))
    with pytest.raises(dataclasses.FrozenInstanceError):
        setattr(group, dataclasses.fields(group)[0].name, 0)
    assert hash(options) == hash(type(options)())  # usable as a cache key; equal by value


def test_with_changes_nested_dotted_and_top_level():
    base = TrackerOptions()
    a = with_changes(base, {"max_objects": 24, "body": {"high_foot_widths": 0.25}})
    b = with_changes(base, {"body.high_foot_widths": 0.25, "max_objects": 24})
    c = dataclasses.replace(base, max_objects=24,
                            body=dataclasses.replace(base.body, high_foot_widths=0.25))
    assert a == b == c and a.body.high_foot_frames == 3 and base.body.high_foot_widths == 0.0
    assert a.relink is base.relink  # untouched groups are shared, not copied
    whole = with_changes(base, {"body": BodyOptions(sample_estimate=False)})
    assert whole.body == BodyOptions(sample_estimate=False)
    cnt = with_changes(CountOptions(), {"stitch.enabled": False, "verdicts.classify": False})
    assert cnt == CountOptions(stitch=StitchOptions(enabled=False),
                               verdicts=VerdictOptions(classify=False))


@pytest.mark.parametrize("changes, match", [
    ({"high_foot_widths": 0.25}, "TrackerOptions has no field 'high_foot_widths'"),
    ({"body.high_foot": 0.25}, "BodyOptions has no field 'high_foot'"),
    ({"max_dv_mps": 1.8}, "no field 'max_dv_mps'"),
])
def test_with_changes_names_an_unknown_field(changes, match):
    with pytest.raises(KeyError, match=match):
        with_changes(TrackerOptions(), changes)


def test_count_dynamics_checked():
    with pytest.raises(ValueError, match="dynamics must be one of"):
        CountOptions(dynamics="4d")
    with pytest.raises(ValueError, match="dynamics must be one of"):
        with_changes(CountOptions(), {"dynamics": "4d"})


def test_synthetic_preset_changes_only_the_high_foot_rule():
    opt = synthetic_options()
    assert SYNTHETIC_OPTIONS == {"body": {"high_foot_widths": 0.25}}
    assert opt.body.high_foot_widths == 0.25
    assert dataclasses.replace(opt, body=dataclasses.replace(
        opt.body, high_foot_widths=0.0)) == TrackerOptions()
