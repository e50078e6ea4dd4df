"""`life.jump_rewind`: at a velocity jump a pedestrian goes on from its filter state at the last
kept row instead of ending (`count.rewind`, `slot_filter.Restore`). The restored filter against
the float64 EKF loop of tests/helpers.py (the skipped frames replaced by one prediction of the
lead); `rewind` and `rows_to_drop` on a hand-made pedestrian; the options through the level's
`_after` and `_place`."""

from __future__ import annotations

import math
from collections import deque

import numpy as np
import pytest

from rhythmjax.count import CountOptions
from rhythmjax.count.options import with_changes
from rhythmjax.count.rewind import keep_state, rewind, rewind_requests, rows_to_drop, state_store
from rhythmjax.count.slot_filter import FILTER_OUT, Restore, SlotFilter
from rhythmjax.model.camera_np import project_3d
from rhythmjax.model.status import TrackState
from rhythmjax.track.rows import TrackRow

from .helpers import cam_ref_of, ekf_reference
from .test_pedestrians import CFG, FAST


DT = 1 / 15


def _walk(x0, y0, vx, vy, T, rng):
    """Foot points (T, 2) px of a walker at (x0 + vx t, y0 + vy t) m, 1.5 px noise."""
    t = np.arange(T) * DT
    uv = np.array([project_3d(CFG.camera, x0 + vx * s, y0 + vy * s, 0.0) for s in t])
    return (uv + rng.normal(0, 1.5, uv.shape)).astype(np.float32)


def test_a_restored_slot_is_the_ekf_that_skipped_the_bad_frames():
    rng = np.random.default_rng(5)
    T, j, i = 40, 19, 25  # rows 0..j kept, j+1..i another object's, restored before i+1
    z0 = _walk(-2.0, 9.0, 1.3, 0.1, T, rng)
    z1 = _walk(1.0, 7.0, -1.0, 0.3, T, rng)
    bad = z0.copy()
    bad[j + 1:i + 1, 1] += 25.0  # the foot row on a nearer object: a depth jump
    sf = SlotFilter(CFG, "3d", slots=3)
    outs = []
    for k in range(T):
        z = np.full((3, 2), np.nan, np.float32)
        z[0], z[2] = bad[k], z1[k]
        back = None
        if k == i + 1:
            back = Restore.none(3)
            back.slots[0] = True
            back.state[0] = np.concatenate([outs[j].mean[0], outs[j].cov[0]])
            back.lead[0] = (i - j) * DT
        outs.append(sf.step(np.array([k == 0, False, k == 0]), z,
                            np.array([True, False, True]), DT, restore=back))
    nz = CFG.noise
    cam, q, R, s0 = (cam_ref_of(CFG.camera), np.asarray(nz.q_std(), np.float64),
                     np.asarray(nz.R(), np.float64), float(nz.init_speed_std()))
    # slot 0: frames 0..j, one absent step of the lead (i - j) dt, then i+1..T-1
    zr = np.concatenate([z0[:j + 1], np.full((1, 2), np.nan), z0[i + 1:]]).astype(np.float64)
    dts = np.full(len(zr), DT)
    dts[j + 1] = (i - j) * DT
    pres = np.isfinite(zr[:, 0])
    ref = ekf_reference(cam, q, R, s0, zr, dt=dts, present=pres)
    got_mean = np.array([o.mean[0] for o in outs[i + 1:]])
    got_cov = np.array([o.cov[0].reshape(4, 4) for o in outs[i + 1:]])
    want_mean, want_cov = ref["mean"][j + 2:], ref["cov"][j + 2:]
    # float32 against float64: 1e-3 m and 1e-3 m/s; covariances 1e-3 of their diagonal scale
    assert np.max(np.abs(got_mean - want_mean)) < 1e-3
    scale = np.max(np.abs(np.diagonal(want_cov, axis1=1, axis2=2)), axis=1)[:, None, None]
    assert np.max(np.abs(got_cov - want_cov) / scale) < 1e-3
    # the jumped frames did move it: without the restore it is elsewhere
    assert np.max(np.abs(outs[i].mean[0] - ref["mean"][j + 1])) > 0.1
    # slot 2 (never restored) is its own plain EKF all along
    ref2 = ekf_reference(cam, q, R, s0, z1.astype(np.float64), dt=np.full(T, DT))
    assert np.max(np.abs(np.array([o.mean[2] for o in outs]) - ref2["mean"])) < 1e-3


def _row(k, state=TrackState.OBSERVE):
    return TrackRow(k, k * DT, 10.0, 20.0, 5.0, 1.0, 0.0, 8.0, int(state), math.nan, math.nan)


