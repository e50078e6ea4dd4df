"""Actor geometry for `rhythmjax.synth`: gaits and 3-D body parts of walkers, bicycles and dogs.

Body frame (m): s along the heading, l lateral (to the left of the heading), z height above the
ground; the origin is the object's ground reference (for a walker the pelvis' ground point). A part
is (mode, points (n, 3) in the body frame, grey level, thickness m, anchor l): mode "hull" fills
the convex hull of the projected points, "closed" / "open" draw a polyline of that 3-D thickness.
Parts are drawn far first by the depth of their anchor (0, anchor l, 0), ties in list order: a
fixed order per actor (far-side limbs, body, near-side limbs) that never flickers.

Gait (walkers and dogs). One gait cycle is two steps; c = F t / 2 + phase counts cycles (F the
step frequency, Hz). A foot with cycle offset o swings during the first `swing` fraction of its
cycle (p = frac(c - o) < swing) and moves forward 2 L then (L the step length) with the smooth
profile (1 - cos(pi p / swing)) / 2; otherwise it is planted. Its position relative to the body,
which moves at the constant speed F L, is rel = 2 L (g(p) - p) - L (1 - swing): zero mean, and
constant on the ground during stance. Walkers: offsets 0 and 1/2, swing 0.4 of the cycle (0.8 of
a step period), double support between; their legs straight (`rod_legs`) or, `articulated`,
with knees and feet rolling heel to toe (`articulated_legs`, `sim.legs`). Dogs trot: diagonal
pairs share an offset, swing 0.45.
"""

from __future__ import annotations

import math

import numpy as np

from . import legs


WALKER_SWING = legs.SWING  # 0.4
DOG_SWING = 0.45
WHEEL_RADIUS = 0.34  # m
WHEELBASE = 1.05  # m
CRANK = 0.17  # m
FOOT_LIFT = 0.025  # m, a walker's foot at mid-swing
BB_HEIGHT = 0.32  # m, bottom bracket: the lowest pedal stays 0.15 m above the ground


def gait(c, offset: float, swing: float, step_length: float):
    """(rel m, lift in [0, 1], swinging bool) of a foot at gait cycles c (array or scalar)."""
    c = np.asarray(c, np.float64)
    p = np.mod(c - offset, 1.0)
    swinging = p < swing
    tau = np.clip(p / swing, 0.0, 1.0)
    g = np.where(swinging, 0.5 - 0.5 * np.cos(np.pi * tau), 1.0)
    rel = 2.0 * step_length * (g - p) - step_length * (1.0 - swing)
    lift = np.where(swinging, np.sin(np.pi * tau), 0.0)
    return rel, lift, swinging


def _box(s0, s1, l0, l1, z0, z1) -> np.ndarray:
    return np.array([[s, ll, z] for s in (s0, s1) for ll in (l0, l1) for z in (z0, z1)])


def _limb(p, q, hs_p, hl_p, hs_q, hl_q) -> np.ndarray:
    """8 corners of a limb from p to q (body frame), half-sizes along s and l at each end."""
    out = []
    for c, hs, hl in ((p, hs_p, hl_p), (q, hs_q, hl_q)):
        for ds in (-hs, hs):
            for dl in (-hl, hl):
                out.append((c[0] + ds, c[1] + dl, c[2]))
    return np.array(out)


def walker_feet(c, step_length: float):
    """Feet of a walker: list of (rel, lift) arrays for the left (+l) and right (-l) feet."""
    return [gait(c, o, WALKER_SWING, step_length)[:2] for o in (0.0, 0.5)]


def walker_parts(c: float, a: dict) -> list:
    """Parts of a walker at gait cycle c; `a` holds height_m, step_length_m, grey levels, bag,
    suitcase and `articulated` (legs with knees and heel-to-toe feet, `sim.legs`; else straight
    legs, `rod_legs`)."""
    k = a["height_m"] / 1.7
    if a.get("articulated", False):
        parts = articulated_legs(c, a, k)
    else:
        parts = rod_legs(c, a, k)
    parts.append(("hull", _box(-0.13, 0.13, -0.225, 0.225, 0.86 * k, 1.46 * k), a["torso"], 0.0,
                  0.0))
    parts.append(("hull", _box(-0.1, 0.1, -0.08, 0.08, 1.47 * k, 1.7 * k), a["head"], 0.0, 0.0))
    if a["bag"]:
        sgn = a["bag_side"]
        parts.append(("hull", _box(-0.16, 0.16, 0.28 * sgn, 0.38 * sgn, 0.55 * k, 0.9 * k),
                      a["bag_grey"], 0.0, 0.4 * sgn))
    if a["suitcase"]:
        parts.extend(suitcase_parts(a, k))
    return parts


