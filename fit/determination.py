"""What every `rhythmjax-fit` camera fit reports beside its values: the parameter names and
units (`NAMES`, `UNITS`), when a standard error means a parameter is determined by the data
(`se_limits`, `determination`), the lines printed first (`value_lines`), and MINPACK's
stationarity test for a fit stopped at its step limit (`stationarity`, `GTOL`). Shared by
`fit.camera` (footprints) and `fit.selfcal` (walkers)."""

from __future__ import annotations

import math

import numpy as np


NAMES = ("af", "bf", "h", "theta", "uc", "vc", "roll", "tx", "ty", "yaw")
UNITS = {"af": "px", "bf": "px", "h": "m", "theta": "deg", "uc": "px", "vc": "px",
         "roll": "deg", "tx": "m", "ty": "m", "yaw": "deg"}
WORLD = ("tx", "ty", "yaw")


def se_limits(values: dict[str, float]) -> dict[str, float]:
    """The standard error (`UNITS`) beyond which a fitted parameter is not determined."""
    return {"h": 0.5 * values["h"], "theta": 10.0, "af": 0.5 * values["af"],
            "bf": 0.5 * values["bf"], "uc": 200.0, "vc": 200.0, "roll": 10.0, "tx": 50.0,
            "ty": 50.0, "yaw": 20.0}


def determination(fitted, values: dict[str, float], se: dict[str, float], cond: float,
                  weak_direction: str) -> dict[str, str]:
    """Per fitted parameter: "determined" (SE at most a tenth of `se_limits`), "weak" (up to the
    limit) or "not determined" (beyond it, non-finite, or in the named singular direction
    `weak_direction` of a Jacobian with condition number `cond` above 1e8). `values` may leave
    out parameters that were not fitted."""
    lim = se_limits({**{k: 0.0 for k in NAMES}, **values})
    singular = weak_direction.split()[1::2] if cond > 1e8 else []
    return {k: "not determined" if not se[k] <= lim[k] or k in singular else
            "determined" if se[k] <= 0.1 * lim[k] else "weak" for k in fitted}


def value_lines(fitted, values: dict[str, float], se: dict[str, float],
                det: dict[str, str]) -> list[str]:
    """The lines `rhythmjax-fit` prints first: each fitted value with its SE and unit, then
    which are determined, weakly determined and not determined (`determination`'s `det`)."""
    lines = [f"{k:6s} = {values[k]:11.4f} +- {se[k]:.4f} {UNITS[k]}" for k in fitted]
    for what, head in (("determined", "determined by the data"),
                       ("weak", "weakly determined (SE over 1/10 of its limit)"),
                       ("not determined", "NOT determined")):
        names = [k + (f" (SE {se[k]:.3g} {UNITS[k]})" if what != "determined" else "")
                 for k in fitted if det[k] == what]
        if names or what == "determined":
            lines.append(f"{head}: {', '.join(names) or '-'}")
    return lines


GTOL = 1e-8  # the orthogonality test of MINPACK's gtol: a stationary point of the squared sum


def stationarity(J: np.ndarray, r: np.ndarray) -> float:
    """Largest |cosine| between the residual vector and a Jacobian column (0 at a least-squares
    stationary point, whatever the parameters' scales)."""
    norms = np.linalg.norm(J, axis=0) * np.linalg.norm(r)
    with np.errstate(all="ignore"):
        cos = np.abs(J.T @ r) / np.where(norms > 0, norms, 1.0)
    return float(np.max(cos)) if np.all(np.isfinite(cos)) else math.inf
