"""The pedestrians level (rhythmjax.count.patches, count.slot_filter, count.PedestrianLevel):
patch size, dynamics against independent filters, placement, and two constructed scenes
(crossing, group split)."""

from __future__ import annotations

import math

import equinox as eqx
import jax.numpy as jnp
import numpy as np
import pytest

from rhythmjax.count import CountOptions, count_frames
from rhythmjax.count.options import NewPedestrianOptions, VerdictOptions
from rhythmjax.count.patches import ShapeModel, middle_foot_point, patch_size_3d, place_patch
from rhythmjax.count.pedestrian_level import END_REASONS
from rhythmjax.count.slot_filter import SlotFilter, image_noise
from rhythmjax.model import ekf
from rhythmjax.model.params import config_from_dict
from rhythmjax.sim.scene import SceneSpec, project_3d, render_scene, walker
from rhythmjax.track.rows import TrackRow


# a small camera: 256x192, 3 m high, 25 deg down, a f = b f = 200 px/m; people 3-15 m away
SMALL = {"camera": {"f_m": 0.008, "h_m": 3.0, "theta_deg": 25.0, "a_px_per_m": 25000.0,
                    "b_px_per_m": 25000.0, "uc_px": 128.0, "vc_px": 96.0, "fps": 15.0,
                    "image_width_px": 256, "image_height_px": 192},
         "thresholds": {"range_min_m": 3.0, "range_max_m": 15.0},
         "noise": {"r_std_px": [3.0, 3.0]}, "width": {"std_m": 0.2}}
CFG = config_from_dict(SMALL)
QUIET = VerdictOptions(classify=False, online=False)  # no judging, no compile
FAST = CountOptions(verdicts=QUIET)


def _ground_ref(camera, u: float, v: float) -> tuple[float, float]:
    """Inverse of (3) by bisection on y (float64, the camera's stored float32 values), then x:
    independent of the closed form."""
    f, h, th, a, b, uc, vc = (float(np.asarray(getattr(camera, k)))
                              for k in ("f", "h", "theta", "a", "b", "uc", "vc"))
    bf, af = b * f, a * f
    vrow = lambda y: vc - bf * (y * math.sin(th) - h * math.cos(th)) / (
        f + y * math.cos(th) + h * math.sin(th))
    lo, hi = 0.0, 1e4  # v decreases with y
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if vrow(mid) > v else (lo, mid)
    y = 0.5 * (lo + hi)
    return (u - uc) * (f + y * math.cos(th) + h * math.sin(th)) / af, y


@pytest.mark.parametrize("uv", [(40.0, 150.0), (128.0, 96.0), (200.0, 60.0), (10.0, 185.0)])
def test_patch_size_is_the_projection_of_the_average_pedestrian(uv):
    x, y = _ground_ref(CFG.camera, *uv)
    W, Hm = 0.5, 1.7
    ul, _ = project_3d(CFG.camera, x - W / 2, y, 0.0)
    ur, vf = project_3d(CFG.camera, x + W / 2, y, 0.0)
    _, vt = project_3d(CFG.camera, x, y, Hm)
    assert abs(vf - uv[1]) < 1e-8  # the reference found the foot point's ground point
    w, h, ok = patch_size_3d(CFG.camera, *uv, W, Hm)
    assert ok
    np.testing.assert_allclose([w, h], [ur - ul, vf - vt], rtol=1e-9)
    shape = ShapeModel.from_config(CFG, "3d")
    np.testing.assert_allclose(shape.size(*uv), [ur - ul, vf - vt], rtol=1e-9)


def test_2d_shape_is_the_size_at_the_middle_of_the_scene():
    shape2 = ShapeModel.from_config(CFG, "2d")
    u, v = middle_foot_point(CFG)
    _, y = _ground_ref(CFG.camera, u, v)
    assert abs(y - 9.0) < 1e-5  # (range_min + range_max) / 2
    want = patch_size_3d(CFG.camera, u, v, 0.5, 1.7)[:2]
    np.testing.assert_allclose(shape2.size(10.0, 180.0), want, rtol=1e-12)
    np.testing.assert_allclose(shape2.size(200.0, 50.0), want, rtol=1e-12)


def test_above_the_horizon_has_no_patch():
    w, h, ok = patch_size_3d(CFG.camera, 100.0, -300.0, 0.5, 1.7)
    assert not ok and math.isnan(w) and math.isnan(h)