def _arm(rel: float, side: float, k: float, a: dict) -> tuple:
    """An arm swinging against the leg of its side (rel: that leg's foot place, m)."""
    sh, hand = 1.42 * k, -0.6 * rel
    return ("hull", _limb((0.0, 0.25 * side, sh), (hand, 0.27 * side, 0.8 * k), 0.045, 0.045,
                          0.04, 0.04), a["torso"], 0.0, 0.3 * side)


def rod_legs(c: float, a: dict, k: float) -> list:
    """Straight legs from hip to a flat shoe that slides FOOT_LIFT above the ground in swing,
    and the arms (the plain walker)."""
    L, hip = a["step_length_m"], 0.9 * k
    parts = []
    for side, (rel, lift) in zip((1.0, -1.0), walker_feet(c, L)):
        rel, lift = float(rel), float(lift)
        lat, fz = 0.05 * side, FOOT_LIFT * lift  # step width 0.1 m; toe clearance a few cm
        parts.append(("hull", _limb((0.0, 1.8 * lat, hip), (rel, lat, fz + 0.07), 0.075, 0.065,
                                    0.05, 0.045), a["legs"], 0.0, lat))
        parts.append(("hull", _box(rel - 0.12, rel + 0.12, lat - 0.04, lat + 0.04, fz, fz + 0.08),
                      a["shoes"], 0.0, lat))
        parts.append(_arm(rel, side, k, a))
    return parts


def articulated_legs(c: float, a: dict, k: float) -> list:
    """Thigh, shank and a heel-to-toe foot per leg (`sim.legs`), and the arms."""
    L = a["step_length_m"]
    parts = []
    for side, offset in ((1.0, 0.0), (-1.0, 0.5)):
        lat = 0.05 * side
        (hs, hz), (ks, kz), (as_, az), phi = legs.leg_joints(c, offset, L, k)
        parts.append(("hull", _limb((hs, 1.8 * lat, hz), (ks, 1.4 * lat, kz), 0.075, 0.065,
                                    0.06, 0.055), a["legs"], 0.0, lat))
        parts.append(("hull", _limb((ks, 1.4 * lat, kz), (as_, lat, az), 0.06, 0.055, 0.045,
                                    0.04), a["legs"], 0.0, lat))
        parts.append(("hull", legs.foot_points(as_, az, phi, lat), a["shoes"], 0.0, lat))
        parts.append(_arm(as_, side, k, a))
    return parts


def suitcase_parts(a: dict, k: float) -> list:
    """A wheeled suitcase pulled behind a walker (body frame: s forward, l lateral, z up, m):
    0.40 m long, 0.24 m wide, 0.55 m tall, leaning towards the walker (its bottom 0.45-0.85 m
    behind the walker's reference point, its top 0.25 m further forward) on its bag side, and
    its handle up to the walker's hand (0.8 k m high). It translates with the walker and has no
    rhythm of its own (drawn after the dev renderer's trailing suitcase; docs/rules.md, "The
    foot column from the upper body")."""
    sgn = a["bag_side"]
    lat = 0.2 * sgn
    return [("hull", _limb((-0.65, lat, 0.03), (-0.4, lat, 0.58), 0.2, 0.12, 0.2, 0.12),
             a["bag_grey"], 0.0, lat),
            ("hull", _limb((-0.2, 0.27 * sgn, 0.8 * k), (-0.3, lat, 0.58), 0.015, 0.015, 0.015,
                           0.015), a["bag_grey"], 0.0, lat)]


