"""Independent float64 NumPy references for the camera model, the EKF and the gates (STYLE R8).

Nothing here imports `rhythmjax`: the references are written again from the paper's equations
(PAPERS.md) so that a shared mistake cannot hide. Arrays are float64 throughout.

- `project_ref`: equation (3) in its expanded form (PAPERS.md, "Signs in (3)");
  `project_paper_ref`: (3) exactly as printed, with sin(theta - pi/2) and cos(theta - pi/2).
- `ground_ref`: inverse perspective by solving the two equations of (3), which are linear in
  (x, y) once (u, v) are fixed, with `np.linalg.solve` (a different route from the library's).
- `ekf_reference`: a plain loop of the EKF (4)-(9) with the library's conventions (first usable
  measurement initialises, Joseph update, NaN or absent measurement -> prediction), the Jacobian
  by central finite differences, and an optional gate object (`PaperGatesRef`) reproducing the
  width gate (10) and the outlier gate (11) with an explicit inverse of P(k|k-1).
- `simulate_tracks`: walkers drawn from exactly the model the filter assumes, for NIS/NEES.
"""

from __future__ import annotations

import math
from dataclasses import astuple, dataclass

import numpy as np


LOG_2PI = math.log(2.0 * math.pi)
EPS_DEPTH = 1e-3  # m; the library treats a depth below this as behind the camera


@dataclass(frozen=True)
class CamRef:
    """Camera of (3) as plain floats, in the argument order of `project_ref`."""

    f: float = 0.008
    h: float = 1.0
    theta: float = math.radians(15.0)
    a: float = 1.0e5
    b: float = 1.0e5
    uc: float = 256.0
    vc: float = 256.0

    def args(self) -> tuple[float, ...]:
        return astuple(self)


def cam_ref_of(camera) -> CamRef:
    """The float64 values of a `rhythmjax.model.params.Camera` (attribute reads only)."""
    return CamRef(*(float(np.asarray(getattr(camera, k))) for k in
                    ("f", "h", "theta", "a", "b", "uc", "vc")))


def project_ref(f, h, theta, a, b, uc, vc, x, y):
    """(3) expanded: u = Uc + a f x / D, v = Vc - b f (y sin(theta) - h cos(theta)) / D,
    D = f + y cos(theta) + h sin(theta)."""
    x, y = np.asarray(x, np.float64), np.asarray(y, np.float64)
    D = f + y * math.cos(theta) + h * math.sin(theta)
    return uc + a * f * x / D, vc - b * f * (y * math.sin(theta) - h * math.cos(theta)) / D


def project_paper_ref(f, h, theta, a, b, uc, vc, x, y):
    """(3) as printed in the paper, with the (theta - pi/2) terms left as they are."""
    x, y = np.asarray(x, np.float64), np.asarray(y, np.float64)
    t = theta - math.pi / 2
    D = f - y * math.sin(t) + h * math.cos(t)
    return uc + a * f * x / D, vc - b * f * (y * math.cos(t) + h * math.sin(t)) / D


def depth_ref(cam: CamRef, y):
    return cam.f + np.asarray(y, np.float64) * math.cos(cam.theta) + cam.h * math.sin(cam.theta)


def horizon_ref(cam: CamRef) -> float:
    """lim_{y -> inf} v of (3) = Vc - b f sin(theta) / cos(theta)."""
    return cam.vc - cam.b * cam.f * math.sin(cam.theta) / math.cos(cam.theta)


def ground_ref(cam: CamRef, u: float, v: float) -> tuple[float, float, bool]:
    """Inverse perspective of one point. With D = f + y c + h s, (3) gives two linear equations
        a f x - (u - Uc) c y = (u - Uc)(f + h s)
        ((Vc - v) c - b f s) y = -(Vc - v)(f + h s) - b f h c,
    solved with `np.linalg.solve`. ok: below the horizon and in front of the camera."""
    s, c = math.sin(cam.theta), math.cos(cam.theta)
    du, dv = u - cam.uc, cam.vc - v
    if not (np.isfinite(u) and np.isfinite(v)) or v <= horizon_ref(cam):
        return 0.0, 0.0, False
    A = np.array([[cam.a * cam.f, -du * c], [0.0, dv * c - cam.b * cam.f * s]])
    fhs, bf = cam.f + cam.h * s, cam.b * cam.f
    rhs = np.array([du * fhs, -dv * fhs - bf * cam.h * c])
    x, y = np.linalg.solve(A, rhs)
    return float(x), float(y), bool(depth_ref(cam, y) > EPS_DEPTH)


def jac_fd(fun, x, eps):
    """Central finite differences of a vector function; `eps` a scalar or one step per input."""
    x = np.asarray(x, np.float64)
    eps = np.broadcast_to(np.asarray(eps, np.float64), x.shape)
    cols = []
    for j in range(x.size):
        e = np.zeros_like(x)
        e[j] = eps[j]
        cols.append((np.asarray(fun(x + e)) - np.asarray(fun(x - e))) / (2 * eps[j]))
    return np.stack(cols, axis=-1)