def _measurements(T=40, seed=0):
    rng = np.random.default_rng(seed)
    k = np.arange(T)
    z = np.stack([60.0 + 2.5 * k, 120.0 - 0.8 * k], 1) + rng.normal(0, 2.0, (T, 2))
    present = np.ones(T, bool)
    present[[7, 8, 20]] = False  # frames without a measurement: predict only
    return z.astype(np.float32), present


@pytest.fixture(scope="module")
def slot_runs():
    """Slot 1 of a 4-slot SlotFilter fed the measurements, for both dynamics families."""
    z, present = _measurements()
    out = {}
    for dyn in ("3d", "2d"):
        sf = SlotFilter(CFG, dyn, slots=4)
        rows = []
        for k in range(len(z)):
            zz = np.full((4, 2), np.nan, np.float32)
            if present[k]:
                zz[1] = z[k]
            pres = np.array([False, True, False, False])
            got = sf.step(np.array([False, k == 0, False, False]), zz, pres, 1 / 15)
            rows.append(np.concatenate([[got.started[1]], got.est_uv[1], got.next_uv[1],
                                        got.ground[1], got.velocity[1]]))
        out[dyn] = np.asarray(rows)  # (started, est u, v, next u, v, ground x, y, vx, vy)
    return z, present, out


def test_3d_dynamics_is_the_core_ekf(slot_runs):
    z, present, out = slot_runs
    T = len(z)
    zz = np.where(present[:, None], z, np.nan).astype(np.float32)
    run = eqx.filter_jit(ekf.filter_track)
    ref = run(CFG.camera, CFG.noise, ekf.FromAnnotations(), jnp.asarray(zz), jnp.full(T, jnp.nan),
              jnp.full(T, 1 / 15), jnp.asarray(present))
    mean = np.asarray(ref.steps.mean)
    np.testing.assert_allclose(out["3d"][:, 5], mean[:, 0], rtol=1e-4, atol=2e-4)
    np.testing.assert_allclose(out["3d"][:, 6], mean[:, 2], rtol=1e-4, atol=2e-4)


def test_2d_dynamics_is_a_linear_kalman_filter(slot_runs):
    z, present, out = slot_runs
    nz = image_noise(CFG)
    q2 = np.asarray(jnp.exp(2 * nz.log_q), np.float64)
    R = np.asarray(nz.R(), np.float64)
    s2 = float(nz.init_speed_std()) ** 2
    dt = 1 / 15
    F = np.array([[1, dt, 0, 0], [0, 1, 0, 0], [0, 0, 1, dt], [0, 0, 0, 1]], float)
    Q = np.diag([0, q2[0] * dt, 0, q2[1] * dt])
    H = np.array([[1, 0, 0, 0], [0, 0, 1, 0]], float)
    x = np.array([z[0, 0], 0, z[0, 1], 0], float)
    P = np.diag([R[0, 0], s2, R[1, 1], s2])
    P[0, 2] = P[2, 0] = R[0, 1]
    est = [x.copy()]
    for k in range(1, len(z)):
        x, P = F @ x, F @ P @ F.T + Q
        if present[k]:
            K = P @ H.T @ np.linalg.inv(H @ P @ H.T + R)
            x, P = x + K @ (z[k].astype(float) - H @ x), (np.eye(4) - K @ H) @ P
        est.append(x.copy())
    est = np.asarray(est)
    np.testing.assert_allclose(out["2d"][:, 1], est[:, 0], rtol=0, atol=2e-3)
    np.testing.assert_allclose(out["2d"][:, 2], est[:, 2], rtol=0, atol=2e-3)


def test_placement_covers_the_blob_and_stands_on_its_bottom():
    shape = ShapeModel.from_config(CFG, "3d")
    labels = np.zeros((192, 256), np.int32)
    w, h = (float(q) for q in shape.size(100.0, 140.0))
    labels[int(140 - h * 0.9):141, 94:107] = 3  # a body, columns 94..106, bottom row 140
    labels[60:80, 150:170] = 5  # another blob, not related
    pl = place_patch(labels, np.array([3]), None, shape, 92.0, 132.0, radius_px=12.0)
    assert pl is not None
    assert pl.v == 140.0
    # the whole body is covered, and the placement is the covering one nearest the prediction
    assert pl.covered == int((labels == 3).sum())
    right = lambda u: math.floor(u + pl.w / 2 + 0.5)  # exclusive right column of the patch
    assert math.floor(pl.u - pl.w / 2 + 0.5) <= 94 and right(pl.u - 1) < 107 <= right(pl.u)
    np.testing.assert_allclose((pl.w, pl.h), shape.size(pl.u, pl.v))
    claimed = np.zeros_like(labels, bool)
    claimed[:, :] = True
    assert place_patch(labels, np.array([3]), claimed, shape, 92.0, 132.0, radius_px=12.0) is None
    assert place_patch(labels, np.array([5]), None, shape, 92.0, 132.0, radius_px=12.0) is None


