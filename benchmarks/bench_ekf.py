"""Throughput of the batched EKF (`rhythmjax.model.ekf_fused.filter_batch`, the per-entry kernel,
float32, jit + vmap) against the readable `rhythmjax.model.ekf.filter_batch` (the same filter in
4x4 matrix form), filterpy's `ExtendedKalmanFilter` (one Python object per track) and dynamax's
`extended_kalman_filter` (jit + vmap), on synthetic walkers of T = 64 steps.

    python benchmarks/bench_ekf.py [--quick] [--sizes 1 64 ...]
    JAX_PLATFORMS=cuda python benchmarks/bench_ekf.py   # on a GPU (peers' rows stay on CPU)

Prints a markdown table: track-steps per second (best warm call) of the fused kernel ("ours")
and of the readable filter (means + covariances), with the outputs dynamax is
asked for (filtered means and covariances per step: the ratios use this rate) and with every
output of `FilterOutput` (predictions, innovations, NIS, log-likelihood, gate flags as well),
then a second like-for-like pair with the filtered means alone (what classification uses;
dynamax asked for `filtered_means` only), compile time (trace + lower + compile, timed apart),
the ratios ours/filterpy and ours/dynamax, and achieved GFLOP/s from the flop count of one EKF
step against the machine's measured float32 matmul rate (on a GPU that column compares with
the host's CPU, so it means nothing there). filterpy
is timed on at most 64 tracks (its cost is linear in the number of tracks; the rate is per
track-step). dynamax is optional: it is skipped with a message when it does not import.
Timings on a shared machine vary with its load; the load average is printed with them.

All three run the same model: camera (3) with Table 1 values, constant-velocity state (1),
q = 0.4 m/s/sqrt(s), R = 1.5^2 px^2, no missing measurements (dynamax has no NaN handling).
Ours starts every track from its first measurement and updates with the other 63; filterpy and
dynamax start from our step-0 state and update with the same 63 measurements.
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import time
import warnings


os.environ.setdefault("JAX_PLATFORMS", "cpu")

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from rhythmjax.model import ekf, ekf_fused
from rhythmjax.model.params import Camera, Noise


T, FPS, Q_STD, R_STD = 64, 15.0, 0.4, 1.5
AF, S15, C15, F_M, H_M, UC, VC = 800.0, math.sin(math.radians(15)), math.cos(math.radians(15)), \
    0.008, 1.0, 256.0, 256.0
SIZES = (1, 64, 1024, 16384)
FILTERPY_MAX_TRACKS = 64

# Flops of one tracked step of `ekf_fused.filter_track` as now written (entry by entry, structural
# zeros of F, H and I - K H skipped; a multiply-add counts 2): the arithmetic floor per step.
FLOPS = {
    "predict: F x and F P F^T + Q on the 10 upper entries": 4 + 29,
    "h(x) of (3) and its 4 non-zero H entries (two jvps)": 15 + 20,
    "P H^T (4x2) and H P H^T (2x2, 3 entries), S = . + R": 24 + 9 + 3,
    "det, closed-form S^-1, checks": 12,
    "K = P H^T S^-1 (4x2)": 24,
    "innovation and mean update": 2 + 16,
    "I - K H (8 non-trivial entries)": 32,
    "(I - K H) P (4x4, 2-3 terms each)": 56,
    "Joseph: (.) (I - K H)^T + K R K^T, 10 upper entries": 24 + 10 * 8,
    "NIS and log-likelihood": 12,
    "select (where over 14 entries) and outputs": 14,
}
FLOPS_PER_STEP = sum(FLOPS.values())


def walkers(n: int, rng: np.random.Generator) -> dict[str, np.ndarray]:
    """n walkers (x, y in m) at 1.2 m/s in random directions, 6-14 m ahead; (u, v) by (3)."""
    t = np.arange(T) / FPS
    heading = rng.uniform(-np.pi, np.pi, (n, 1))
    x = rng.uniform(-1.5, 1.5, (n, 1)) + 1.2 * np.cos(heading) * t
    y = rng.uniform(6.0, 14.0, (n, 1)) + 1.2 * np.sin(heading) * t
    D = F_M + y * C15 + H_M * S15
    u = UC + AF * x / D + R_STD * rng.standard_normal((n, T))
    v = VC - AF * (y * S15 - H_M * C15) / D + R_STD * rng.standard_normal((n, T))
    return {"z": np.stack([u, v], -1).astype(np.float32),
            "width": (AF * 0.5 / D).astype(np.float32),
            "dt": np.full((n, T), 1.0 / FPS, np.float32)}


def timed(jitted, args, repeats: int) -> tuple[float, float]:
    """(trace + lower + compile, best of `repeats` warm calls) in seconds."""
    t0 = time.perf_counter()
    jitted.lower(*args).compile()
    compile_s = time.perf_counter() - t0
    jax.block_until_ready(jitted(*args))  # warm-up (fills the call cache)
    best = math.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        jax.block_until_ready(jitted(*args))
        best = min(best, time.perf_counter() - t0)
    return compile_s, best


@eqx.filter_jit
def _means_and_covs(*args):
    """What dynamax's filter is asked for: the filtered means and covariances per step (XLA
    drops the rest of `FilterOutput`)."""
    out = ekf_fused.filter_batch(*args)
    return out.steps.mean, out.steps.cov


@eqx.filter_jit
def _readable_means_and_covs(*args):
    """`_means_and_covs` of the readable filter, `ekf.filter_batch`."""
    out = ekf.filter_batch(*args)
    return out.steps.mean, out.steps.cov


@eqx.filter_jit
def _means(*args):
    """The filtered means alone (XLA drops the rest)."""
    return ekf_fused.filter_batch(*args).steps.mean


def bench_ours(data, repeats):
    """(compile s, best s for means + covariances, best s for the whole `FilterOutput`, best s
    for the means, best s for the readable filter's means + covariances, output)."""
    z, w, dt = (jnp.asarray(data[k]) for k in ("z", "width", "dt"))
    present = jnp.ones(z.shape[:2], bool)
    args = (Camera(), Noise(q_std=(Q_STD, Q_STD), r_std=(R_STD, R_STD)), ekf.FromAnnotations(),
            z, w, dt, present)
    compile_s, best = timed(_means_and_covs, args, repeats)
    _, best_full = timed(ekf_fused.filter_batch, args, repeats)
    _, best_means = timed(_means, args, repeats)
    _, best_readable = timed(_readable_means_and_covs, args, repeats)
    return (compile_s, best, best_full, best_means, best_readable,
            ekf_fused.filter_batch(*args))


# -- filterpy -------------------------------------------------------------------------------------

def _h(x):
    D = F_M + x[2, 0] * C15 + H_M * S15
    return np.array([[UC + AF * x[0, 0] / D], [VC - AF * (x[2, 0] * S15 - H_M * C15) / D]])


def _H(x):
    D = F_M + x[2, 0] * C15 + H_M * S15
    dD = C15
    num = x[2, 0] * S15 - H_M * C15
    return np.array([[AF / D, 0.0, -AF * x[0, 0] * dD / D**2, 0.0],
                     [0.0, 0.0, -AF * (S15 * D - num * dD) / D**2, 0.0]])


def bench_filterpy(data, init_mean, init_cov):
    from filterpy.kalman import ExtendedKalmanFilter

    n = min(len(data["z"]), FILTERPY_MAX_TRACKS)
    dt = 1.0 / FPS
    F = np.array([[1, dt, 0, 0], [0, 1, 0, 0], [0, 0, 1, dt], [0, 0, 0, 1]], float)
    Q = np.diag([0.0, Q_STD**2 * dt, 0.0, Q_STD**2 * dt])
    R = np.eye(2) * R_STD**2
    z = data["z"].astype(np.float64)
    means = np.zeros((n, 4))
    t0 = time.perf_counter()
    for i in range(n):
        kf = ExtendedKalmanFilter(dim_x=4, dim_z=2)
        kf.x, kf.P, kf.F, kf.Q, kf.R = init_mean[i][:, None].copy(), init_cov[i].copy(), F, Q, R
        for k in range(1, T):
            kf.predict()
            kf.update(z[i, k][:, None], _H, _h)
        means[i] = kf.x[:, 0]
    return time.perf_counter() - t0, n, means


# -- dynamax --------------------------------------------------------------------------------------

def make_dynamax():
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            from dynamax.nonlinear_gaussian_ssm import ParamsNLGSSM, extended_kalman_filter
    except Exception as e:  # noqa: BLE001 - any import failure means "skip"
        return None, f"dynamax skipped: {type(e).__name__}: {e}"
    dt = 1.0 / FPS
    F = jnp.array([[1, dt, 0, 0], [0, 1, 0, 0], [0, 0, 1, dt], [0, 0, 0, 1]], jnp.float32)
    Q = jnp.diag(jnp.array([0.0, Q_STD**2 * dt, 0.0, Q_STD**2 * dt], jnp.float32))
    R = jnp.eye(2, dtype=jnp.float32) * R_STD**2

    def h(x):
        D = F_M + x[2] * C15 + H_M * S15
        return jnp.stack([UC + AF * x[0] / D, VC - AF * (x[2] * S15 - H_M * C15) / D])

    def one(m0, P0, ys, fields=("filtered_means", "filtered_covariances")):
        # dynamax conditions on ys[0] first: give it our step-0 state predicted one step
        params = ParamsNLGSSM(F @ m0, F @ P0 @ F.T + Q, lambda x: F @ x, Q, h, R)
        post = extended_kalman_filter(params, ys, output_fields=list(fields))
        return tuple(getattr(post, f) for f in fields)

    means_only = lambda m0, P0, ys: one(m0, P0, ys, ("filtered_means",))
    return (jax.jit(jax.vmap(one)), jax.jit(jax.vmap(means_only))), None


def matmul_gflops() -> float:
    """Measured float32 GEMM rate of this machine (NumPy/BLAS, all cores, best of 6): a
    practical peak. The nominal peak of 2 AVX-512 cores at ~2.5 GHz is 2 x 2.5e9 x 2 FMA units
    x 16 lanes x 2 = 320 GFLOP/s."""
    a = np.random.default_rng(0).standard_normal((2048, 2048)).astype(np.float32)
    best = math.inf
    for _ in range(6):
        t0 = time.perf_counter()
        a @ a
        best = min(best, time.perf_counter() - t0)
    return 2 * 2048**3 / best / 1e9


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="sizes 1 and 64 only")
    parser.add_argument("--sizes", type=int, nargs="+", help=f"batch sizes (default {SIZES})")
    opts = parser.parse_args()
    sizes = opts.sizes or (SIZES[:2] if opts.quick else SIZES)
    rng = np.random.default_rng(0)
    dynamax_runs, dynamax_msg = make_dynamax()
    dynamax_run, dynamax_means = dynamax_runs or (None, None)
    peak = matmul_gflops()
    print(f"# EKF throughput, T = {T} steps, float32, {platform.processor() or platform.machine()}"
          f", {os.cpu_count()} cores, jax {jax.__version__} ({jax.default_backend()}), load"
          f" average {os.getloadavg()[0]:.1f} at start")
    print(f"flops per EKF step (counted, see FLOPS): {FLOPS_PER_STEP}; measured float32 GEMM"
          f" rate (practical peak): {peak:.0f} GFLOP/s")
    if dynamax_msg:
        print(dynamax_msg)
    rows, checks = [], []
    for n in sizes:
        data = walkers(n, rng)
        repeats = 5  # best of 5: a shared machine's load spikes hit single calls
        compile_s, best, best_full, best_means, best_readable, out = bench_ours(data, repeats)
        ours_rate = n * T / best
        init_mean = np.asarray(out.steps.mean[:, 0], np.float64)
        init_cov = np.asarray(out.steps.cov[:, 0], np.float64)
        fp_time, fp_n, fp_means = bench_filterpy(data, init_mean, init_cov)
        fp_rate = fp_n * (T - 1) / fp_time
        ours_last = np.asarray(out.steps.mean[:fp_n, -1], np.float64)
        checks.append(("filterpy", n, np.abs(ours_last - fp_means).max()))
        row = {"n": n, "ours": ours_rate, "full": n * T / best_full, "compile": compile_s,
               "means": n * T / best_means, "dyn_means": None,
               "readable": n * T / best_readable,
               "filterpy": fp_rate,
               "fp_n": fp_n, "dynamax": None, "dyn_compile": None}
        if dynamax_run is not None:
            args = (jnp.asarray(init_mean, jnp.float32), jnp.asarray(init_cov, jnp.float32),
                    jnp.asarray(data["z"][:, 1:]))
            d_compile, d_best = timed(dynamax_run, args, repeats)
            row["dynamax"], row["dyn_compile"] = n * (T - 1) / d_best, d_compile
            row["dyn_means"] = n * (T - 1) / timed(dynamax_means, args, repeats)[1]
            dm = np.asarray(dynamax_run(*args)[0][:, -1], np.float64)
            checks.append(("dynamax", n, np.abs(np.asarray(out.steps.mean[:, -1]) - dm).max()))
        rows.append(row)
    print()
    print("| tracks | ours, means + covs (track-steps/s) | ours, all outputs | ours compile (s) "
          "| readable ekf, means + covs | ours/readable "
          "| filterpy (track-steps/s) | dynamax (track-steps/s) | dynamax compile (s) "
          "| ours/filterpy | ours/dynamax | ours GFLOP/s | % of GEMM rate |")
    print("|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        dyn = f"{r['dynamax']:.3g}" if r["dynamax"] else "skipped"
        dync = f"{r['dyn_compile']:.2f}" if r["dynamax"] else "-"
        ratio_d = f"{r['ours'] / r['dynamax']:.2f}" if r["dynamax"] else "-"
        gflops = r["ours"] * FLOPS_PER_STEP / 1e9
        print(f"| {r['n']} | {r['ours']:.3g} | {r['full']:.3g} | {r['compile']:.2f} | "
              f"{r['readable']:.3g} | {r['ours'] / r['readable']:.1f} | "
              f"{r['filterpy']:.3g}"
              f" ({r['fp_n']} tracks timed) | {dyn} | {dync} | {r['ours'] / r['filterpy']:.1f}"
              f" | {ratio_d} | {gflops:.3f} | {100 * gflops / peak:.2f} |")
    print()
    print("Filtered means alone, like for like:")
    print()
    print("| tracks | ours (track-steps/s) | dynamax (track-steps/s) | ours/dynamax |")
    print("|---:|---:|---:|---:|")
    for r in rows:
        dyn = f"{r['dyn_means']:.3g}" if r["dyn_means"] else "skipped"
        ratio_d = f"{r['means'] / r['dyn_means']:.2f}" if r["dyn_means"] else "-"
        print(f"| {r['n']} | {r['means']:.3g} | {dyn} | {ratio_d} |")
    print()
    for name, n, err in checks:
        print(f"agreement at the last step, {n} tracks: max |ours - {name}| = {err:.2e} m or m/s")


if __name__ == "__main__":
    main()