def _pedestrian(n, k, observed_until=None, off=()):
    """Rows 0..n-1 (measured through `observed_until`), the states of the last 2k + 1 kept;
    the rows in `off` flagged with their foot row off the prediction."""
    from rhythmjax.count.pedestrian import Pedestrian

    p = Pedestrian(slot=2, born=0, track_id=4, states=state_store(k))
    for r in range(n):
        measured = observed_until is None or r <= observed_until
        p.rows.append(_row(r, TrackState.OBSERVE if measured else TrackState.PREDICT))
        state = np.concatenate([[0.1 * r, 1.2, 8.0, -0.1], np.eye(4).ravel() * (1 + r)])
        p.states.append((r * DT, state, r in off))
    return p


def test_rewind_by_hand():
    k = 3
    p = _pedestrian(12, k)  # states kept: the last 2k + 1 = 7 rows (5..11)
    assert len(p.states) == 7
    p.rows = p.rows[:-k]  # the level drops the k rows first
    t = 11 * DT
    assert rewind(p, k, t, CFG.camera, DT)
    state, lead = p.restore
    assert lead == pytest.approx(3 * DT)  # from row 8 to the jump frame 11
    np.testing.assert_allclose(state[:4], [0.8, 1.2, 8.0, -0.1])
    np.testing.assert_allclose(state[4:], np.eye(4).ravel() * 9)
    x, y = 0.8 + 1.2 * lead, 8.0 - 0.1 * lead  # moved at its velocity, projected by (3)
    np.testing.assert_allclose(p.est_uv, project_3d(CFG.camera, x, y, 0.0), rtol=1e-12)
    x, y = 0.8 + 1.2 * (lead + DT), 8.0 - 0.1 * (lead + DT)
    np.testing.assert_allclose(p.next_uv, project_3d(CFG.camera, x, y, 0.0), rtol=1e-12)
    assert p.coast == pytest.approx(3 * DT)  # row 8 was measured
    assert len(p.states) == 4 and math.isnan(p.z[0])
    # its slot's request, once
    r = rewind_requests([p], 5)
    assert r.slots.tolist() == [False, False, True, False, False]
    np.testing.assert_array_equal(r.state[2], state)
    assert r.lead[2] == pytest.approx(lead) and p.restore is None
    assert rewind_requests([p], 5) is None


def test_rewind_refuses_without_state_or_measured_row():
    k = 3
    young = _pedestrian(3, k)  # 3 states: fewer than k + 1 -> it ends
    assert not rewind(young, k, 3 * DT, CFG.camera, DT) and young.restore is None
    off = _pedestrian(12, k)
    off.states = None  # option off
    assert not rewind(off, k, 11 * DT, CFG.camera, DT)
    coasting = _pedestrian(12, k, observed_until=-1)  # no measured row
    coasting.rows = coasting.rows[:-k]
    assert not rewind(coasting, k, 11 * DT, CFG.camera, DT) and coasting.restore is None
    # its coast counts from the last measured kept row: 2 predicted rows after row 6
    late = _pedestrian(12, k, observed_until=6)
    late.rows = late.rows[:-k]
    assert rewind(late, k, 11 * DT, CFG.camera, DT)
    assert late.coast == pytest.approx(5 * DT)


def test_rows_to_drop_by_hand():
    k = 4
    p = _pedestrian(12, k, off=(9, 10))  # rows 8..11 are the last k; 9 the first off
    assert rows_to_drop(p, k, only_off=False) == (k, True)  # option off: all k rows
    assert rows_to_drop(p, k, only_off=True) == (3, True)  # rows 9, 10, 11 (11 not off itself)
    assert rows_to_drop(_pedestrian(12, k, off=(11,)), k, True) == (1, True)
    assert rows_to_drop(_pedestrian(12, k, off=(8, 11)), k, True) == (4, True)
    assert rows_to_drop(_pedestrian(12, k, off=(7,)), k, True) == (k, False)  # before the k
    assert rows_to_drop(_pedestrian(12, k), k, True) == (k, False)  # none off: it ends
    assert rows_to_drop(p, 0, True) == (0, True)  # no jump
    young = _pedestrian(3, k, off=(0,))  # no state before the off row: it ends
    assert rows_to_drop(young, k, True) == (k, False)
    assert rows_to_drop(_pedestrian(3, k, off=(1,)), k, True) == (2, True)