def _truth_switches(res, scene):
    """Per frame, truth foot points and track boxes paired one-to-one (Hungarian on the foot
    distance, gated: |du| < box width, |dv| < 0.3 box height); per truth walker returns (id
    changes, fraction of visible frames paired, the set of paired ids)."""
    from scipy.optimize import linear_sum_assignment

    m = res.mot
    seqs = {i: [] for i in range(len(scene.truth))}
    for k in range(len(scene.frames)):
        sel = m["frame"] == k + 1
        fu = m["bb_left"][sel] + m["bb_width"][sel] / 2
        fv = m["bb_top"][sel] + m["bb_height"][sel]
        vis = [i for i, tr in enumerate(scene.truth) if tr.visible[k]]
        if not vis or not sel.any():
            continue
        du = np.abs(fu[None, :] - np.array([scene.truth[i].u[k] for i in vis])[:, None])
        dv = np.abs(fv[None, :] - np.array([scene.truth[i].v[k] for i in vis])[:, None])
        ok = (du < m["bb_width"][sel][None, :]) & (dv < 0.3 * m["bb_height"][sel][None, :])
        cost = np.where(ok, np.hypot(du, dv), 1e6)
        for r, c in zip(*linear_sum_assignment(cost)):
            if ok[r, c]:
                seqs[vis[r]].append(int(m["id"][sel][c]))
    return [(sum(a != b for a, b in zip(q, q[1:])), len(q) / tr.visible.sum(), set(q))
            for q, tr in zip(seqs.values(), scene.truth)]


def _run(actors, dynamics="3d"):
    spec = SceneSpec(n_frames=72, actors=actors, camera=CFG.camera)
    scene = render_scene(1, spec)
    opt = CountOptions(dynamics=dynamics, verdicts=QUIET)
    res = count_frames(CFG, ((i, i / 15.0, f) for i, f in enumerate(scene.frames)), options=opt)
    return res, scene


@pytest.mark.parametrize("dynamics", ["3d", "3d-shape"])
def test_two_walkers_crossing_keep_their_ids(dynamics):
    a = walker(-4.0, 7.0, 0.0, start_frame=3, phase=0.1)
    b = walker(4.0, 7.6, math.pi, start_frame=3, phase=0.6, grey_torso=150, grey_legs=70)
    res, scene = _run((a, b), dynamics)
    # they overlap in the image around frame 37 (merged blob), then part
    assert res.counts["tracks"] == 2
    (s0, f0, ids0), (s1, f1, ids1) = _truth_switches(res, scene)
    assert s0 == 0 and s1 == 0
    assert f0 > 0.9 and f1 > 0.9
    assert ids0.isdisjoint(ids1)
    # both walk on to the clip's last frame: each piece ends there, none for another reason
    ends = res.summary["ends"]
    assert set(ends) == set(END_REASONS) and ends["clip-end"] == 2 and sum(ends.values()) == 2


def test_a_group_splitting_gives_two_pedestrians():
    a = walker(-0.35, 7.0, math.pi + 0.25, start_frame=3)
    b = walker(0.35, 7.0, -0.25, start_frame=3, phase=0.5, grey_torso=150)
    res, scene = _run((a, b))
    # one blob two walkers wide at the start: two pedestrians side by side, then one each
    assert res.counts["tracks"] == 2
    first = res.mot["frame"] == res.mot["frame"].min()
    assert first.sum() == 2
    (s0, f0, ids0), (s1, f1, ids1) = _truth_switches(res, scene)
    assert s0 == s1 == 0 and f0 > 0.9 and f1 > 0.9 and ids0.isdisjoint(ids1)


