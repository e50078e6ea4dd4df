"""No ghost tracks (issue 16 item 4): a person present in the first frame who walks away leaves
no track on the spot where they stood (`count.still`: the background from the first seconds'
median, pedestrians that never move ended and dropped); the background pieces against plain
NumPy references."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from rhythmjax.count import CountOptions, count_frames
from rhythmjax.count.still import is_still, never_moved, peek_background
from rhythmjax.sim.scene import SceneSpec, render_scene, walker
from rhythmjax.vision.blobs import BackgroundModel, median_background

from .test_pedestrians import CFG, QUIET


OLD = CountOptions(verdicts=QUIET,  # the background from frame 0, no still rule
                   blobs=dataclasses.replace(CountOptions().blobs, bg_init_s=0.0),
                   life=dataclasses.replace(CountOptions().life, still_s=0.0))
NEW = CountOptions(verdicts=QUIET,  # the first 3 s' median, the still rule
                   blobs=dataclasses.replace(CountOptions().blobs, bg_init_s=3.0))


@pytest.fixture(scope="module")
def walk_away():
    """A walker in view from frame 0 (x = -2.5 m, 7 m ahead, walking right at 1.48 m/s)."""
    a = walker(-2.5, 7.0, 0.0, start_frame=0, phase=0.2)
    return render_scene(3, SceneSpec(n_frames=90, actors=(a,), camera=CFG.camera)).frames


def _items(frames):
    return [(k, k / 15.0, f) for k, f in enumerate(frames)]


U0 = 65.0  # px: the walker's foot column in frame 0 (x = -2.5 m)


def _tracks(res):
    """Per track: (moved: its box centre spans > 40 px; ghost: its last box centre within 15
    px of where the walker stood in frame 0, after >= 1 s)."""
    mot, out = res.mot, {}
    for i in np.unique(mot["id"]):
        k = mot["id"] == i
        u = mot["bb_left"][k] + 0.5 * mot["bb_width"][k]
        out[int(i)] = (bool(np.ptp(u) > 40), bool(abs(u[-1] - U0) < 15 and k.sum() >= 15))
    return out


def test_a_walker_present_in_frame_0_leaves_no_ghost(walk_away):
    frames = list(walk_away[:75])
    old = _tracks(count_frames(CFG, iter(_items(frames)), options=OLD))
    assert sorted(old.values()) == [(False, True), (True, False)]  # frame 0 learnt: a ghost
    new = count_frames(CFG, iter(_items(frames)), options=NEW)
    assert list(_tracks(new).values()) == [(True, False)]  # the first 3 s' median: no ghost


def test_a_person_who_stood_through_the_first_seconds_leaves_no_ghost(walk_away):
    # stands still 3 s (in the median's background), then walks off: the spot they leave is a
    # ghost, which stays put: its still rows go, the rest is too short, the patch is absorbed
    frames = [walk_away[0]] * 45 + list(walk_away)
    old = _tracks(count_frames(CFG, iter(_items(frames)), options=OLD))
    assert sorted(old.values()) == [(False, True), (True, False)]
    new = count_frames(CFG, iter(_items(frames)), options=NEW)
    assert list(_tracks(new).values()) == [(True, False)]


def test_median_background_and_peek_against_numpy():
    rng = np.random.default_rng(0)
    g = [rng.integers(0, 256, (6, 7), dtype=np.uint8) for _ in range(5)]
    ref = np.sort(np.stack(g).astype(int), axis=0)[2]  # odd count: the middle value
    assert np.array_equal(median_background(g), ref)
    two = median_background(g[:2])  # even: the mean of the two, truncated
    assert np.array_equal(two, (g[0].astype(int) + g[1]) // 2)
    items = [(k, k / 10.0, g[k % 5]) for k in range(40)]  # 10 fps
    med, again = peek_background(iter(items), 0.45, 99)  # t < 0.45 s: frames 0-4
    assert np.array_equal(med, ref)
    assert [k for k, _, _ in again] == list(range(40))  # nothing lost
    med, _ = peek_background(iter(items), 3.0, 5)  # 30 frames, 5 evenly spaced: 0 7 14 22 29
    pick = [g[k % 5] for k in (0, 7, 14, 22, 29)]
    assert np.array_equal(med, np.sort(np.stack(pick).astype(int), axis=0)[2])
    assert peek_background(iter(items), 0.0, 5)[0] is None


def test_absorb_copies_the_frame_into_the_background():
    bg = BackgroundModel(np.zeros((10, 12), np.uint8))
    frame = np.full((10, 12), 90, np.uint8)
    bg.absorb(frame, (-3.2, 2.5, 4.1, 20.0))  # clipped: columns 0-4, rows 2-9
    ref = np.zeros((10, 12), np.float32)
    ref[2:10, 0:5] = 90
    assert np.array_equal(bg.background, ref)


def test_is_still_on_block_means():
    n = 75  # 5 s at 15 fps, 1 s blocks
    rng = np.random.default_rng(1)
    ghost = np.column_stack([100 + rng.normal(0, 0.7, n), 80 + rng.normal(0, 0.7, n)])
    assert is_still(ghost, (20.0, 60.0), 15, 0.15, 0.04)
    walk = ghost + np.column_stack([np.arange(n) * 0.2, np.zeros(n)])  # 14 px = 0.7 W
    assert not is_still(walk, (20.0, 60.0), 15, 0.15, 0.04)
    # a foot row creeping 0.06 H (3.6 px) over the window: moving (blocks 4 s apart differ
    # by 0.048 H > 0.04 H); half that creeps within the gate
    creep = ghost * 0 + np.column_stack([np.full(n, 100.0), 80 + np.arange(n) * 3.6 / n])
    assert not is_still(creep, (20.0, 60.0), 15, 0.15, 0.04)
    creep[:, 1] = 80 + np.arange(n) * 1.8 / n
    assert is_still(creep, (20.0, 60.0), 15, 0.15, 0.04)
    gaps = ghost.copy()
    gaps[1::2] = np.nan  # 38 of 75 rows measured (>= half): still judged; fewer: not
    assert is_still(gaps, (20.0, 60.0), 15, 0.15, 0.04)
    gaps[::4] = np.nan
    assert not is_still(gaps, (20.0, 60.0), 15, 0.15, 0.04)
    gaps = np.concatenate([ghost, np.full((40, 2), np.nan)])  # its measured rows only
    assert never_moved(gaps, (20.0, 60.0), 15, 0.15, 0.04)
    assert not never_moved(np.concatenate([walk, gaps]), (20.0, 60.0), 15, 0.15, 0.04)
    assert not is_still(ghost[:20], (20.0, 60.0), 15, 0.15, 0.04)  # under two blocks


def test_a_track_left_without_measured_rows_is_not_kept():
    # a still track whose every row was still: all its rows go, and nothing reaches stitching
    from rhythmjax.count.pedestrian_level import Pedestrian, PedestrianLevel

    level = PedestrianLevel(CFG, CountOptions(verdicts=QUIET))
    p = Pedestrian(slot=0, born=0, track_id=1)
    level._end(p, "still")
    assert level.finished == []


def test_the_default_drops_the_ghost_by_the_still_rule(walk_away):
    """The default keeps the paper's frame-0 background (the first seconds' median cost counts on
    the project's own seeds: 55 -> 65 of 58) and ends the ghost it leaves by the still rule: the
    spot where the walker stood in frame 0 never moves, so no ghost track is output."""
    assert CountOptions().blobs.bg_init_s == 0.0 and CountOptions().life.still_s > 0
    res = count_frames(CFG, iter(_items(list(walk_away))), options=CountOptions(verdicts=QUIET))
    tracks = _tracks(res)
    assert not any(ghost for _, ghost in tracks.values()), tracks
    assert any(moved for moved, _ in tracks.values())
    # the ends by reason (before stitching): the ghost's piece by the still rule, the walker's
    # when its patch leaves the image (frame 77 of 90); no piece runs to the clip's end
    ends = res.summary["ends"]
    assert ends["still"] == 1 and ends["left-image"] == 1 and ends["clip-end"] == 0, ends
    assert res.mot["frame"].max() < len(walk_away) - 1