def bicycle_parts(t: float, a: dict) -> list:
    """Parts of a bicycle and its rider at local time t (s); `a` holds speed_mps, cadence_hz,
    phase, grey levels."""
    R, hw = WHEEL_RADIUS, WHEELBASE / 2
    tyre = 0.04
    ang = a["phase"] * 2 * math.pi - a["speed_mps"] * t / R  # rolls without slipping
    crank = a["phase"] * 7.0 + 2 * math.pi * a["cadence_hz"] * t
    circ = np.linspace(0, 2 * math.pi, 24, endpoint=False)
    parts = []
    bb = (0.0, 0.0, BB_HEIGHT)
    seat, head = (-0.22, 0.0, 0.95), (0.42, 0.0, 0.92)
    pedals = [(CRANK * math.cos(crank + ph), CRANK * math.sin(crank + ph)) for ph in (0, math.pi)]
    for side, (ps, pz) in zip((1.0, -1.0), pedals):  # rider's legs
        parts.append(("hull", _limb((seat[0], 0.1 * side, 1.0), (ps, 0.1 * side, BB_HEIGHT + pz),
                                    0.08, 0.06, 0.05, 0.05), a["legs"], 0.0, 0.3 * side))
    for hub in (-hw, hw):
        rr = R - tyre / 2
        ring = np.stack([hub + rr * np.cos(circ), np.zeros_like(circ), R + rr * np.sin(circ)], 1)
        parts.append(("closed", ring, a["tyre"], tyre, 0.0))
        for j in range(3):
            q = ang + j * math.pi / 3
            cs, sn = rr * math.cos(q), rr * math.sin(q)
            parts.append(("open", np.array([[hub - cs, 0, R - sn], [hub + cs, 0, R + sn]]),
                          a["tyre"], 0.008, 0.0))
    frame = np.array([(-hw, 0, R), bb, seat, (-hw, 0, R), seat, head, bb, head, (hw, 0, R)])
    parts.append(("open", frame, a["frame"], 0.035, 0.0))
    torso = np.concatenate([_box(-0.32, -0.08, -0.2, 0.2, 0.98, 1.1),
                            _box(0.08, 0.3, -0.2, 0.2, 1.45, 1.58)])  # leaning forward
    parts.append(("hull", torso, a["torso"], 0.0, 0.0))
    parts.append(("hull", _box(0.18, 0.38, -0.08, 0.08, 1.6, 1.82), a["head"], 0.0, 0.0))
    for side in (1.0, -1.0):
        parts.append(("open", np.array([(0.2, 0.2 * side, 1.5), (0.45, 0.2 * side, 1.0)]),
                      a["torso"], 0.07, 0.35 * side))
    return parts


DOG_LEGS = ((0.4, 1.0, 0.0), (0.4, -1.0, 0.5), (-0.4, 1.0, 0.5), (-0.4, -1.0, 0.0))  # s, side, o


def dog_feet(c, step_length: float):
    return [gait(c, o, DOG_SWING, step_length)[:2] for _, _, o in DOG_LEGS]


def dog_parts(c: float, a: dict) -> list:
    """Parts of a trotting dog at gait cycle c; `a` holds body_length_m, height_m, grey."""
    Lb, H = a["body_length_m"], a["height_m"]
    parts = []
    for (fs, side, _), (rel, lift) in zip(DOG_LEGS, dog_feet(c, a["step_length_m"])):
        s0, lat = fs * Lb, 0.07 * side
        parts.append(("hull", _limb((s0, lat, 0.66 * H), (s0 + float(rel), lat,
                                                            0.05 * float(lift)),
                                    0.045, 0.035, 0.03, 0.03), a["legs"], 0.0, 0.3 * side))
    parts.append(("hull", _box(-Lb / 2, Lb / 2, -0.11, 0.11, 0.6 * H, H), a["torso"], 0.0, 0.0))
    parts.append(("hull", _box(Lb / 2 - 0.05, Lb / 2 + 0.18, -0.07, 0.07, 0.8 * H, 1.25 * H),
                  a["head"], 0.0, 0.0))
    parts.append(("open", np.array([(-Lb / 2, 0, 0.95 * H), (-Lb / 2 - 0.2, 0, 1.1 * H)]),
                  a["torso"], 0.03, 0.0))
    return parts