def test_new_pedestrians_start_only_in_the_detection_range():
    a = walker(-4.0, 7.0, 0.0, start_frame=3, phase=0.1)  # 7 m ahead
    spec = SceneSpec(n_frames=40, actors=(a,), camera=CFG.camera)
    frames = render_scene(1, spec).frames
    near = config_from_dict({**SMALL, "thresholds": {"range_min_m": 3.0, "range_max_m": 6.0}})
    items = lambda: ((i, i / 15.0, f) for i, f in enumerate(frames))
    assert count_frames(near, items(), options=FAST).counts["tracks"] == 0
    off = CountOptions(verdicts=QUIET, new=NewPedestrianOptions(in_range=False))
    assert count_frames(near, items(), options=off).counts["tracks"] == 1
    assert count_frames(CFG, items(), options=FAST).counts["tracks"] == 1


def _g(ground: list[tuple]) -> list:
    """`Pedestrian.ground` records of plain (x, y m, vx, vy m/s) tuples (no image velocity)."""
    from rhythmjax.count.rows import GroundRow

    return [GroundRow(*g, math.nan, math.nan) for g in ground]


def test_a_track_whose_ground_velocity_jumps_ends_before_the_jump():
    from rhythmjax.count.pedestrian_level import Pedestrian, PedestrianLevel

    level = PedestrianLevel(CFG, FAST)
    k = round(0.5 * 15)  # life.dv_window_s = 0.5 s at 15 fps
    p = Pedestrian(slot=0, born=0)
    # 2 s walking at 1.4 m/s, then the velocity swings by 3 m/s within 0.3 s (the patch slid
    # down a merged blob onto a nearer person)
    p.ground = _g([(0.1 * i, 8.0, 1.4, 0.0) for i in range(30)])
    assert level._velocity_jump(p) == 0
    p.ground += _g([(3.0, 8.0 - 0.2 * i, 1.4, -1.0 * i) for i in range(1, 5)])
    assert level._velocity_jump(p) == k
    # a cyclist at a steady 6 m/s is not lost; nor is a track younger than 2 windows (its
    # filter starts at rest)
    p.ground = _g([(0.4 * i, 8.0, 6.0, 0.0) for i in range(40)])
    assert level._velocity_jump(p) == 0
    p.ground = _g([(0.0, 8.0, 0.0, 0.0)] * 3 + [(0.1, 8.0, 4.0, 0.0)] * 5)
    assert level._velocity_jump(p) == 0
    # the 2-D dynamics have no ground velocity: never
    level2 = PedestrianLevel(CFG, CountOptions(dynamics="2d", verdicts=QUIET))
    p.ground = _g([(0.1 * i, 8.0, 1.4, 0.0) for i in range(30)] + [(3.0, 8.0, 1.4, -4.0)] * 4)
    assert level2._velocity_jump(p) == 0
    assert level._velocity_jump(p) == k


def test_a_swap_between_crossing_walkers_ends_the_track():
    """The default limit (1.5 m/s within 0.5 s: 3 m/s^2, no walker turns or brakes that fast)
    catches a patch that moves from one walker to another crossing at right angles at the
    same 1.4 m/s: |dv| = 1.4 x sqrt(2) = 1.98 m/s; a walker speeding up from 1.0 to 1.4 m/s
    over the window, or turning by 45 degrees (|dv| = 2 x 1.4 x sin(22.5 deg) = 1.07 m/s),
    is not lost."""
    from rhythmjax.count.pedestrian_level import Pedestrian, PedestrianLevel

    level = PedestrianLevel(CFG, FAST)
    assert level.opt.life.max_dv_mps == 1.5
    k = round(0.5 * 15)
    p = Pedestrian(slot=0, born=0)
    walk = _g([(0.1 * i, 8.0, 1.4, 0.0) for i in range(30)])
    p.ground = walk + _g([(3.0, 8.0 + 0.1 * i, 0.0, 1.4) for i in range(1, k + 1)])
    assert level._velocity_jump(p) == k
    p.ground = walk + _g([(3.0 + 0.1 * i, 8.0 + 0.1 * i, 1.4 * math.cos(math.pi / 4),
                           1.4 * math.sin(math.pi / 4)) for i in range(1, k + 1)])
    assert level._velocity_jump(p) == 0
    p.ground = _g([(0.1 * i, 8.0, 1.0 + 0.4 * min(1.0, i / 30), 0.0) for i in range(40)])
    assert level._velocity_jump(p) == 0


