"""Articulated walker legs (`rhythmjax.sim.legs`): a planted foot does not slide, the links keep
their lengths, the joint angles are those of textbook gait, and the option changes nothing but
the legs.

References are independent of the module's construction: world positions recomputed from the
drawn foot corners, link lengths from the joint positions, knee angles from the link directions.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from rhythmjax.sim import actors, legs
from rhythmjax.sim.scene import SceneSpec, random_spec, render_scene, walker


L, K = 0.72, 1.0
C = np.linspace(0.0, 2.0, 4001)  # two cycles, 0.0005 cycle apart


def _world_foot(c, offset=0.0):
    """(heel bottom, toe bottom) in the world's (s, z), m: the body moves 2 L per cycle."""
    heel, toe = [], []
    for ci in np.atleast_1d(c):
        a_s, a_z, phi = (float(x) for x in legs.ankle(ci, offset, L))
        pts = legs.foot_points(a_s, a_z, phi, 0.0)[:, [0, 2]]
        heel.append(pts[0] + (2 * L * ci, 0.0))  # FOOT_OUTLINE[0], first lateral corner
        toe.append(pts[6] + (2 * L * ci, 0.0))  # FOOT_OUTLINE[3]
    return np.array(heel), np.array(toe)


def _stance_q(c, offset=0.0):
    p = np.mod(c - offset, 1.0)
    return p, (p - legs.SWING) / (1.0 - legs.SWING)


@pytest.mark.parametrize("offset", [0.0, 0.5])
def test_planted_foot_does_not_slide(offset):
    _, q = _stance_q(C, offset)
    heel, toe = _world_foot(C, offset)
    stance = (C - offset >= legs.SWING) & (C - offset < 1.0)  # one stance
    first = stance & (q < legs.HEEL_ROLL)  # rolling about the heel
    last = stance & (q > 1 - legs.TOE_ROLL)  # about the toe
    flat = stance & (q >= legs.HEEL_ROLL) & (q <= 1 - legs.TOE_ROLL)
    for sel, pts in ((first, heel), (last, toe), (flat, heel), (flat, toe)):
        assert sel.sum() > 50
        assert np.ptp(pts[sel, 0]) < 1e-9  # m: the pivot stays where it landed
        np.testing.assert_allclose(pts[sel, 1], 0.0, atol=1e-9)  # on the ground


def test_foot_path_is_continuous_and_above_ground():
    a_s, a_z, phi = legs.ankle(C, 0.0, L)
    # one sample moves the ankle by at most its fastest speed times 0.0005 cycle (~2.5 cm
    # at 5 L / cycle); a jump at a phase boundary would be ~10 cm
    assert np.max(np.abs(np.diff(a_s))) < 0.005
    assert np.max(np.abs(np.diff(a_z))) < 0.002
    assert np.max(np.abs(np.diff(phi))) < math.radians(0.5)
    heel, toe = _world_foot(C[::4])
    assert min(heel[:, 1].min(), toe[:, 1].min()) > -1e-9


def test_swing_heights_are_textbook():
    p = np.mod(C, 1.0)
    a_s, a_z, phi = legs.ankle(C, 0.0, L)
    _, toe = _world_foot(C)
    mid = (p > 0.5 * legs.SWING) & (p < 0.75 * legs.SWING)
    assert 0.01 < toe[mid, 1].min() < 0.04  # toe clearance at mid-swing, m
    assert 0.15 < a_z[p < legs.SWING].max() < 0.25  # the swing ankle's highest, m
    np.testing.assert_allclose(math.degrees(phi[np.argmin(np.abs(p - legs.SWING))]), 15.0,
                               atol=0.5)  # heel strike, toe up


def _joints(c, L=L, k=K):
    return [legs.leg_joints(float(ci), 0.0, L, k) for ci in np.atleast_1d(c)]


@pytest.mark.parametrize("step", [0.55, 0.72])
def test_links_keep_their_length(step):
    half = legs.segment_length(K)
    for hip, knee, ank, _ in _joints(C[::20], step):
        d = math.dist(hip, ank)
        if d <= 2 * half:
            assert math.dist(hip, knee) == pytest.approx(half, abs=1e-9)
            assert math.dist(knee, ank) == pytest.approx(half, abs=1e-9)
            assert knee[0] >= 0.5 * (hip[0] + ank[0]) - 1e-9  # bends forwards


def _flexion(c):
    out = []
    for hip, knee, ank, _ in _joints(c):
        thigh = math.atan2(knee[0] - hip[0], hip[1] - knee[1])
        shank = math.atan2(ank[0] - knee[0], knee[1] - ank[1])
        out.append(math.degrees(thigh - shank))
    return np.array(out)


def test_knee_angles_are_textbook():
    """Sagittal knee flexion of normal walking (step 0.72 m, 1.7 m tall): near straight at heel
    strike and mid-stance, 35-60 deg around toe-off, 45-70 deg at its swing peak."""
    c = np.linspace(0.0, 1.0, 1001)
    f = _flexion(c)
    p = np.mod(c, 1.0)
    at = lambda x: f[int(round(x * 1000))]  # noqa: E731
    assert abs(at(legs.SWING)) < 8.0
    assert abs(at(0.65)) < 8.0
    assert 35.0 < at(0.999) < 60.0
    assert 45.0 < f[p < legs.SWING].max() < 70.0


def test_hip_is_lowest_at_heel_strike():
    c = np.linspace(0.0, 1.0, 1001)
    z = legs.hip_height(c, L, K)
    low, high = legs.hip_range(L, K)
    assert z.min() == pytest.approx(low, abs=1e-6) and z.max() == pytest.approx(high, abs=1e-6)
    assert abs(c[np.argmin(z)] - legs.SWING) < 1e-3 or abs(c[np.argmin(z)] - 0.9) < 1e-3
    assert 0.02 < high - low < 0.12  # m, the pelvis' rise and fall


def test_truth_foot_point_is_the_ankles_midpoint():
    a = walker(0.0, 8.0, 0.0, step_length_m=L, articulated=True).attrs()
    t = np.linspace(0.0, 2.0, 31)
    c = a["pace_hz"] * t / 2.0 + a["phase"]
    want = 0.5 * (legs.ankle(c, 0.0, L)[0] + legs.ankle(c, 0.5, L)[0])
    np.testing.assert_allclose(actors.contact_offset("pedestrian", t, a), want, atol=1e-12)


def test_option_changes_only_the_legs():
    rod = random_spec(1770001, n_walkers=3, n_bicycles=1, n_dogs=1, n_frames=60)
    knees = random_spec(1770001, n_walkers=3, n_bicycles=1, n_dogs=1, n_frames=60,
                        articulated=True)
    for a, b in zip(rod.actors, knees.actors):
        assert dataclasses.replace(b, articulated=False) == a
        assert b.articulated == (b.kind == "pedestrian")
    one = SceneSpec(n_frames=12, actors=(walker(-1.0, 12.0, 0.0),))
    two = SceneSpec(n_frames=12, actors=(walker(-1.0, 12.0, 0.0, articulated=True),))
    s1, s2 = render_scene(3, one), render_scene(3, two)
    changed = np.abs(s1.frames.astype(int) - s2.frames.astype(int)) > 20
    body = np.abs(s1.frames.astype(int) - s1.background.astype(int)) > 20
    assert changed.any()
    for k in range(12):
        rows = np.flatnonzero(body[k].any(axis=1))
        top, bottom = rows.min(), rows.max()
        # the head (the walker's top 0.23 of 1.7 m) is drawn the same
        assert not changed[k, : top + int(0.12 * (bottom - top))].any()