def object_parts(kind: str, t: float, a: dict) -> list:
    """Parts of any actor at local time t (s)."""
    c = a["pace_hz"] * t / 2.0 + a["phase"]
    if kind == "pedestrian":
        return walker_parts(c, a)
    if kind == "dog":
        return dog_parts(c, a)
    return bicycle_parts(t, a)


def contact_offset(kind: str, t: np.ndarray, a: dict) -> np.ndarray:
    """Along-track offset (m) of the truth foot point from the body reference at local times t:
    the midpoint of the feet for walkers, the mean of the four feet for dogs, 0 for bicycles
    (the midpoint between the wheels' ground contacts)."""
    c = a["pace_hz"] * np.asarray(t, np.float64) / 2.0 + a["phase"]
    if kind == "pedestrian" and a.get("articulated", False):
        return np.mean([legs.ankle(c, o, a["step_length_m"])[0] for o in (0.0, 0.5)], axis=0)
    if kind == "pedestrian":
        return np.mean([r for r, _ in walker_feet(c, a["step_length_m"])], axis=0)
    if kind == "dog":
        return np.mean([r for r, _ in dog_feet(c, a["step_length_m"])], axis=0)
    return np.zeros_like(c)


EXTENT = {"pedestrian": (0.5, 1.8), "bicycle": (1.0, 1.9), "dog": (0.6, 0.7)}  # half-width, height


CLOTHING = ("contrasted", "any")  # `sample_params`' clothing grey levels


def _grey_pair(rng, clothing: str = "contrasted") -> tuple[int, int]:
    """Two clothing grey levels (torso, legs). "contrasted": each clearly darker (20-80) or
    lighter (165-235) than the ground (~120); "any": each uniform in 20-235, so about one in five
    lies within 20 grey levels of the ground (below the counting mask's threshold)."""
    if clothing == "any":
        return tuple(int(rng.uniform(20, 235)) for _ in range(2))
    if clothing != "contrasted":
        raise ValueError(f"clothing must be one of {CLOTHING}, got {clothing!r}")
    return tuple(int(rng.uniform(20, 80) if rng.random() < 0.6 else rng.uniform(165, 235))
                 for _ in range(2))


def sample_params(kind: str, rng, bicycle_speed, bag_fraction,
                  clothing: str = "contrasted", suitcase_fraction: float = 0.0) -> dict:
    """Random ActorSpec keyword arguments of one actor of `kind` (see `synth.random_spec`);
    `clothing` as `_grey_pair`'s. A walker pulls a suitcase with probability
    `suitcase_fraction`, drawn last and only where it is above 0 (scenes without suitcases
    draw the same numbers as before it existed)."""
    torso, legs = _grey_pair(rng, clothing)
    kw = {"grey_torso": torso, "grey_legs": legs, "phase": float(rng.uniform(0, 1)),
          "grey_head": int(rng.uniform(60, 110))}
    if kind == "pedestrian":
        kw.update(pace_hz=float(np.clip(rng.normal(2.05, 0.183), 1.5, 2.6)),
                  step_length_m=float(np.clip(rng.normal(0.72, 0.09), 0.45, 1.0)),
                  height_m=float(np.clip(rng.normal(1.7, 0.08), 1.5, 1.95)),
                  grey_feet=int(rng.uniform(15, 60)), bag=bool(rng.random() < bag_fraction),
                  bag_side=float(rng.choice([-1.0, 1.0])),
                  grey_extra=int(rng.uniform(20, 70) if rng.random() < 0.5
                                 else rng.uniform(170, 230)))
        if suitcase_fraction > 0:
            kw["suitcase"] = bool(rng.random() < suitcase_fraction)
    elif kind == "bicycle":
        speed, cad = rng.uniform(*bicycle_speed), rng.uniform(0.9, 1.5)
        kw.update(pace_hz=2 * cad, step_length_m=speed / (2 * cad), grey_feet=20,
                  grey_extra=int(rng.uniform(150, 230)))
    else:
        kw.update(pace_hz=float(rng.uniform(3.0, 5.0)), step_length_m=float(rng.uniform(0.2, 0.35)),
                  body_length_m=float(rng.uniform(0.6, 0.9)),
                  height_m=float(rng.uniform(0.45, 0.55)))
        kw["grey_legs"] = kw["grey_torso"]
    return kw