def test_scalar_patch_size_is_the_array_one_exactly():
    """`ShapeModel.size` on two floats (plain arithmetic) gives the float64 values of the NumPy
    path (`patch_size_3d`), NaN where there is no ground point, for both shapes."""
    rng = np.random.default_rng(3)
    u, v = rng.uniform(-100, 400, 3000), rng.uniform(-200, 400, 3000)
    v[:30], u[30:60] = np.nan, np.inf
    for dyn in ("3d", "2d"):
        shape = ShapeModel.from_config(CFG, dyn)
        wa, ha = np.broadcast_arrays(*shape.size(u, v))
        one = np.array([shape.size(float(a), float(b)) for a, b in zip(u, v)])
        if dyn == "3d":
            assert np.isnan(wa).sum() > 100  # above the horizon, off the ground
        np.testing.assert_array_equal(one[:, 0], wa)
        np.testing.assert_array_equal(one[:, 1], ha)


def test_placement_cut_to_the_related_blobs_box_is_the_same():
    """place_patch with `bbox` (the related blobs' box) gives the placement of the full search
    window on random blob images, claimed pixels and predictions."""
    from rhythmjax.vision.blobs import find_blobs

    shape = ShapeModel.from_config(CFG, "3d")
    rng = np.random.default_rng(11)
    same = found = n = 0
    for _ in range(300):
        mask = np.zeros((192, 256), np.uint8)
        for _ in range(int(rng.integers(1, 6))):
            x, y = int(rng.integers(0, 240)), int(rng.integers(30, 180))
            mask[max(0, y - int(rng.integers(5, 60))):y, x:x + int(rng.integers(3, 30))] = 1
        blobs, labels = find_blobs(mask, min_area=1)
        if not blobs:
            continue
        rel = rng.choice(len(blobs), size=int(rng.integers(1, len(blobs) + 1)), replace=False)
        bx = [blobs[j].box for j in rel]
        bbox = (min(b[0] for b in bx), min(b[1] for b in bx), max(b[2] for b in bx),
                max(b[3] for b in bx))
        claimed = rng.random(labels.shape) < 0.1 if rng.random() < 0.5 else None
        b = blobs[int(rel[0])]
        pu, pv = b.bottom_center[0] + rng.normal(0, 8), b.bottom_center[1] + rng.normal(0, 6)
        lab = np.asarray([blobs[j].label for j in rel])
        kw = dict(radius_px=float(rng.uniform(2, 20)),
                  v_max=None if rng.random() < 0.5 else float(bbox[3] - 1))
        full = place_patch(labels, lab, claimed, shape, pu, pv, **kw)
        cut = place_patch(labels, lab, claimed, shape, pu, pv, bbox=bbox, **kw)
        same += full == cut
        n += 1
        found += full is not None
    assert same == n > 250 and found > 100


def _lifted_scene(level, span_frac: float):
    """Labels (one blob, label 1): a near walker's patch standing on (80, 170) and, right of
    the 1.8 W its pedestrian explains, a farther walker's columns standing on (u2, 110), spanning
    `span_frac` of its patch height up from its feet; the near pedestrian already placed."""
    from rhythmjax.count.pedestrian_level import Pedestrian
    from rhythmjax.vision.blobs import Blob

    w, h = level.shape.size(80.0, 170.0)
    w2, h2 = level.shape.size(130.0, 110.0)
    u2 = 80.0 + 0.9 * w + 0.5 * w2 + 2.0
    lab = np.zeros((192, 256), np.int32)
    lab[max(0, round(171 - h)):171, round(80 - w / 2):round(80 + w / 2)] = 1
    lab[max(0, round(111 - span_frac * h2)):111, round(u2 - w2 / 2):round(u2 + w2 / 2)] = 1
    ys, xs = np.nonzero(lab)
    blob = Blob((int(xs.min()), int(ys.min()), int(xs.max()) + 1, int(ys.max()) + 1),
                int(ys.size), 0.0, (float(xs.mean()), float(ys.mean())), 0.5, 1)
    p = Pedestrian(slot=0, born=0)
    p.z = (80.0, 170.0)
    level.peds = [p]
    return [blob], lab, u2, h, h2


