"""Articulated walker legs for `rhythmjax.sim`: thigh, shank and a foot that rolls heel to toe.

The plain walker of `sim.actors` has straight legs from hip to shoe and shoes that stay flat
and slide a few centimetres above the ground through the swing. Real legs (and the independent
renderer's of ../shared/data/dev) bend at the knee, lift the heel before the toe leaves the
ground and carry the swinging foot well above it. This module draws the leg the second way,
from textbook sagittal-plane gait kinematics (heel strike with the toe up ~15 deg, foot flat
through mid-stance, heel rise about the toe to ~45 deg at toe-off, the swing ankle highest,
~0.2 m, early in the swing, toe clearance ~2 cm at mid-swing, the knee near straight at heel
strike and mid-stance, ~45 deg at toe-off, 50-65 deg at its swing peak). The pelvis is highest
at mid-stance and lowest at heel strike, by 3, 7 and 14 cm for steps of 0.55, 0.72 and 0.9 m of
a 1.7 m walker: more than a real walker's 4-5 cm for long steps, as the legs here have one
length and no hip rotation. Nothing here was fitted to any clip.

Conventions as `sim.actors`: body frame s forward, z up (m); c counts gait cycles (one cycle
is two steps); a leg with cycle offset o is in swing for p = frac(c - o) < `actors.WALKER_SWING`
(0.4) and in stance after it; heel strike at p = 0.4, toe-off at p = 1. The body moves 2 L per
cycle (L the step length, m), so a planted foot moves back by 2 L per cycle in the body frame.

Construction, per leg and instant:
1. the ankle (s, z) and the foot's pitch phi (rad, toe up positive): in stance the foot rolls
   about the heel (phi 15 deg -> 0 over the first 12 % of stance), stays flat, then rolls about
   the toe (0 -> -45 deg over the last 40 %), with the pivot fixed on the ground (no sliding);
   in swing the ankle moves from its toe-off to its heel-strike place along the world profile
   (1 - cos(pi tau)) / 2, tau = p / swing, its height and the pitch through the key frames of
   `SWING_KEYS`; the flat foot's place is shifted by `ankle_shift` so that the hip-ankle
   distance is the same at heel strike and at toe-off;
2. the hip rises and falls with a cosine, twice a cycle: lowest at heel strike, where the
   leading leg reaches its ankle 5 deg bent, highest a quarter step later, the stance leg 5 deg
   bent under it (`hip_range`; k = height / 1.7 m);
3. the knee by two-link inverse kinematics, thigh and shank each half the hip-to-ankle length
   0.9 k - 0.08 m, bending forwards; where the ankle is out of reach (a long step's trailing
   leg) the knee sits midway and the leg is drawn straight to the ankle.
"""

from __future__ import annotations

import functools
import math

import numpy as np


SWING = 0.4  # fraction of a walker's gait cycle in swing (sim.actors.WALKER_SWING is this)
HEEL = 0.06  # m, heel behind the ankle
TOE = 0.18  # m, toe ahead of the ankle
ANKLE = 0.08  # m, ankle above the sole
HEEL_STRIKE_PITCH = math.radians(15.0)  # toe up at heel strike
TOE_OFF_PITCH = math.radians(-45.0)  # heel up at toe-off
HEEL_ROLL = 0.12  # fraction of stance rolling about the heel
TOE_ROLL = 0.4  # fraction of stance (its end) rolling about the toe
HIP = 0.9  # hip joint height per unit k (k = height / 1.7 m), m
MID_STANCE_KNEE = math.radians(5.0)  # knee flexion with the stance foot under the hip
HEEL_STRIKE_KNEE = math.radians(5.0)  # and at heel strike
# Swing key frames: (tau, ankle height m or None for the geometric end, pitch deg).
SWING_KEYS = ((0.0, None, math.degrees(TOE_OFF_PITCH)), (0.3, 0.20, -25.0), (0.6, 0.10, 0.0),
              (1.0, None, math.degrees(HEEL_STRIKE_PITCH)))
# Foot outline about the ankle, flat (s, z) m: heel bottom and top, toe top and bottom.
FOOT_OUTLINE = ((-HEEL, -ANKLE), (-HEEL, 0.0), (TOE, -0.045), (TOE, -ANKLE))


def _smooth(x):
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def _rotate(s, z, phi):
    c, n = np.cos(phi), np.sin(phi)
    return s * c - z * n, s * n + z * c


def _heel_pose(phi):
    """Ankle (ds, z) about the heel pivot on the ground, relative to the flat ankle's s."""
    ds, z = _rotate(HEEL, ANKLE, phi)
    return ds - HEEL, z


def _toe_pose(phi):
    """Ankle (ds, z) about the toe pivot on the ground, relative to the flat ankle's s."""
    ds, z = _rotate(-TOE, ANKLE, phi)
    return ds + TOE, z


def ankle_shift() -> float:
    """Shift (m) of the flat foot's place from `actors.gait`'s rel that makes the ankle's
    horizontal distance from the hip the same at heel strike and at toe-off."""
    return -0.5 * (float(_heel_pose(HEEL_STRIKE_PITCH)[0]) + float(_toe_pose(TOE_OFF_PITCH)[0]))


