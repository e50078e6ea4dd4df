"""Rule 57 (`relink.side_rows`): a relink whose observed rows next to its gap move faster on
either side than any walk (14) accepts is undone at the track's end. The pieces by hand, the
least-squares speed against numpy.polyfit, and an own scene where a bicycle's lost track is
continued by a walker."""

import math

import numpy as np
import pytest

from rhythmjax.model.params import Config, walking_top_speed
from rhythmjax.model.status import TrackState
from rhythmjax.track import relink
from rhythmjax.track.options import RelinkOptions
from rhythmjax.track.rows import TrackRow


CFG = Config()
OBS, PRED, NONE = int(TrackState.OBSERVE), int(TrackState.PREDICT), int(TrackState.NONE)
FPS = 15.0


def _rows(speeds, states, x0=0.0, y0=10.0):
    """One row a frame at 15 Hz, walking along x at `speeds[k]` m/s from (x0, y0) m; NONE rows
    are unmeasured (u NaN), the others measured (u 100 px)."""
    out, x = [], x0
    for k, (v, s) in enumerate(zip(speeds, states)):
        x += v / FPS
        u = math.nan if s == NONE else 100.0
        out.append(TrackRow(k, k / FPS, u, 200.0, 30.0, 5.0, x, y0, s))
    return out


def test_relink_gaps_are_the_runs_of_none_rows_inside_a_track():
    states = [OBS] * 3 + [NONE] * 2 + [OBS] * 4 + [NONE] + [OBS] * 2
    assert relink.relink_gaps(_rows([1.0] * 12, states)) == [(3, 5), (9, 10)]
    assert relink.relink_gaps(_rows([1.0] * 4, [OBS, PRED, PRED, OBS])) == []
    assert relink.relink_gaps(_rows([1.0] * 4, [NONE, OBS, NONE, OBS])) == [(2, 3)]  # not row 0


def test_side_speed_is_the_least_squares_slope_of_the_ground_positions():
    """Against numpy.polyfit on noisy positions moving (1.3, -0.4) m/s: |(vx, vy)|."""
    rng = np.random.default_rng(57)
    t = np.sort(rng.uniform(0.0, 2.0, 16))
    x = 2.0 + 1.3 * t + rng.normal(0, 0.05, 16)
    y = 9.0 - 0.4 * t + rng.normal(0, 0.05, 16)
    rows = [TrackRow(k, tk, 1.0, 1.0, 1.0, 1.0, xk, yk, OBS)
            for k, (tk, xk, yk) in enumerate(zip(t, x, y))]
    want = math.hypot(np.polyfit(t, x, 1)[0], np.polyfit(t, y, 1)[0])
    assert relink.side_speed(rows) == pytest.approx(want, rel=1e-12)
    assert math.isnan(relink.side_speed(rows[:1]))
    assert math.isnan(relink.side_speed([rows[0], rows[0]._replace(frame=1)]))  # one time


def test_walking_top_speed_is_the_table_1_bound():
    """(14) with Table 1: the fastest pace and stride the walking model accepts, 2.57 m/s."""
    assert walking_top_speed(CFG) == pytest.approx(2.57, abs=0.01)


@pytest.mark.parametrize("before, after, fast", [
    (1.2, 1.4, False),  # a walker hidden and found again
    (3.2, 1.3, True),  # a bicycle's track continued by a walker
    (1.3, 3.0, True),  # a walker's track continued by a bicycle
    (2.5, 2.5, False),  # a brisk walk, just under (14)'s 2.57 m/s
])
def test_fast_gap_reads_both_sides(before, after, fast):
    states = [OBS] * 20 + [PRED] * 5 + [NONE] * 6 + [OBS] * 20
    speeds = [before] * 25 + [0.0] * 6 + [after] * 20
    assert relink.fast_gap(_rows(speeds, states), 16, 2.57) == ((25, 31) if fast else None)


def test_fast_gap_reads_only_the_m_rows_nearest_the_gap():
    """A bicycle for 40 rows, then 16 walking rows before the gap: with m 16 the walking rows are
    read; with m 40, 24 bicycle rows too (least squares 2.96 m/s)."""
    states = [OBS] * 56 + [NONE] * 4 + [OBS] * 16
    speeds = [4.0] * 40 + [1.2] * 16 + [0.0] * 4 + [1.2] * 16
    assert relink.fast_gap(_rows(speeds, states), 16, 2.57) is None
    assert relink.fast_gap(_rows(speeds, states), 24, 2.57) is None  # 1.85 m/s
    assert relink.fast_gap(_rows(speeds, states), 40, 2.57) == (56, 60)


def test_a_side_with_fewer_than_half_m_observed_rows_is_not_read():
    states = [OBS] * 7 + [NONE] * 3 + [OBS] * 20
    speeds = [4.0] * 7 + [0.0] * 3 + [1.2] * 20
    assert relink.fast_gap(_rows(speeds, states), 16, 2.57) is None
    assert relink.fast_gap(_rows(speeds, states), 14, 2.57) == (7, 10)


