"""Clean frames and classifiable objects of a synthetic scene (`rhythmjax.sim.clean`), against a
reference built from the rendered frames themselves: each actor rendered alone in black on a flat
ground, its silhouette the pixels at least half dark."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from rhythmjax.sim.clean import (
    MIN_UNHIDDEN,
    RANGE_M,
    WINDOW_M,
    classifiable,
    clean_frames,
    hidden_fractions,
    longest_run,
)
from rhythmjax.sim.scene import SceneSpec, project_3d, render_scene, walker
from rhythmjax.vision.window_b import window_b_rect


BLACK = dict(grey_torso=0, grey_legs=0, grey_feet=0, grey_head=0)
GROUND = 120.0  # flat ground grey (ground_contrast 0, no noise)
# a far walker crossing to the right, a near one crossing to the left in front of it, and one
# walking away from 2.2 m (out of the range at first, then in it, and in front of both at times)
SPEC = SceneSpec(120, (walker(-3.0, 12.0, 0.0, **BLACK), walker(3.0, 6.0, math.pi, **BLACK),
                       walker(0.5, 2.2, math.pi / 2, **BLACK)),
                 noise_std=0.0, ground_contrast=0.0, ground_mean=GROUND)


@pytest.mark.parametrize("flags, run", [([], 0), ([0, 0], 0), ([1], 1), ([1, 1, 0, 1], 2),
                                        ([0, 1, 1, 1, 0, 1, 1], 3), ([1] * 5, 5)])
def test_longest_run(flags, run):
    assert longest_run(flags) == run


def _reference(scene):
    """(clean flags, hidden fractions) per object and frame from single-actor renders."""
    spec = scene.spec
    cam = spec.camera
    H, W = cam.image_height, cam.image_width
    alone = [render_scene(0, dataclasses.replace(spec, actors=(a,))).frames for a in spec.actors]
    n, T = len(spec.actors), spec.n_frames
    frac = np.full((n, T), np.nan)
    clean = np.zeros((n, T), bool)
    for i, obj in enumerate(scene.truth):
        for k in range(T):
            if not obj.alive[k]:
                continue
            u, v = project_3d(cam, obj.x[k], obj.y[k], 0.0)
            if not (0 <= u <= W - 1 and 0 <= v <= H - 1 and RANGE_M[0] <= obj.y[k] <= RANGE_M[1]):
                continue
            ul, _ = project_3d(cam, obj.x[k] - WINDOW_M / 2, obj.y[k], 0.0)
            ur, _ = project_3d(cam, obj.x[k] + WINDOW_M / 2, obj.y[k], 0.0)
            x0, y0, x1, y1 = window_b_rect((H, W), u, v, abs(ur - ul))
            hidden = np.zeros((y1 - y0, x1 - x0), bool)
            for j, other in enumerate(scene.truth):
                if j != i and other.alive[k] and other.body_y[k] < obj.body_y[k]:  # nearer
                    hidden |= alone[j][k, y0:y1, x0:x1] <= GROUND / 2  # >= half covered
            frac[i, k] = hidden.mean()
            clean[i, k] = 1.0 - frac[i, k] >= MIN_UNHIDDEN
    return clean, frac


def test_clean_frames_match_the_rendered_silhouettes():
    scene = render_scene(1, SPEC)
    got = clean_frames(scene)
    want, frac = _reference(scene)
    mine = hidden_fractions(scene)
    assert np.array_equal(np.isfinite(mine), np.isfinite(frac))
    # a pixel covered by half rounds either way (one grey level): at most 1 % of a window's
    # pixels (~3 px of a 40 x 8 px window at 12 m) may differ
    ok = np.isfinite(frac)
    assert np.max(np.abs(mine[ok] - frac[ok])) <= 0.01
    sure = ~(np.abs(frac - (1.0 - MIN_UNHIDDEN)) < 0.01)
    assert np.array_equal(got[sure], want[sure])
    far, near, away = got
    # the far walker is hidden while the others pass in front of it, clean before and after
    assert (~far & np.isfinite(frac[0])).sum() >= 5 and far.sum() >= 40
    # the walker walking away is out of the range (< 3 m) at first
    y = scene.truth[2].y
    assert not away[y < RANGE_M[0]].any() and away[(y > 3.5) & (y < 12)].all()


def test_classifiable_is_a_run_of_n_clean_frames():
    scene = render_scene(1, SPEC)
    flags = clean_frames(scene)
    runs = [longest_run(f) for f in flags]
    out = classifiable(scene, n=64)
    assert list(out) == [o.track_id for o in scene.truth]
    assert [r for r, _ in out.values()] == runs
    assert [ok for _, ok in out.values()] == [r >= 64 for r in runs]
    assert runs[2] >= 64 > runs[0]  # the walker walking away is; the one crossed twice is not
    # the window's size and the range are inputs: a window hidden nowhere makes the far walker
    # clean wherever its feet are in the image and the range
    loose = clean_frames(scene, min_unhidden=0.0)
    assert loose[0].sum() > flags[0].sum()