def _out(slots, x, vx, y, vy, uv, uv_next):
    out = FILTER_OUT.unpack(FILTER_OUT.empty(slots, np.float64))
    out.started[:], out.used[:] = 1.0, 1.0
    out.est_uv[0], out.next_uv[0] = uv, uv_next
    out.ground[0], out.velocity[0], out.image_velocity[0] = (x, y), (vx, vy), (0.0, 0.0)
    out.cov[0] = np.eye(4).ravel() * 0.01
    return out


@pytest.mark.parametrize("on", [False, True])
def test_the_option_through_the_level(on):
    from rhythmjax.count.pedestrian_level import PedestrianLevel

    level = PedestrianLevel(CFG, with_changes(FAST, {"life.jump_rewind": on,
                                                     "life.rewind_across": on}))
    level.image_shape = (192, 256)
    p = level.new_pedestrian(0)
    assert (p.states is not None) == on
    p.track_id = 1
    level.peds.append(p)
    k = level._dv_frames
    n = 2 * k + 4
    for f in range(n + 1):
        t = f * DT
        vx = 1.3 if f < n else 3.3  # the last row's velocity jumped by 2 m/s
        x, y = -1.0 + 1.3 * t, 8.0
        uv = project_3d(CFG.camera, x, y, 0.0)
        p.z = uv
        level._after(p, _out(level.filter.slots, x, vx, y, 0.0, uv, uv), f, t, DT, [], None)
    if not on:
        assert p not in level.peds and p.end_reason == "velocity-jump"
        assert len(level.finished[0].rows) == n + 1 - k and level.rewinds == 0
        return
    assert p in level.peds and p.end_reason == "" and level.rewinds == 1 and p.rewound
    assert len(p.rows) == n + 1 - k and len(p.ground) == n + 1 - k
    state, lead = p.restore
    assert lead == pytest.approx(k * DT)  # back to row n - k, the last kept
    np.testing.assert_allclose(state[:4], [-1.0 + 1.3 * (n - k) * DT, 1.3, 8.0, 0.0], atol=1e-12)
    want = project_3d(CFG.camera, -1.0 + 1.3 * n * DT, 8.0, 0.0)  # on its old line at t
    np.testing.assert_allclose(p.est_uv, want, rtol=1e-9)
    r = rewind_requests(level.peds, level.filter.slots)
    assert r.slots[0] and not r.slots[1:].any()


def test_keep_state_only_with_the_option():
    from rhythmjax.count.pedestrian import Pedestrian

    out = _out(4, 1.0, 1.2, 8.0, 0.0, (10.0, 20.0), (11.0, 20.0))
    p = Pedestrian(slot=0, born=0)
    keep_state(p, out, 0.5)
    assert p.states is None
    p.states = deque(maxlen=3)
    for f in range(5):
        keep_state(p, out, f * DT)
    assert len(p.states) == 3 and p.states[-1][0] == pytest.approx(4 * DT)
    np.testing.assert_array_equal(p.states[-1][1][:4], [1.0, 1.2, 8.0, 0.0])
    assert p.states[-1][2] is False
    keep_state(p, out, 5 * DT, True)
    assert p.states[-1][2] is True


def test_the_options_are_off_by_default():
    assert CountOptions().life.jump_rewind is False
    assert CountOptions().life.rewind_across is False
    assert CountOptions().life.rewind_off_rows is False
    assert CountOptions().life.rewind_predict is False


@pytest.mark.parametrize("bad", [0, 2])
def test_only_the_off_rows_go(bad):
    """`life.rewind_off_rows`: the last `bad` rows placed 3 tolerances below the prediction,
    the velocity jumping at the last row: only those rows go and the slot goes back to the row
    before them; with no row off the track ends at the jump as without the option."""
    from rhythmjax.count.pedestrian_level import PedestrianLevel

    level = PedestrianLevel(CFG, with_changes(FAST, {"life.jump_rewind": True,
                                                     "life.rewind_off_rows": True}))
    level.image_shape = (192, 256)
    p = level.new_pedestrian(0)
    p.track_id = 1
    level.peds.append(p)
    k, tol = level._dv_frames, level.row_tolerance
    n = 2 * k + 4
    for f in range(n + 1):
        t = f * DT
        x, y = -1.0 + 1.3 * t, 8.0
        uv = project_3d(CFG.camera, x, y, 0.0)
        p.next_uv = (uv[0], uv[1])  # its prediction for this frame
        p.z = (uv[0], uv[1] + (3 * tol if f > n - bad else 0.0))
        vx = 1.3 if f < n else 3.3  # the last row's velocity jumped by 2 m/s
        level._after(p, _out(level.filter.slots, x, vx, y, 0.0, uv, uv), f, t, DT, [], None)
    if bad == 0:
        assert p not in level.peds and p.end_reason == "velocity-jump"
        assert len(level.finished[0].rows) == n + 1 - k and level.rewinds == 0
        return
    assert p in level.peds and level.rewinds == 1 and not p.rewound  # rewind_predict off
    assert len(p.rows) == n + 1 - bad and len(p.ground) == n + 1 - bad
    assert len(p.states) == 2 * k + 1 - bad and not any(q[2] for q in p.states)  # off ones gone
    state, lead = p.restore
    assert lead == pytest.approx(bad * DT)
    np.testing.assert_allclose(state[0], -1.0 + 1.3 * (n - bad) * DT, atol=1e-12)


