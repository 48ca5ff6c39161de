"""Per-point measures of periodic solutions: the columns of ``branches.csv``.

For every dof NAME (SPEC 4.3): ``amp_NAME = (max - min)/2`` over one period,
``max_NAME``, ``min_NAME``, ``rms_NAME`` (RMS of the oscillating part, mean
removed) and ``hK_NAME``, the amplitude ``sqrt(a_K^2 + b_K^2)`` of harmonic K
of the base frequency ``w/nu`` (``h0`` is the mean).
"""

from __future__ import annotations

import numpy as np

from contin import aft
from contin.harmonics import coefficient_blocks, harmonic_amplitudes

__all__ = ["point_measures", "measure_names"]


def measure_names(dof_names, harmonic_columns: int, H: int) -> list[str]:
    """Column names in output order."""
    names = []
    for d in dof_names:
        names += [f"amp_{d}", f"max_{d}", f"min_{d}", f"rms_{d}"]
        names += [f"h{k}_{d}" for k in range(min(H, harmonic_columns) + 1)]
    return names


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
    U = np.ascontiguousarray(coefficient_blocks(u, n_dof))
    H = (U.shape[0] - 1) // 2
    N = samples or max(256, 8 * H + 1)
    x, _ = aft.synthesize(U, N)
    amps = harmonic_amplitudes(u, n_dof)
    out = {}
    for i, d in enumerate(dof_names):
        xi = x[:, i]
        out[f"amp_{d}"] = 0.5 * (xi.max() - xi.min())
        out[f"max_{d}"] = xi.max()
        out[f"min_{d}"] = xi.min()
        # Parseval: RMS of the oscillating part from the coefficients (exact)
        out[f"rms_{d}"] = float(np.sqrt(0.5 * np.sum(amps[1:, i] ** 2)))
        for k in range(min(H, harmonic_columns) + 1):
            out[f"h{k}_{d}"] = amps[k, i]
    return out