def measure_ref(cam: CamRef, state):
    u, v = project_ref(*cam.args(), state[0], state[2])
    return np.array([u, v])


def measure_jac_ref(cam: CamRef, state, eps=1e-4):
    """H of (9) by central differences; 1e-4 m steps balance truncation and rounding (~1e-10)."""
    return jac_fd(lambda s: measure_ref(cam, s), state, eps)


def R_ref(r_std, r_corr=0.0):
    s0, s1 = r_std
    return np.array([[s0 * s0, r_corr * s0 * s1], [r_corr * s0 * s1, s1 * s1]])


def F_ref(dt):
    return np.array([[1.0, dt, 0, 0], [0, 1.0, 0, 0], [0, 0, 1.0, dt], [0, 0, 0, 1.0]])


def Q_ref(q_std, dt):
    return np.diag([0.0, q_std[0] ** 2 * dt, 0.0, q_std[1] ** 2 * dt])


def init_ref(cam: CamRef, R, init_speed_std, z):
    """First measurement -> state: position by inverse perspective, covariance J R J^T with J the
    inverse of the 2x2 ground-to-image Jacobian (inverse function theorem); velocity 0."""
    x, y, ok = ground_ref(cam, float(z[0]), float(z[1]))
    if not ok:
        return None
    G = jac_fd(lambda p: np.array(project_ref(*cam.args(), p[0], p[1])), np.array([x, y]), 1e-4)
    J = np.linalg.inv(G)
    pos = J @ R @ J.T
    P = np.diag([0.0, init_speed_std**2, 0.0, init_speed_std**2])
    P[np.ix_([0, 2], [0, 2])] = pos
    return np.array([x, 0.0, y, 0.0]), P


@dataclass(frozen=True)
class PaperGatesRef:
    """(10), (11) and the detection range of Fig. 3, with explicit inverses."""

    cam: CamRef
    width_mean: float = 0.5
    width_std: float = 0.12
    k1: float = 3.0
    k2: float = 3.0
    range_min: float = 3.0
    range_max: float = 20.0

    def width_d2(self, z, width_px) -> float:
        _, y, ok = ground_ref(self.cam, float(z[0]), float(z[1]))
        if not ok or not np.isfinite(width_px):
            return math.nan
        wid = width_px * float(depth_ref(self.cam, y)) / (self.cam.a * self.cam.f)
        return (wid - self.width_mean) ** 2 / self.width_std**2

    def outlier_d2(self, prior_mean, prior_cov, temp_mean) -> float:
        dx = np.asarray(prior_mean) - np.asarray(temp_mean)
        return float(dx @ np.linalg.inv(prior_cov) @ dx)

    def accept_initial(self, z, width_px, init_mean) -> bool:
        """Fig. 3: DETECT -> OBSERVE when the object is inside the detection range; no width
        test there (a too-wide first detection starts a track that is then only predicted)."""
        return bool(self.range_min <= init_mean[2] <= self.range_max)

    def __call__(self, prior_mean, prior_cov, temp_mean, z, width_px) -> bool:
        return bool(self.width_d2(z, width_px) <= self.k1**2
                    and self.outlier_d2(prior_mean, prior_cov, temp_mean) <= self.k2**2)


def _sym(P):
    return 0.5 * (P + P.T)


def ekf_reference(cam: CamRef, q_std, R, init_speed_std, z, width=None, dt=None, present=None,
                  gate=None) -> dict[str, np.ndarray]:
    """The EKF (4)-(9) of one track as a float64 loop; returns per-step arrays named like
    `model.ekf.StepOutput` (mean, cov, pred_mean, innovation, nis, loglik, available, valid,
    started). dt[k] is the interval before step k; `gate` None means every measurement is used."""
    z = np.asarray(z, np.float64)
    T = len(z)
    width = np.full(T, np.nan) if width is None else np.asarray(width, np.float64)
    dt = np.asarray(dt, np.float64)
    present = np.ones(T, bool) if present is None else np.asarray(present, bool)
    R = np.asarray(R, np.float64)
    out = {k: np.zeros((T,) + s) for k, s in (("mean", (4,)), ("cov", (4, 4)),
                                               ("pred_mean", (4,)), ("innovation", (2,)),
                                               ("nis", ()), ("loglik", ()))}
    for k in ("available", "valid", "started"):
        out[k] = np.zeros(T, bool)
    mean, P, started = np.zeros(4), np.eye(4), False
    for k in range(T):
        F = F_ref(dt[k])
        pm, pP = F @ mean, _sym(F @ P @ F.T + Q_ref(q_std, dt[k]))  # (5), (8)
        avail = bool(present[k] and np.all(np.isfinite(z[k])))
        out["pred_mean"][k], out["available"][k] = pm, avail
        if not started:
            init = init_ref(cam, R, init_speed_std, z[k]) if avail else None
            if init is not None and (gate is None or gate.accept_initial(z[k], width[k], init[0])):
                (mean, P), started = init, True
        elif avail:
            H = measure_jac_ref(cam, pm)  # (9)
            nu = z[k] - measure_ref(cam, pm)
            S = H @ pP @ H.T + R
            K = np.linalg.solve(S, H @ pP).T  # (6): K = P H^T S^-1 (S, P symmetric)
            cand = pm + K @ nu  # (4)
            IKH = np.eye(4) - K @ H
            candP = _sym(IKH @ pP @ IKH.T + K @ R @ K.T)  # (7), Joseph form
            nis = float(nu @ np.linalg.solve(S, nu))
            ok = (float(depth_ref(cam, pm[2])) > EPS_DEPTH and np.all(np.isfinite(S))
                  and np.all(np.diag(S) >= np.diag(R) * (1 - 1e-3)))
            valid = bool(ok and (gate is None or gate(pm, pP, cand, z[k], width[k])))
            out["innovation"][k], out["nis"][k], out["valid"][k] = nu, nis, valid
            if valid:
                out["loglik"][k] = -0.5 * (nis + np.linalg.slogdet(S)[1] + 2 * LOG_2PI)
                mean, P = cand, candP
            else:
                mean, P = pm, pP
        else:
            mean, P = pm, pP
        out["mean"][k], out["cov"][k], out["started"][k] = mean, P, started
    return out


