"""`sim.groups`: a walker's partner at its shoulder worked by hand, the view check, and pairing
a random scene (deterministic, walker counts kept, pairs side by side in every frame)."""

from __future__ import annotations

import math

import pytest

from rhythmjax.model.params import Camera
from rhythmjax.sim.groups import in_view, partner_of, with_pairs
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