@pytest.mark.parametrize("span_frac, lifted_height, starts", [
    (1.0, 0.55, True),   # a farther walker merged with a nearer one: its feet far above the
    (0.52, 0.55, False),  # blob's bottom; an arm-high run (>= new_min_height, < lifted) does not
    (0.52, 0.5, True),   # ... (it is the lifted rule that stops it)
    (1.0, 2.0, False),   # the rule off: only runs reaching the blob's bottom start one
])
def test_a_walker_merged_above_a_nearer_one_starts_a_pedestrian(span_frac, lifted_height,
                                                                 starts):
    from rhythmjax.count.pedestrian_level import PedestrianLevel

    level = PedestrianLevel(CFG, CountOptions(verdicts=QUIET, new=NewPedestrianOptions(
        lifted_height=lifted_height)))
    assert level.opt.new.min_height == 0.5 and CountOptions().new.lifted_height == 0.55
    blobs, lab, u2, h, h2 = _lifted_scene(level, span_frac)
    assert 110 < 170 - level.opt.new.max_lift * h  # lifted: above the blob's bottom band
    assert level._in_range((u2, 110.0))
    new = level._new_pedestrians(blobs, lab)
    if starts:
        assert len(new) == 1
        assert abs(new[0].z[0] - u2) <= 1.0 and new[0].z[1] == 110.0
    else:
        assert new == []


def test_online_verdict_windows_start_every_hop_samples():
    """The pedestrians level's online verdict (drawn on the overlay) judges the same windows as
    `rhythm.classify_track`: N = 32 rows, one starting every hop = 16 rows; a constant signal
    (no peak, never Pedestrian) is judged at 32, 48 and 64 rows, and not in between."""
    from rhythmjax.count.pedestrian_level import Pedestrian, PedestrianLevel

    cfg = config_from_dict({"thresholds": {"n_samples": 32}})
    level = PedestrianLevel(cfg, CountOptions(verdicts=VerdictOptions(classify=False)))
    p = Pedestrian(slot=0, born=0)
    judged_at = []
    for k in range(70):  # (index, t, u, v, width, intensity, x, y, state)
        p.rows.append(TrackRow(k, k / 15.0, 100.0, 200.0, 30.0, 5.0, 0.1 * k, 10.0, 2))
        before = p.windows_done
        level._match(p)
        if p.windows_done > before:
            judged_at.append(len(p.rows))
    assert judged_at == [32, 48, 64]
    assert not p.decided and int(p.result["verdict"]) == 2 and p.result["window"] == (0, 32)
    assert p.win_start == 48  # windows (0, 32), (16, 48), (32, 64) judged; the first kept


def test_placement_helpers_match_plain_references():
    """`related_mask` (np.isin), `lowest_rows`, `range_max` (NumPy loops) and `row_sizes`
    (`size` at each row) give the same values exactly (integers; the same float64 operations)."""
    from rhythmjax.count.patches import lowest_rows, range_max, related_mask

    rng = np.random.default_rng(5)
    for dtype in (np.uint8, np.uint16, np.int32):
        win = rng.integers(0, 9, (40, 30)).astype(dtype)
        for rel in ([3], [0], [2, 5], [1, 2, 3, 4, 7, 8], [-1, 3, 70000], []):
            want = np.isin(win.astype(np.int64), [q for q in rel if q >= 0])
            np.testing.assert_array_equal(related_mask(win, np.asarray(rel, np.int64)), want)
    for _ in range(50):
        m = rng.random((int(rng.integers(1, 30)), int(rng.integers(1, 30)))) < rng.random()
        want = [np.flatnonzero(c)[-1] if c.any() else -1 for c in m.T]
        np.testing.assert_array_equal(lowest_rows(m.view(np.uint8)), want)
        np.testing.assert_array_equal(lowest_rows(m), want)
        x = rng.integers(-5, 100, int(rng.integers(1, 40)))
        lo, hi = rng.integers(0, x.size + 1, (2, 60))
        want = [x[a:b].max() if b > a else -7 for a, b in zip(lo, hi)]
        np.testing.assert_array_equal(range_max(x, lo, hi, -7), want)
    for dyn in ("3d", "2d"):
        shape = ShapeModel.from_config(CFG, dyn)
        rows = np.arange(192.0)
        want = np.broadcast_arrays(*shape.size(rng.uniform(0, 256, rows.size), rows))
        np.testing.assert_array_equal(np.stack(shape.row_sizes(192)), np.stack(want))
