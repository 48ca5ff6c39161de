"""Per-point measures of periodic solutions: the columns of ``branches.csv``.

For every dof NAME (SPEC 4.3): ``amp_NAME = (max - min)/2`` over one period,
``max_NAME``, ``min_NAME``, ``rms_NAME`` (RMS of the oscillating part, mean
removed) and ``hK_NAME``, the amplitude ``sqrt(a_K^2 + b_K^2)`` of harmonic K
of the base frequency ``w/nu`` (``h0`` is the mean).
"""

from __future__ import annotations

import numpy as np

from contin.hb import aft
from contin.hb.harmonics import coefficient_blocks, harmonic_amplitudes

__all__ = ["point_measures", "measure_names"]


def measure_names(dof_names, harmonic_columns: int, H: int) -> list[str]:
    """Column names in output order."""
    names = []
    for d in dof_names:
        names += [f"amp_{d}", f"max_{d}", f"min_{d}", f"rms_{d}"]
        names += [f"h{k}_{d}" for k in range(min(H, harmonic_columns) + 1)]
    return names


def extremum_angle(a, b, k, theta: float) -> float:
    """Angle of the extremum of ``sum a_k cos k th + b_k sin k th`` near ``theta``.

    Newton on ``x'(theta) = 0`` from a sampled extremum, which is off by
    ``O((pi/N)^2)``; ``theta`` itself if Newton wanders farther than
    ``pi / max(k)``.
    """
    th = theta
    for _ in range(8):
        c, s = np.cos(k * th), np.sin(k * th)
        d1 = np.sum(k * (b * c - a * s))
        d2 = -np.sum(k * k * (a * c + b * s))
        if d2 == 0.0:
            break
        step = d1 / d2
        th -= step
        if abs(step) < 1e-15:
            break
    return th if abs(th - theta) <= np.pi / max(k.size, 1) else theta


def _polish_extremum(a0, a, b, k, theta, sampled, maximum):
    """Extremum of the Fourier series near ``theta`` (see :func:`extremum_angle`):
    ``max``/``min``/``amp`` exact to rounding, the sampled value if Newton wanders."""
    if k.size == 0:
        return sampled
    th = extremum_angle(a, b, k, theta)
    value = a0 + np.sum(a * np.cos(k * th) + b * np.sin(k * th))
    if th == theta or not np.isfinite(value):
        return sampled
    # Newton converges to the nearby extremum; never report less than the samples show
    return max(value, sampled) if maximum else min(value, sampled)


def point_measures(u: np.ndarray, n_dof: int, dof_names, harmonic_columns: int = 5, samples: int | None = None) -> dict:
    """Measures of one solution.

    Parameters
    ----------
    u : ndarray, shape (n(2H+1),)
    n_dof : int
    dof_names : sequence of str
    harmonic_columns : int
        Highest harmonic K reported as ``hK_NAME`` (capped at H).
    samples : int, optional
        Time samples used for max/min (default ``max(256, 8H)``): extrema of
        a truncated Fourier series lie between samples.
    """
    # a writable copy: a read-only array (a stored branch's view) would make numba compile a second
    # specialisation of the transform on a cold cache
    U = np.array(coefficient_blocks(u, n_dof), dtype=float, order="C")
    H = (U.shape[0] - 1) // 2
    N = samples or max(256, 8 * H + 1)
    x, _ = aft.synthesize(U, N)
    amps = harmonic_amplitudes(u, n_dof)
    out = {}
    ks = np.arange(1, H + 1)
    for i, d in enumerate(dof_names):
        xi = x[:, i]
        a, b = U[1::2, i], U[2::2, i]
        hi = _polish_extremum(U[0, i], a, b, ks, 2 * np.pi * np.argmax(xi) / N, xi.max(), True)
        lo = _polish_extremum(U[0, i], a, b, ks, 2 * np.pi * np.argmin(xi) / N, xi.min(), False)
        out[f"amp_{d}"] = 0.5 * (hi - lo)
        out[f"max_{d}"] = hi
        out[f"min_{d}"] = lo
        # Parseval: RMS of the oscillating part from the coefficients (exact)
        out[f"rms_{d}"] = float(np.sqrt(0.5 * np.sum(amps[1:, i] ** 2)))
        for k in range(min(H, harmonic_columns) + 1):
            out[f"h{k}_{d}"] = amps[k, i]
    return out
