"""`sim.groups`: a walker's partner at its shoulder or in file worked by hand, the view check,
and pairing a random scene (deterministic, walker counts kept, pairs side by side or one
behind the other in every frame)."""

from __future__ import annotations

import math

import pytest

from rhythmjax.model.params import Camera
from rhythmjax.sim.groups import (
    LATE_S,
    LAYOUTS,
    follower_of,
    in_view,
    late_of,
    partner_of,
    with_pairs,
)
from rhythmjax.sim.scene import ActorSpec, SceneSpec, random_spec


def test_partner_by_hand():
    lead = ActorSpec("pedestrian", x0=-1.0, y0=8.0, heading_rad=0.0, pace_hz=2.0,
                     step_length_m=0.7, start_frame=5, n_frames=60)
    other = ActorSpec("pedestrian", x0=3.0, y0=12.0, heading_rad=2.0, pace_hz=1.75,
                      step_length_m=0.8, start_frame=0, n_frames=90, height_m=1.6, bag=True)
    left = partner_of(lead, other, 0.6, 1.0)  # heading +x: its left is +y (farther)
    assert (left.x0, left.y0) == pytest.approx((-1.0, 8.6), abs=1e-12)
    assert (left.heading_rad, left.start_frame, left.n_frames) == (0.0, 5, 60)
    assert left.speed_mps == pytest.approx(1.4, abs=1e-12)  # the lead's 2.0 x 0.7
    assert left.pace_hz == 1.75 and left.step_length_m == pytest.approx(0.8)  # 1.4 / 1.75
    assert left.height_m == 1.6 and left.bag  # its own look kept
    walking_at_camera = ActorSpec("pedestrian", x0=0.0, y0=15.0, heading_rad=-math.pi / 2,
                                  pace_hz=2.0, step_length_m=0.7)
    right = partner_of(walking_at_camera, other, 0.7, -1.0)  # heading -y: its right is -x
    assert (right.x0, right.y0) == pytest.approx((-0.7, 15.0), abs=1e-12)


def test_in_view_follows_the_path():
    spec = SceneSpec(n_frames=30, camera=Camera())
    stays = ActorSpec("pedestrian", x0=0.0, y0=8.0, heading_rad=0.0, pace_hz=2.0,
                      step_length_m=0.5, n_frames=30)  # 1 m in 2 s at 8 m: in view
    assert in_view(spec, stays, (3.1, 19.9), 8.0)
    assert not in_view(spec, stays, (8.5, 19.9), 8.0)  # nearer than the range allows
    leaves = ActorSpec("pedestrian", x0=0.0, y0=8.0, heading_rad=0.0, pace_hz=2.0,
                       step_length_m=5.0, n_frames=30)  # 20 m sideways: out of the image
    assert not in_view(spec, leaves, (3.1, 19.9), 8.0)
    assert in_view(spec, ActorSpec("pedestrian", 50.0, 8.0, 0.0, 2.0, 0.7, start_frame=0,
                                   n_frames=0), (3.1, 19.9), 8.0)  # never alive: nothing out


def test_pairing_a_random_scene():
    spec = random_spec(31, n_walkers=6, n_bicycles=1, n_dogs=0, n_frames=120, occlusion=True,
                       min_life=60, max_life=90, range_m=(3.1, 19.9))
    assert with_pairs(spec, 31, 0.0) is spec
    a, b = with_pairs(spec, 31, 1.0), with_pairs(spec, 31, 1.0)
    assert a == b  # deterministic
    assert [x.kind for x in a.actors] == [x.kind for x in spec.actors]
    walkers = [x for x in a.actors if x.kind == "pedestrian"]
    groups: dict = {}
    for w in walkers:
        groups.setdefault((w.start_frame, w.n_frames, w.heading_rad), []).append(w)
    pairs = [g for g in groups.values() if len(g) == 2]
    assert len(pairs) >= 2  # fraction 1: every walker that can be is paired
    for p, q in pairs:
        assert p.speed_mps == pytest.approx(q.speed_mps, rel=1e-12)
        h = p.heading_rad  # the offset is across the heading, 0.55-0.8 m
        dx, dy = q.x0 - p.x0, q.y0 - p.y0
        assert abs(dx * math.cos(h) + dy * math.sin(h)) < 1e-9
        assert 0.55 <= math.hypot(dx, dy) <= 0.8
        assert in_view(a, q, (3.1, 19.9), 8.0)
    bikes = [x for x in a.actors if x.kind == "bicycle"]
    assert bikes == [x for x in spec.actors if x.kind == "bicycle"]  # others untouched
    with pytest.raises(ValueError, match="pair fraction"):
        with_pairs(spec, 31, 1.5)


