"""`life.merge_hold_s` (`count.coast`): a pedestrian keeping its prediction in a merge it entered
measured does not run the 1 s PREDICT time-out. The coast and hold by hand, the merge rule of
`PedestrianLevel._place` marking both pedestrians of a narrow shared blob, and the end by
time-out through the level's `_after` with and without the option."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rhythmjax.count import CountOptions
from rhythmjax.count.coast import advance_coast, timed_out
from rhythmjax.count.options import with_changes
from rhythmjax.count.pedestrian import Pedestrian
from rhythmjax.count.slot_filter import FILTER_OUT
from rhythmjax.model.camera_np import project_3d

from .test_pedestrians import CFG, FAST


DT = 1 / 15  # the test camera's frame time, s


@pytest.mark.parametrize("hold_s", [0.0, 0.5])
def test_coast_and_hold_by_hand(hold_s):
    p = Pedestrian(slot=0, born=0)
    # (measured, merged) per frame; the coast and hold after it, worked by hand
    frames = [(True, False), (False, True), (False, True), (False, False), (False, True),
              (True, False), (False, False), (False, True)]
    if hold_s:  # merged frames entered measured are held; after an unmerged one they coast
        want = [(0, 0), (0, 1), (0, 2), (1, 2), (2, 2), (0, 0), (1, 0), (2, 0)]
    else:  # every unmeasured frame coasts, merged or not (the paper's PREDICT time-out)
        want = [(0, 0), (1, 0), (2, 0), (3, 0), (4, 0), (0, 0), (1, 0), (2, 0)]
    for (measured, merged), (coast, held) in zip(frames, want):
        p.merged = merged
        advance_coast(p, measured, DT, hold_s)
        assert p.coast == pytest.approx(coast * DT, abs=1e-12)
        assert p.held == pytest.approx(held * DT, abs=1e-12)


def test_timed_out_by_hand():
    p = Pedestrian(slot=0, born=0)
    p.coast, p.held = 1.0, 2.5
    assert not timed_out(p, 1.0, 3.0) and timed_out(p, 0.9, 3.0)  # coast over 1 s: > not >=
    assert timed_out(p, 1.0, 2.4) and not timed_out(p, 1.0, 0.0)  # hold 0: off, never ends it


def test_the_options_default_and_bad_values():
    assert CountOptions().life.merge_hold_s == 0.0
    for bad in (-1.0, math.nan, math.inf):
        with pytest.raises(ValueError, match="life.merge_hold_s"):
            with_changes(CountOptions(), {"life.merge_hold_s": bad})


def test_a_narrow_shared_blob_marks_both_merged():
    """Two pedestrians predicted on one blob a single walker wide (< merge_widths x 2 W): both
    keep their predictions (no measurement) and are marked merged; alone, one is measured."""
    from rhythmjax.count.pedestrian_level import PedestrianLevel
    from rhythmjax.vision.blobs import Blob

    level = PedestrianLevel(CFG, FAST)
    w, h = (float(q) for q in level.shape.size(100.0, 100.0))
    lab = np.zeros((192, 256), np.int32)
    lab[round(101 - h):101, round(100 - w / 2):round(100 + w / 2)] = 1
    ys, xs = np.nonzero(lab)
    blob = Blob((int(xs.min()), int(ys.min()), int(xs.max()) + 1, int(ys.max()) + 1),
                int(ys.size), 0.0, (float(xs.mean()), float(ys.mean())), 0.5, 1)
    a, b = Pedestrian(slot=0, born=0), Pedestrian(slot=1, born=2)
    for q, u in ((a, 98.0), (b, 102.0)):
        q.hits, q.track_id, q.next_uv = 20, 1 + q.slot, (u, 100.0)
    level.peds = [a, b]
    level._place({id(a): {0}, id(b): {0}}, [blob], lab)
    assert a.merged and b.merged
    assert all(math.isnan(c) for c in a.z + b.z)
    a.merged, level.peds = False, [a]
    level._place({id(a): {0}}, [blob], lab)
    assert not a.merged and a.z == pytest.approx((100.0, 100.0), abs=1.0)


def unmeasured_step(slots, uv):
    """A filter step that took no measurement: the state on (uv) px, 8 m ahead."""
    out = FILTER_OUT.unpack(FILTER_OUT.empty(slots, np.float64))
    out.started[:], out.used[:] = 1.0, 0.0
    out.est_uv[0] = out.next_uv[0] = uv
    out.ground[0], out.velocity[0], out.image_velocity[0] = (0.0, 8.0), (0.0, 0.0), (0.0, 0.0)
    out.cov[0] = np.eye(4).ravel() * 0.01
    return out


@pytest.mark.parametrize("hold_s, arrives_coasting, lasts", [
    (0.0, False, 16),  # off: the paper's 1 s at 15 fps (ends after 16 unmeasured frames)
    (2.9, False, 44),  # held: ends once held over 2.9 s (44 frames, 2.93 s)
    (2.9, True, 16),  # arrived coasting: the 1 s coast as before
])
def test_a_pedestrian_held_in_a_merge_outlives_the_coast(hold_s, arrives_coasting, lasts):
    from rhythmjax.count.pedestrian_level import PedestrianLevel

    level = PedestrianLevel(CFG, with_changes(FAST, {"life.merge_hold_s": hold_s}))
    level.image_shape = (192, 256)
    p = level.new_pedestrian(0)
    p.track_id = p.hits = 1
    level.peds.append(p)
    uv = project_3d(CFG.camera, 0.0, 8.0, 0.0)
    assert level.coast_s == pytest.approx(1.0)
    for f in range(100):
        p.z, p.merged = (math.nan, math.nan), not (arrives_coasting and f == 0)
        level._after(p, unmeasured_step(level.filter.slots, uv), f, f * DT, DT, [], None)
        if p not in level.peds:
            break
    assert f + 1 == lasts and p.end_reason == "timeout"
