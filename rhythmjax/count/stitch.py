"""Stitching fragments of one walker into one track (`stitch_pieces`; the rule is in
`rhythmjax.count.counting`'s module docstring)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..model.camera_np import project_3d
from ..model.status import TrackState
from ..track.relink import Anchor, gate_distance
from .appearance import appearance_distance
from .patches import ground_point
from .pedestrian_level import Pedestrian, PedestrianLevel


if TYPE_CHECKING:
    from .options import AppearanceOptions


__all__ = ["Piece", "ground_dv_misfit", "ground_velocity", "halfway_misfit", "piece_of",
           "reach_misfit", "reid_distance", "stitch_level", "stitch_pieces"]


@dataclass(frozen=True)
class Piece:
    """A track for stitching: first and last measured frame (index) and time (s); its foot point
    (u, v px, du, dv px/s) at its first frame and at its last, and the patch (w, h) px at its
    first; for the "3d" dynamics also its ground state (x, y m, vx, vy m/s) at its last frame
    (the EKF's: the prediction runs on the ground plane). NaN: unknown. `start_xy`: the ground
    point (m) of its start foot point; `look`: its (2, bins) appearance descriptor
    (`appearance.Appearance.mean`); `start_v`, `end_v`: its ground velocity (vx, vy m/s) at its
    start (the start line fit through the inverse of (3)) and at its end (the EKF's for "3d",
    else the end line fit's, likewise); None: unknown."""

    first: int
    last: int
    t_first: float
    t_last: float
    start: tuple[float, float, float, float]
    end: tuple[float, float, float, float]
    size: tuple[float, float]
    end_ground: tuple[float, float, float, float] | None = None
    start_xy: tuple[float, float] | None = None
    look: np.ndarray | None = None
    start_v: tuple[float, float] | None = None
    end_v: tuple[float, float] | None = None


def ground_velocity(camera, u: float, v: float, du: float, dv: float,
                    dt: float = 1e-3) -> tuple[float, float] | None:
    """Ground velocity (vx, vy) m/s of a foot point at (u, v) px moving at (du, dv) px/s: the
    inverse of (3) at (u, v) -+ dt/2 (du, dv), differenced over dt s (a central difference;
    1 ms: its error is about (dt |v| / y)^2 of the velocity, 3e-7 of it for a 4 m/s cyclist
    8 m away). None where either point has no ground point or an input is not finite."""
    if not all(math.isfinite(q) for q in (u, v, du, dv)):
        return None
    h = 0.5 * dt
    x0, y0, ok0 = ground_point(camera, u - h * du, v - h * dv)
    x1, y1, ok1 = ground_point(camera, u + h * du, v + h * dv)
    if not (bool(ok0) and bool(ok1)):
        return None
    return float(x1 - x0) / dt, float(y1 - y0) / dt


def ground_dv_misfit(A: Piece, B: Piece) -> float:
    """|A's ground velocity at its end - B's at its start| (m/s; `Piece.end_v`, `start_v`);
    inf when either is unknown."""
    if A.end_v is None or B.start_v is None:
        return math.inf
    return math.hypot(A.end_v[0] - B.start_v[0], A.end_v[1] - B.start_v[1])


def _line_fit(t: np.ndarray, uv: np.ndarray, at: float) -> tuple[float, float, float, float]:
    """(u, v, du, dv) at time `at` of a least-squares line through (t, uv); NaN with < 2
    points (velocity 0 when every t is the same)."""
    if len(t) < 2:
        return (math.nan,) * 4
    tc = t - at
    if np.ptp(tc) <= 0:
        m = uv.mean(axis=0)
        return float(m[0]), float(m[1]), 0.0, 0.0
    A = np.stack([np.ones_like(tc), tc], 1)
    coef, *_ = np.linalg.lstsq(A, uv, rcond=None)
    return float(coef[0, 0]), float(coef[0, 1]), float(coef[1, 0]), float(coef[1, 1])


def piece_of(p: Pedestrian, shape, dynamics: str, fit_s: float) -> Piece:
    """The `Piece` of a pedestrian's rows: a line fit over its measured foot points in its first
    `fit_s` s gives its start; its end is the EKF ground state at its last (measured) row for
    "3d" (projected, with the image velocity of its ground velocity), else the same fit over
    its last `fit_s` s."""
    t = np.asarray([r.t for r in p.rows], np.float64)
    uv = np.asarray([(r.u, r.v) for r in p.rows], np.float64).reshape(-1, 2)
    state = np.asarray([r.state for r in p.rows], np.int64)
    use = (state == int(TrackState.OBSERVE)) & np.all(np.isfinite(uv), axis=1)
    t0, t1 = float(t[0]), float(t[-1])
    head = use & (t <= t0 + fit_s)
    start = _line_fit(t[head], uv[head], t0)
    size = tuple(float(q) for q in shape.size(*start[:2])) if np.isfinite(start[0]) else \
        (math.nan, math.nan)
    ground = None
    if dynamics == "3d":
        last = p.ground[-1]
        x, y, vx, vy = ground = (float(last.x), float(last.y), float(last.vx), float(last.vy))
        u, v = project_3d(shape.camera, x, y, 0.0)
        u2, v2 = project_3d(shape.camera, x + 0.1 * vx, y + 0.1 * vy, 0.0)
        end = (u, v, (u2 - u) / 0.1, (v2 - v) / 0.1)
    else:
        tail = use & (t >= t1 - fit_s)
        end = _line_fit(t[tail], uv[tail], t1)
    start_xy = None
    if np.isfinite(start[0]):
        gx, gy, ok = ground_point(shape.camera, start[0], start[1])
        start_xy = (float(gx), float(gy)) if bool(ok) else None
    look = None if p.look is None else p.look.mean()
    end_v = ground_velocity(shape.camera, *end) if ground is None else ground[2:]
    return Piece(int(p.rows[0].frame), int(p.rows[-1].frame), t0, t1, start, end, size, ground,
                 start_xy, look, ground_velocity(shape.camera, *start), end_v)


def _predict(A: Piece, dt: float, camera: tuple | None) -> np.ndarray:
    """A's foot point (u, v) dt s after its end: on the ground plane (EKF state) when it has
    one, else in the image."""
    if A.end_ground is not None and camera is not None:
        x, y, vx, vy = A.end_ground
        return np.asarray(project_3d(camera, x + vx * dt, y + vy * dt, 0.0))
    e = np.asarray(A.end)
    return e[:2] + e[2:] * dt


def halfway_misfit(A: Piece, B: Piece, camera: tuple | None, *, gate_w: float, gate_h: float,
                   gate_per_s: float, max_dv_w: float) -> tuple[float, float]:
    """`stitch_pieces`' halfway misfits of B after A, each over its gate (<= 1: inside): the
    position d (A predicted gap/2 s on, `_predict`, against B's start taken gap/2 s back at its
    own velocity; an ellipse gate_w W across and gate_h H up or down, W, H: B's patch, growing
    by gate_per_s per second of gap) and the image velocity dv (over max_dv_w W/s). A.end and
    B.start must be finite; B after A."""
    sb, (w, h) = np.asarray(B.start, np.float64), B.size
    gap = B.t_first - A.t_last
    mid_a = _predict(A, 0.5 * gap, camera)
    mid_b = sb[:2] - sb[2:] * 0.5 * gap
    d = float(np.hypot((mid_a[0] - mid_b[0]) / (gate_w * w),
                       (mid_a[1] - mid_b[1]) / (gate_h * h))) / (1.0 + gate_per_s * gap)
    dv = float(np.hypot(*(np.asarray(A.end, np.float64)[2:] - sb[2:]))) / (max_dv_w * w)
    return d, dv


def reid_distance(A: Piece, B: Piece, camera: tuple | None, *, gate_w: float, gate_h: float,
                  gate_per_s: float) -> float:
    """Ground-plane re-identification misfit (<= 1: inside the gate) of B's first foot point
    (its start fit, px, at B.t_first) with A moved on for the whole gap: A's last EKF ground
    state at constant velocity, projected (`track.relink.gate_distance`, as the single-object
    tracker re-finds a track lost in PREDICT); without a ground state, A's image line. The
    ellipse is gate_w W across and gate_h H up or down (W, H: B's patch at its start), growing
    by gate_per_s per second of gap. Unlike the halfway meeting it does not use B's start
    velocity, which a walker stepping out from behind another often gets wrong. inf: unknown."""
    sb, (w, h) = np.asarray(B.start, np.float64), B.size
    gap = B.t_first - A.t_last
    if not (np.all(np.isfinite(sb[:2])) and w > 0 and h > 0 and gap >= 0):
        return math.inf
    if A.end_ground is not None and camera is not None:
        return gate_distance(camera, Anchor(A.t_last, *A.end_ground), B.t_first, sb[:2], w,
                             gate_w=gate_w, gate_h=gate_h, gate_per_s=gate_per_s,
                             height_per_W=h / w)
    e = np.asarray(A.end, np.float64)
    if not np.all(np.isfinite(e)):
        return math.inf
    at = e[:2] + e[2:] * gap
    return float(np.hypot((at[0] - sb[0]) / (gate_w * w), (at[1] - sb[1]) / (gate_h * h))) / \
        (1.0 + gate_per_s * gap)


def reach_misfit(A: Piece, B: Piece, camera: tuple | None, reach_m: float,
                 speed_mps: float) -> float:
    """Ground distance (m) from A's last ground point (its EKF state, else its end foot point's
    ground point) to B's start ground point (`Piece.start_xy`), over what a walker can cover in
    the gap: reach_m + speed_mps x gap (<= 1: reachable). inf: unknown or B not after A."""
    gap = B.t_first - A.t_last
    if B.start_xy is None or not gap >= 0:
        return math.inf
    if A.end_ground is not None:
        xa, ya = A.end_ground[:2]
    elif camera is not None and np.all(np.isfinite(A.end[:2])):
        xa, ya, ok = ground_point(camera, A.end[0], A.end[1])
        if not bool(ok):
            return math.inf
    else:
        return math.inf
    d = math.hypot(float(xa) - B.start_xy[0], float(ya) - B.start_xy[1])
    return d / max(1e-9, reach_m + speed_mps * gap)


def stitch_pieces(pieces: list[Piece], *, max_gap_s: float, gate_w: float, gate_h: float,
                  gate_per_s: float, max_dv_w: float, camera: tuple | None = None,
                  reid: bool = False, reid_max_dv_w: float = math.inf,
                  look: AppearanceOptions | None = None, body_width_m: float = 0.5,
                  max_dv_mps: float = math.inf) -> list[int]:
    """Successor of each piece (index into `pieces`, -1: none); see the module docstring.

    B may follow A when B.first > A.last and B.t_first - A.t_last = gap <= max_gap_s, and they
    meet halfway: A predicted gap/2 s on (`_predict`) and B's start taken gap/2 s back at its
    own velocity differ by at most (gate_w W, gate_h H) x (1 + gate_per_s x gap) (W, H: B's
    patch at its start; an ellipse), and their image velocities by at most max_dv_w W/s.
    Cheapest pairs first (position misfit / its gate + velocity misfit / max_dv_w; charging the
    gap as well, so that A -> B -> C beats A -> C, was tried and lost: 59 -> 55 counted of 58 on
    the synthetic scenes, as a short-gap wrong piece then beats the right one); each piece has at
    most one predecessor and one successor.

    `reid` (a fallback): B may also follow A when B's first foot point lies where A's
    constant-velocity ground prediction puts it (`reid_distance` <= 1, same gate) and their
    image velocities differ by at most reid_max_dv_w W/s; such pairs are taken, cheapest first,
    only after every halfway pair. Taken together with them, cheapest of the two misfits first,
    re-identified pairs displaced right halfway ones in groups, where many walkers pass the
    predicted spot within seconds (own seeds 42024: missed/over/extra walkers 11/3/5 ->
    11/2/7; 31337: 11/3/9 -> 12/4/10); as a fallback it changed no count there.

    `look` (`AppearanceOptions`, when enabled; a second fallback, taken after both): B may also
    follow A when B starts within look.max_gap_s s, within reach (`reach_misfit` <= 1 with
    reach_widths x body_width_m m and reach_speed_mps) and their descriptors (`Piece.look`) are
    at most look.max_distance apart (`appearance.appearance_distance`), cheapest first (none
    when look.max_distance is 0); a halfway or re-identified pair whose descriptors are more
    than look.veto_distance apart is refused.

    `max_dv_mps` (finite: on; inf, the default: off): a halfway or re-identified pair must also
    have A's ground velocity at its end and B's at its start (`ground_dv_misfit`) within
    max_dv_mps m/s (unknown: refused), and that misfit / max_dv_mps replaces the image velocity
    misfit in its cost. In the image a walker's and a cyclist's velocities differ little when
    they move in depth (the rows foreshorten), and W/s weighs rows and columns alike; on the
    ground they differ by their speeds."""
    ground_gate = math.isfinite(max_dv_mps)
    use_look = look is not None and look.enabled
    look_joins = use_look and look.max_distance > 0  # 0: descriptors for the veto only
    cand, gate = [], dict(gate_w=gate_w, gate_h=gate_h, gate_per_s=gate_per_s)
    for a, A in enumerate(pieces):
        ea = np.asarray(A.end, np.float64)
        if not np.all(np.isfinite(ea)):
            continue
        for b, B in enumerate(pieces):
            sb, (w, h) = np.asarray(B.start, np.float64), B.size
            gap = B.t_first - A.t_last
            if (B.first <= A.last or not np.all(np.isfinite(sb)) or not (w > 0 and h > 0)):
                continue
            dist = appearance_distance(A.look, B.look) if use_look else math.nan
            if gap > max_gap_s:
                if (look_joins and gap <= look.max_gap_s and dist <= look.max_distance
                        and reach_misfit(A, B, camera, look.reach_widths * body_width_m,
                                         look.reach_speed_mps) <= 1.0):
                    cand.append((2, dist, a, b))
                continue
            d, dv = halfway_misfit(A, B, camera, gate_w=gate_w, gate_h=gate_h,
                                   gate_per_s=gate_per_s, max_dv_w=max_dv_w)
            r = reid_distance(A, B, camera, **gate) if reid else math.inf
            dv_r = dv * max_dv_w / reid_max_dv_w
            ok, ok_r = d <= 1.0 and dv <= 1.0, r <= 1.0 and dv_r <= 1.0
            if ground_gate:
                dv = dv_r = ground_dv_misfit(A, B) / max_dv_mps
                ok, ok_r = ok and dv <= 1.0, ok_r and dv <= 1.0
            if (ok or ok_r) and use_look and dist > look.veto_distance:
                continue
            if ok:
                cand.append((0, d + dv, a, b))
            elif ok_r:
                cand.append((1, r + dv_r, a, b))
            elif (look_joins and gap <= look.max_gap_s and dist <= look.max_distance
                  and reach_misfit(A, B, camera, look.reach_widths * body_width_m,
                                   look.reach_speed_mps) <= 1.0):
                cand.append((2, dist, a, b))
    succ, pred = [-1] * len(pieces), [-1] * len(pieces)
    for _, _, a, b in sorted(cand):
        if succ[a] < 0 and pred[b] < 0:
            succ[a], pred[b] = b, a
    return succ


def stitch_level(level: PedestrianLevel, peds: list[Pedestrian]) -> list[Pedestrian]:
    """Join the chains `stitch_pieces` finds among the ended tracks (`peds`, in id order) into
    one track each (the first piece's id); the rest unchanged."""
    opt = level.opt
    if not opt.stitch.enabled or len(peds) < 2:
        return peds
    pieces = [piece_of(p, level.shape, opt.dynamics, opt.stitch.fit_s) for p in peds]
    succ = stitch_pieces(pieces, max_gap_s=opt.stitch.max_gap_s, gate_w=opt.stitch.gate_w,
                         gate_h=opt.stitch.gate_h, gate_per_s=opt.stitch.gate_per_s,
                         max_dv_w=opt.stitch.max_dv_w, camera=level.shape.camera,
                         reid=opt.stitch.reid, reid_max_dv_w=opt.stitch.reid_max_dv_w,
                         look=opt.appearance, body_width_m=float(level.cfg.width.mean),
                         max_dv_mps=opt.stitch.max_dv_mps)
    has_pred = {b for b in succ if b >= 0}
    out = []
    for a, p in enumerate(peds):
        if a in has_pred:
            continue
        b = succ[a]
        while b >= 0:
            q = peds[b]
            p.rows, p.boxes, p.ground = p.rows + q.rows, p.boxes + q.boxes, p.ground + q.ground
            p.hits += q.hits
            if p.look is not None:
                p.look.merge(q.look)
            else:
                p.look = q.look
            level.stitched += 1
            b = succ[b]
        out.append(p)
    return out