def test_cut_rows_drops_each_fast_gap_and_keeps_slow_ones():
    states = ([OBS] * 20 + [NONE] * 3 + [OBS] * 20 + [NONE] * 2 + [OBS] * 20 + [NONE] * 2
              + [OBS] * 20)
    speeds = [1.2] * 45 + [3.5] * 22 + [1.2] * 20  # walker, walker, bicycle, walker
    rows = _rows(speeds, states)
    assert relink.cut_rows(rows, 16, 2.57) == [slice(0, 43), slice(45, 65), slice(67, None)]
    assert relink.cut_rows(_rows([1.2] * 87, states), 16, 2.57) == [slice(0, None)]


class _Track:
    def __init__(self, track_id, rows):
        self.track_id, self.rows = track_id, rows


def test_undo_fast_relinks_replaces_the_track_by_its_pieces():
    """The first piece keeps the id, the later ones get new ones (track_id None); a track with
    no fast relink and side_rows 0 (off) leave `finished` as it was."""
    states = [OBS] * 30 + [NONE] * 4 + [OBS] * 30
    slow = _Track(3, _rows([1.2] * 64, states))
    fast = _Track(7, _rows([1.2] * 34 + [3.4] * 30, states))
    finished, judged = [slow, fast], []

    def judge(obj, rows, track_id):
        judged.append((obj.track_id, rows, track_id))
        finished.append(_Track(track_id or 99, obj.rows[rows]))

    assert relink.undo_fast_relinks(CFG, list(finished), 0.0, judge) == 0 and judged == []
    assert relink.undo_fast_relinks(CFG, finished, 0.25, judge) == 1
    assert judged == [(7, slice(0, 30), 7), (7, slice(34, None), None)]
    assert [t.track_id for t in finished] == [3, 7, 99]
    assert [len(t.rows) for t in finished] == [64, 30, 30]


def test_side_rows_must_be_a_fraction():
    with pytest.raises(ValueError, match="relink.side_rows"):
        RelinkOptions(side_rows=1.5)


@pytest.fixture(scope="module")
def bicycle_then_walker():
    """Own scene 9997001 (`benchmarks/eval_synthetic.scene_specs(9990001)`'s eighth; found by
    `benchmarks/study_switch_rows.py` on a fresh sample): the bicycle's track times out near a
    walker and the walker, appearing where the bicycle's motion put it, continues it."""
    from rhythmjax.model.params import config_from_dict
    from rhythmjax.sim.presets import SCENE_OPTIONS, SYNTHETIC_CONFIG
    from rhythmjax.sim.scene import random_spec, render_scene

    cfg = config_from_dict(SYNTHETIC_CONFIG)
    spec = random_spec(9997001, n_walkers=3, n_bicycles=1, n_dogs=0, n_frames=180,
                       camera=cfg.camera, articulated=True, **SCENE_OPTIONS)
    return cfg, render_scene(9997001, spec)


@pytest.mark.parametrize("side_rows", [0.0, 0.25])
def test_a_bicycle_continued_by_a_walker_is_cut_apart(bicycle_then_walker, side_rows):
    """Off (the default before rule 57): one track holds the bicycle's rows, a NONE gap, then
    the walker's, is judged Pedestrian on the walker's rows, and the scoring by track gives it
    to the bicycle. On: the relink is undone; the walker's piece (a new id) keeps the Pedestrian
    verdict and the bicycle is no longer judged Pedestrian."""
    from rhythmjax.sim.evaluate import score
    from rhythmjax.sim.presets import synthetic_options
    from rhythmjax.track.options import with_changes
    from rhythmjax.track.tracker import OnlineTracker

    cfg, scene = bicycle_then_walker
    tr = OnlineTracker(cfg, with_changes(synthetic_options(), {"relink.side_rows": side_rows}))
    for k, f in enumerate(scene.frames):
        tr.update(k, k / scene.fps, f)
    tracks, verdicts, objs = tr.finish()
    by_object = {r["object"]: r["verdict"] for r in score(tracks, verdicts, scene.truth)["objects"]}
    gapped = [o for o in objs if relink.relink_gaps(o.rows)]
    if side_rows == 0:
        assert tr.relinked >= 1 and tr.relinks_undone == 0
        assert by_object["bic003"] == "pedestrian"
        assert any(relink.fast_gap(o.rows, 16, walking_top_speed(cfg)) for o in gapped)
        return
    assert tr.relinks_undone == 1
    assert not any(relink.fast_gap(o.rows, 16, walking_top_speed(cfg)) for o in objs)
    assert by_object["bic003"] != "pedestrian" and by_object["ped001"] == "pedestrian"
    ids = [int(t) for t in verdicts["track_id"]]
    assert len(ids) == len(set(ids))
    key = np.stack([tracks["track_id"], tracks["frame"]], axis=1)
    assert len(np.unique(key, axis=0)) == len(key)  # one row per track and frame