def test_follower_by_hand():
    """In file: 1.5 m ahead of (side +1) or behind (-1) the lead along its heading; the lead's
    start, life, heading and speed, its own pace."""
    at_camera = ActorSpec("pedestrian", x0=0.5, y0=12.0, heading_rad=-math.pi / 2, pace_hz=2.0,
                          step_length_m=0.7, start_frame=3, n_frames=50)
    other = ActorSpec("pedestrian", x0=3.0, y0=5.0, heading_rad=1.0, pace_hz=1.75,
                      step_length_m=0.8)
    ahead = follower_of(at_camera, other, 1.5, 1.0)
    behind = follower_of(at_camera, other, 1.5, -1.0)
    assert (ahead.x0, ahead.y0) == pytest.approx((0.5, 10.5), abs=1e-12)  # nearer the camera
    assert (behind.x0, behind.y0) == pytest.approx((0.5, 13.5), abs=1e-12)
    assert (behind.heading_rad, behind.start_frame, behind.n_frames) == (-math.pi / 2, 3, 50)
    assert behind.speed_mps == pytest.approx(1.4, abs=1e-12) and behind.pace_hz == 1.75


def test_pairing_a_random_scene_in_file():
    spec = random_spec(31, n_walkers=6, n_bicycles=1, n_dogs=0, n_frames=120, occlusion=True,
                       min_life=60, max_life=90, range_m=(3.1, 19.9))
    a = with_pairs(spec, 31, 1.0, layout="file")
    assert a == with_pairs(spec, 31, 1.0, layout="file")
    assert with_pairs(spec, 31, 1.0) == with_pairs(spec, 31, 1.0, (0.55, 0.8))  # side: as before
    groups: dict = {}
    for w in (x for x in a.actors if x.kind == "pedestrian"):
        groups.setdefault((w.start_frame, w.n_frames, w.heading_rad), []).append(w)
    pairs = [g for g in groups.values() if len(g) == 2]
    assert len(pairs) >= 2
    for p, q in pairs:  # the offset lies along the heading, within the file range
        h = p.heading_rad
        dx, dy = q.x0 - p.x0, q.y0 - p.y0
        assert abs(-dx * math.sin(h) + dy * math.cos(h)) < 1e-9
        assert LAYOUTS["file"][0] <= math.hypot(dx, dy) <= LAYOUTS["file"][1]
        assert in_view(a, q, (3.1, 19.9), 8.0)
    with pytest.raises(ValueError, match="pair layout"):
        with_pairs(spec, 31, 0.5, layout="ring")


def test_late_follower_by_hand_and_in_a_scene():
    """The follower 1.5 m ahead of a lead walking at the camera (1.4 m/s), appearing 15 frames
    (1 s at 15 fps) later: 1.4 m farther along, at (0.5, 9.1), from frame 18 for 35 frames. In
    a paired random scene every late partner appears 15-30 frames after its lead."""
    lead = ActorSpec("pedestrian", x0=0.5, y0=12.0, heading_rad=-math.pi / 2, pace_hz=2.0,
                     step_length_m=0.7, start_frame=3, n_frames=50)
    other = ActorSpec("pedestrian", x0=3.0, y0=5.0, heading_rad=1.0, pace_hz=1.75,
                      step_length_m=0.8)
    late = late_of(lead, other, 1.5, 1.0, 15, 15.0)
    assert (late.x0, late.y0) == pytest.approx((0.5, 9.1), abs=1e-12)
    assert (late.start_frame, late.n_frames, late.heading_rad) == (18, 35, -math.pi / 2)
    spec = random_spec(31, n_walkers=6, n_bicycles=1, n_dogs=0, n_frames=120, occlusion=True,
                       min_life=60, max_life=90, range_m=(3.1, 19.9))
    a = with_pairs(spec, 31, 1.0, layout="late")
    walkers = [x for x in a.actors if x.kind == "pedestrian"]
    moved = [(p, q) for p, q in zip(walkers[::2], walkers[1::2]) if q.start_frame != p.start_frame]
    assert len(moved) >= 2
    for p, q in moved:
        assert LATE_S[0] * 15 <= q.start_frame - p.start_frame <= LATE_S[1] * 15
        assert q.start_frame + q.n_frames == p.start_frame + p.n_frames  # ends with its lead
        assert in_view(a, q, (3.1, 19.9), 8.0)