def simulate_tracks(rng: np.random.Generator, n: int, T: int, cam: CamRef = CamRef(), *,
                    q_std=(0.4, 0.4), r_std=(1.5, 1.5), r_corr=0.0, init_speed_std=1.0,
                    y0=(7.0, 13.0), x0=(-1.5, 1.5), missing=(0.0, 0.0), dt_jitter=0.0,
                    fps=15.0, width_m=(0.5, 0.05), y_keep=(3.5, 25.0)) -> dict[str, np.ndarray]:
    """Tracks drawn from the filter's own model: X(k) = F X(k-1) + w, w ~ N(0, Q(dt_k)), initial
    velocity ~ N(0, init_speed_std^2), z = h(X) + N(0, R); a fraction ~ U(missing) of each track's
    measurements is NaN (never the first); dt_k = (1 + dt_jitter U(-1, 1)) / fps.
    Tracks leaving y_keep are redrawn. Returns z (n,T,2), width (n,T), dt (n,T), truth (n,T,4)."""
    L = np.linalg.cholesky(R_ref(r_std, r_corr))
    zs, ws, dts, xs = [], [], [], []
    while len(zs) < n:
        dt = (1.0 + dt_jitter * rng.uniform(-1, 1, T)) / fps
        X = np.array([rng.uniform(*x0), rng.normal(0, init_speed_std), rng.uniform(*y0),
                      rng.normal(0, init_speed_std)])
        truth = np.zeros((T, 4))
        for k in range(T):
            if k:
                w = np.sqrt(np.diag(Q_ref(q_std, dt[k]))) * rng.standard_normal(4)
                X = F_ref(dt[k]) @ X + w
            truth[k] = X
        if truth[:, 2].min() < y_keep[0] or truth[:, 2].max() > y_keep[1]:
            continue
        u, v = project_ref(*cam.args(), truth[:, 0], truth[:, 2])
        z = np.stack([u, v], -1) + rng.standard_normal((T, 2)) @ L.T
        w = rng.normal(*width_m) * cam.a * cam.f / depth_ref(cam, truth[:, 2])
        gaps = rng.random(T) < rng.uniform(*missing)
        gaps[0] = False
        z[gaps] = np.nan
        w[gaps] = np.nan
        zs.append(z)
        ws.append(w)
        dts.append(dt)
        xs.append(truth)
    return {"z": np.stack(zs), "width": np.stack(ws), "dt": np.stack(dts), "truth": np.stack(xs)}


def write_clip_and_truth_boxes(scene, folder) -> tuple[str, object]:
    """A rendered scene (`sim.scene.render_scene`) written to `folder` as an MJPG clip
    (scene.avi, 15 fps) and its truth as MOT boxes (gt.txt: 1-based frames, id 1 for walkers
    and 2 for the rest, boxes 3 W tall ending at the true foot row, W the drawn width).
    Returns (video path, gt path)."""
    import cv2

    from rhythmjax.io.mot import write_mot
    from rhythmjax.sim.scene import scene_to_tracks_truth

    path = str(folder / "scene.avi")
    h_px, w_px = scene.frames.shape[1:]
    w = cv2.VideoWriter(path, cv2.VideoWriter_fourcc(*"MJPG"), 15.0, (w_px, h_px), False)
    for f in scene.frames:
        w.write(f)
    w.release()
    c = scene_to_tracks_truth(scene)
    h = 3 * c["width_px"]
    ids = np.where(c["label"] == "pedestrian", 1, 2)
    write_mot(folder / "gt.txt", {"frame": c["frame"] + 1, "id": ids,
                                  "bb_left": c["u"] - c["width_px"] / 2 + 0.5,
                                  "bb_top": c["v"] + 1 - h, "bb_width": c["width_px"],
                                  "bb_height": h})
    return path, folder / "gt.txt"