def _stance(p, L):
    """(ankle s, ankle z, pitch) in the body frame for stance phases p in [SWING, 1)."""
    q = (p - SWING) / (1.0 - SWING)
    flat = 2.0 * L * (1.0 - p) - L * (1.0 - SWING) + ankle_shift()
    heel_phi = HEEL_STRIKE_PITCH * (1.0 - _smooth(q / HEEL_ROLL))
    toe_phi = TOE_OFF_PITCH * _smooth((q - (1.0 - TOE_ROLL)) / TOE_ROLL)
    hs, hz = _heel_pose(heel_phi)
    ts, tz = _toe_pose(toe_phi)
    early = q < HEEL_ROLL
    late = q > 1.0 - TOE_ROLL
    s = flat + np.where(early, hs, np.where(late, ts, 0.0))
    z = np.where(early, hz, np.where(late, tz, ANKLE))
    phi = np.where(early, heel_phi, np.where(late, toe_phi, 0.0))
    return s, z, phi


def _keys(tau, values):
    """Piecewise smoothstep through the swing key frames (value at each key's tau)."""
    taus = np.array([k[0] for k in SWING_KEYS])
    i = np.clip(np.searchsorted(taus, tau, side="right") - 1, 0, len(taus) - 2)
    w = _smooth((tau - taus[i]) / (taus[i + 1] - taus[i]))
    v = np.asarray(values)
    return v[i] + (v[i + 1] - v[i]) * w


def _swing(p, L):
    """(ankle s, ankle z, pitch) in the body frame for swing phases p in [0, SWING)."""
    tau = p / SWING
    s_to, z_to, _ = _stance(np.float64(1.0 - 1e-12), L)
    s_hs, z_hs, _ = _stance(np.float64(SWING), L)
    g = 0.5 - 0.5 * np.cos(np.pi * tau)
    advance = 2.0 * L * SWING  # the body's advance over the swing
    s = s_to + (s_hs + advance - s_to) * g - 2.0 * L * p
    heights = [z_to if k[1] is None else k[1] for k in SWING_KEYS[:-1]] + [z_hs]
    z = _keys(tau, heights)
    phi = np.radians(_keys(tau, [k[2] for k in SWING_KEYS]))
    return s, z, phi


def ankle(c, offset: float, L: float):
    """(ankle s m, ankle z m, foot pitch rad) of the leg with cycle offset `offset` at gait
    cycles c (array or scalar), body frame."""
    p = np.mod(np.asarray(c, np.float64) - offset, 1.0)
    sw, st = _swing(p, L), _stance(np.maximum(p, SWING), L)
    swinging = p < SWING
    return tuple(np.where(swinging, a, b) for a, b in zip(sw, st))


def segment_length(k: float) -> float:
    """Thigh = shank length (m): half of a 1.7 k m tall walker's hip-to-ankle length
    (0.9 k - 0.08 m)."""
    return 0.5 * (HIP * k - ANKLE)


@functools.lru_cache(maxsize=256)
def hip_range(L: float, k: float) -> tuple[float, float]:
    """(lowest, highest) hip height (m): highest with the stance leg under the hip, knee
    `MID_STANCE_KNEE` bent; lowest at heel strike, the leading leg reaching its heel-strike
    ankle with the knee `HEEL_STRIKE_KNEE` bent (the pelvis' rise and fall, longer steps
    lower)."""
    reach = 2.0 * segment_length(k)
    s_hs, z_hs, _ = (float(x) for x in _stance(np.float64(SWING), L))
    high = ANKLE + reach * math.cos(0.5 * MID_STANCE_KNEE)
    r = reach * math.cos(0.5 * HEEL_STRIKE_KNEE)
    low = z_hs + math.sqrt(max(r * r - s_hs * s_hs, 0.0))
    return min(low, high), high


def hip_height(c, L: float, k: float):
    """Hip joint height (m) at gait cycles c: lowest at each heel strike (c = 0.4 and 0.9 for
    the legs of offsets 0 and 1/2), highest a quarter step later."""
    low, high = hip_range(L, k)
    return 0.5 * (high + low) - 0.5 * (high - low) * np.cos(4.0 * np.pi * (np.asarray(
        c, np.float64) - SWING))


def knee(hip_s, hip_z, ankle_s, ankle_z, half: float):
    """Knee (s, z) by two-link inverse kinematics, both links `half` long, bending forwards
    (the knee ahead of the hip-ankle line); on the line where the ankle is out of reach."""
    vs, vz = ankle_s - hip_s, ankle_z - hip_z
    d = np.maximum(np.hypot(vs, vz), 1e-9)
    off = np.sqrt(np.maximum(half * half - 0.25 * d * d, 0.0))
    return hip_s + 0.5 * vs - off * vz / d, hip_z + 0.5 * vz + off * vs / d


def foot_points(ankle_s, ankle_z, phi, lat: float) -> np.ndarray:
    """The foot's 8 corners (body frame, m) for one instant: `FOOT_OUTLINE` pitched by phi
    about the ankle, 0.08 m wide about the lateral place `lat`."""
    out = []
    for s, z in FOOT_OUTLINE:
        ds, dz = _rotate(s, z, phi)
        for dl in (-0.04, 0.04):
            out.append((ankle_s + ds, lat + dl, ankle_z + dz))
    return np.array(out)


def leg_joints(c: float, offset: float, L: float, k: float):
    """(hip, knee, ankle) as (s, z) pairs and the foot's pitch for one leg at one instant."""
    a_s, a_z, phi = (float(x) for x in ankle(c, offset, L))
    h_z = float(hip_height(c, L, k))
    k_s, k_z = (float(x) for x in knee(0.0, h_z, a_s, a_z, segment_length(k)))
    return (0.0, h_z), (k_s, k_z), (a_s, a_z), phi