def test_a_crossing_counted_with_rewinds():
    """Three walkers, two crossing 7-8 m ahead: without the option the crossing ends tracks at
    velocity jumps; with it those tracks go on (rewinds counted in the summary) and every
    track's rows stay in frame order."""
    from rhythmjax.count import count_frames
    from rhythmjax.sim.scene import SceneSpec, render_scene, walker

    from .test_pedestrians import QUIET

    actors = (walker(-3.0, 8.0, 0.0, start_frame=2, phase=0.2),
              walker(3.0, 7.0, np.pi, start_frame=2, phase=0.6),
              walker(-2.5, 6.0, 0.0, start_frame=10, phase=0.1))
    frames = render_scene(4, SceneSpec(n_frames=80, actors=actors, camera=CFG.camera)).frames
    items = [(k, k / 15.0, f) for k, f in enumerate(frames)]
    got = {on: count_frames(CFG, iter(items), options=with_changes(
        CountOptions(verdicts=QUIET), {"life.jump_rewind": on})) for on in (False, True)}
    assert got[False].summary["ends"]["velocity-jump"] >= 1 and got[False].summary["rewinds"] == 0
    assert got[True].summary["rewinds"] >= 1 and got[True].summary["ends"]["velocity-jump"] == 0
    tr = got[True].tracks
    for tid in np.unique(tr["track_id"]):
        frames_of = np.asarray(tr["frame"])[np.asarray(tr["track_id"]) == tid]
        assert np.all(np.diff(frames_of) > 0)


@pytest.mark.parametrize("across", [False, True])
def test_a_rewound_walker_is_measured_across_only_until_its_row_agrees(across):
    """The merged blob of tests/test_count_occlusion.py (a wider object in front, its bottom
    10.5 px below the predicted row, over the 6 px tolerance): a rewound walker with
    `life.rewind_across` keeps its predicted row and stays rewound; alone on its own blob (feet
    1.5 px off) it is measured fully and no longer rewound. Without the option: measured."""
    from rhythmjax.count.options import VerdictOptions
    from rhythmjax.count.pedestrian_level import PedestrianLevel

    from .test_count_occlusion import CFG as SMALL_CFG, alone_on

    opt = with_changes(CountOptions(verdicts=VerdictOptions(classify=False, online=False)),
                       {"life.jump_rewind": True, "life.rewind_across": across})
    level = PedestrianLevel(SMALL_CFG, opt)
    p, _ = alone_on(level, lambda wf: [(60, 85, 160, 113)], rewound=across)
    if across:
        assert p.z[1] == 101.5 and p.rewound and level.gated == {"rewound": 1}
    else:
        assert p.z[1] == 112.0 and not p.rewound and level.gated == {}
    p, _ = alone_on(level, lambda wf: [], rewound=across)
    assert p.z[1] == 100.0 and not p.rewound


def test_a_rewound_walker_predicts_while_its_row_is_off():
    """`life.rewind_predict`: on the merged blob above (its bottom 10.5 px below the predicted
    row) the rewound walker takes no measurement and stays rewound; alone on its own blob it is
    measured and no longer rewound."""
    from rhythmjax.count.options import VerdictOptions
    from rhythmjax.count.pedestrian_level import PedestrianLevel

    from .test_count_occlusion import CFG as SMALL_CFG, alone_on

    opt = with_changes(CountOptions(verdicts=VerdictOptions(classify=False, online=False)),
                       {"life.jump_rewind": True, "life.rewind_predict": True})
    level = PedestrianLevel(SMALL_CFG, opt)
    p, _ = alone_on(level, lambda wf: [(60, 85, 160, 113)], rewound=True)
    assert math.isnan(p.z[0]) and math.isnan(p.z[1]) and p.rewound
    assert level.gated == {"rewound": 1}
    p, _ = alone_on(level, lambda wf: [], rewound=True)
    assert p.z[1] == 100.0 and not p.rewound
