"""Float64 NumPy references for `model.mem`, written from the textbook (Marple 1987, ch. 8;
Kaveh & Lippert 1983 for the tapers); shares no code with the library."""

import numpy as np


def taper_reference(name: str, length: int) -> np.ndarray:
    """Weights on the `length` error products of one Burg stage."""
    j = np.arange(length, dtype=np.float64)
    if name == "none":
        return np.ones(length)
    if name == "hamming":
        return 0.54 - 0.46 * np.cos(2 * np.pi * j / max(length - 1, 1))
    if name == "parabolic":
        return (j + 1) * (length - j)
    raise ValueError(name)


def burg_reference(x, order: int, window: str = "none", demean: bool = True):
    """Burg AR(order): returns (a, sigma2, sigma2_fb, reflection), all float64.

    x[t] + sum_k a_k x[t-k] = e[t]; sigma2 = mean(x^2) prod (1 - k^2) (Marple, spectrum's rho);
    sigma2_fb = sum of the final forward and backward errors squared / (2 (N - order))."""
    x = np.asarray(x, dtype=np.float64)
    if demean:
        x = x - x.mean()
    n = len(x)
    fwd = x.copy()  # fwd[i] = f_m[m + i]
    bwd = x.copy()  # bwd[i] = b_m[m + i]
    a = np.zeros(0)
    refl = []
    e = np.dot(x, x) / n
    for m in range(1, order + 1):
        f_now = fwd[1:]  # f_{m-1}[t], t = m..n-1
        b_lag = bwd[:-1]  # b_{m-1}[t-1]
        w = taper_reference(window, n - m)
        k = -2.0 * np.sum(w * f_now * b_lag) / np.sum(w * (f_now**2 + b_lag**2))
        fwd, bwd = f_now + k * b_lag, b_lag + k * f_now
        a = np.concatenate([a + k * a[::-1], [k]])
        e *= 1.0 - k * k
        refl.append(k)
    sigma2_fb = (np.sum(fwd**2) + np.sum(bwd**2)) / (2.0 * (n - order))
    return a, e, sigma2_fb, np.array(refl)


def psd_reference(a, sigma2, freqs, dt):
    """sigma2 dt / |1 + sum_k a_k exp(-2 pi i f k dt)|^2 with complex float64 arithmetic."""
    a = np.asarray(a, np.float64)
    k = np.arange(1, len(a) + 1)
    z = np.exp(-2j * np.pi * np.outer(np.asarray(freqs, np.float64), k) * dt)
    return sigma2 * dt / np.abs(1.0 + z @ a) ** 2


def stable_ar(rng, order: int, r_max: float = 0.95) -> np.ndarray:
    """Random stable AR(order) coefficients a (x[t] + sum a_k x[t-k] = e[t]) from random roots."""
    n_pairs = order // 2
    r = rng.uniform(0.3, r_max, n_pairs)
    th = rng.uniform(0.1, np.pi - 0.1, n_pairs)
    roots = list(r * np.exp(1j * th)) + list(r * np.exp(-1j * th))
    if order % 2:
        roots.append(rng.uniform(-r_max, r_max))
    return np.real(np.poly(roots))[1:]


def simulate_ar(rng, a, n: int, burn: int = 200) -> np.ndarray:
    """n samples of x[t] = -sum_k a_k x[t-k] + e[t], e ~ N(0, 1), after a burn-in."""
    p = len(a)
    x = np.zeros(n + burn + p)
    e = rng.standard_normal(n + burn + p)
    for t in range(p, len(x)):
        x[t] = e[t] - np.dot(a, x[t - p : t][::-1])
    return x[-n:]


def segment_burg_reference(x, known, order: int, window: str = "none", run_taper: bool = False):
    """Burg AR(order) pooled over the runs of known samples (de Waele & Broersen 2000, "The
    Burg algorithm for segments"): returns (a, sigma2, sigma2_fb, reflection), float64.

    The mean is that of the known samples; each run keeps its own forward and backward errors;
    k_m = -2 sum w f b / sum w (f^2 + b^2) over every run's stage-m products, each product
    weighted by the whole window's taper at its position (`taper_reference(window, N - m)`; with
    `run_taper`, by its run's own: `taper_reference(window, run length - m)` at its index);
    k_m = 0 when no run is longer than m. sigma2 = mean of the known x^2 times prod (1 - k^2);
    sigma2_fb: the final errors squared summed over the runs / (2 their number), 0 when no run
    is longer than the order."""
    x = np.asarray(x, np.float64)
    known = np.asarray(known, bool)
    n = len(x)
    x = np.where(known, x - x[known].mean(), 0.0)
    runs, start = [], None
    for t in range(n + 1):
        if t < n and known[t]:
            start = t if start is None else start
        elif start is not None:
            runs.append((start, t))
            start = None
    fwd = {r: x[r[0]:r[1]].copy() for r in runs}  # fwd[r][i] = f_m[r0 + m + i]
    bwd = {r: x[r[0]:r[1]].copy() for r in runs}
    a, refl = np.zeros(0), []
    e = np.sum(x[known] ** 2) / known.sum()
    for m in range(1, order + 1):
        taper = taper_reference(window, n - m)
        num = den = 0.0
        for r in runs:
            if len(fwd[r]) < 2:
                continue
            pos = r[0] + m + np.arange(len(fwd[r]) - 1)  # global positions of the products
            w = taper_reference(window, len(pos)) if run_taper else taper[pos - m]
            num += np.sum(w * fwd[r][1:] * bwd[r][:-1])
            den += np.sum(w * (fwd[r][1:] ** 2 + bwd[r][:-1] ** 2))
        k = -2.0 * num / den if den > 0 else 0.0
        for r in runs:
            f_now, b_lag = fwd[r][1:], bwd[r][:-1]
            fwd[r], bwd[r] = f_now + k * b_lag, b_lag + k * f_now
        a = np.concatenate([a + k * a[::-1], [k]])
        e *= 1.0 - k * k
        refl.append(k)
    count = sum(len(fwd[r]) for r in runs)
    total = sum(np.sum(fwd[r] ** 2) + np.sum(bwd[r] ** 2) for r in runs)
    sigma2_fb = total / (2.0 * count) if count else 0.0
    return a, e, sigma2_fb, np.array(refl)
