"""What a row of ``branches.csv`` says of a torus computed as an invariant circle.

The circle :mod:`contin.timedomain.invariant_circle` holds the torus' section
at forcing phase zero, ``u(phi)`` at ``phi_j = 2 pi j / N``. The trajectory
from ``u(phi_j)`` runs on the torus at the angles

    theta1 = w t,        theta2 = phi_j + r w t,        r = rho + winding,

(``winding`` the problem's: ``w2 = |r| w`` its second frequency; a negative
``r`` is read with ``phi`` and ``theta2`` reversed, so ``w2 >= 0``), so the ``N``
trajectories over one forcing period, sampled on the integrator's step grid,
sample the torus function ``X(theta1, theta2)`` on a sheared grid that covers
its fundamental domain once. The amplitude of the pair ``(k1, k2)``, the line
at ``k1 w + k2 w2``, is twice the modulus of

    c(k1, k2) = mean over j and t of  x_j(t) exp(-i (k1 theta1 + k2 theta2)),

exact for the trigonometric polynomial the circle is (the mean over ``phi``
at fixed ``t`` is that of a trigonometric polynomial of degree below ``N``;
what remains is a periodic function of ``t``, averaged by the trapezoidal
rule). The extremes are those of the samples: exact trajectories, no
truncated series. ``forced``, ``free`` and ``comb`` are the pairs ``(1, 0)``,
``(0, 1)`` and ``(1, -1)`` as for the two-frequency balance
(:data:`contin.hb.torus.COMPONENTS`): lines at ``w``, ``w2`` and
``w - w2``.
"""

from __future__ import annotations

import math

import numpy as np

from contin.hb.torus import COMPONENTS

__all__ = ["circle_line", "circle_measures", "circle_surface", "circle_whirl", "strongest_winding"]


def circle_surface(problem, u, lam: float) -> tuple[np.ndarray, np.ndarray, float]:
    """The trajectories from the circle's points over one forcing period, on the step grid.

    Parameters
    ----------
    problem : InvariantCircleProblem
    u : array_like, shape (problem.size,)
    lam : float

    Returns
    -------
    X : ndarray, shape (N, S, 2n)
        The state of the trajectory from point ``j`` at ``t_k = k T / S`` (``S`` the steps a period).
    theta1 : ndarray, shape (S,)
        ``w t_k``.
    r : float
        ``|rho + winding|`` (module docstring).
    """
    U, rho = problem.blocks(u)
    S = problem.options.steps_per_period
    X = np.stack([problem.map.step_states(z, lam) for z in U])  # (N, S, 2n): the integrator's own states
    r = rho + problem.winding
    if r < 0.0:  # phi reversed: point j sits at phi = -2 pi j / N
        X = np.roll(X[::-1], 1, axis=0)
    return X, 2.0 * math.pi * np.arange(S) / S, abs(r)


def strongest_winding(problem, u, lam: float, reach: int = 2) -> int:
    """The ``m`` in ``-reach .. reach`` whose line ``(rho + m) w`` is the strongest in the circle's trajectories
    (the sum over the state's components of the squared amplitudes), with the problem's ``winding`` at 0."""
    keep = problem.winding
    problem.winding = 0
    try:
        X, theta1, r = circle_surface(problem, u, lam)  # oriented for |rho|
    finally:
        problem.winding = keep
    best = max(range(-reach, reach + 1), key=lambda m: float(np.sum(circle_line(X, theta1, r, m, 1) ** 2)))
    return best if problem.blocks(u)[1] >= 0.0 else -best


def _line_coefficient(X, theta1, rho: float, k1: int, k2: int) -> np.ndarray:
    """``c(k1, k2)`` (module docstring) of every column of ``X`` (N, S, m): complex, shape (m,)."""
    N = X.shape[0]
    phi = 2.0 * math.pi * np.arange(N) / N
    phase = np.exp(-1j * (k2 * phi[:, None] + (k1 + k2 * rho) * theta1[None, :]))  # (N, S)
    return np.einsum("js,jsm->m", phase, X) / (N * len(theta1))


def circle_line(X, theta1, rho: float, k1: int, k2: int) -> np.ndarray:
    """The amplitude of the pair ``(k1, k2)`` (module docstring) of every column of ``X`` (N, S, m): shape (m,)."""
    c = _line_coefficient(X, theta1, rho, k1, k2)
    return (1.0 if k1 == 0 and k2 == 0 else 2.0) * np.abs(c)


def circle_whirl(problem, u, lam: float, ix: int, iy: int) -> dict:
    """The whirl radii of a node pair ``(x, y)`` (dof indices ``ix``, ``iy``) on the torus.

    ``z = x + i y`` is the sum over the lines of ``(c_x + i c_y) e^{i f t}`` and
    ``(conj c_x + i conj c_y) e^{-i f t}``, ``f = k1 w + k2 w2`` and ``c`` the
    line's coefficient (module docstring): the radius of the forward whirl at
    ``+f`` is ``|c_x + i c_y|``, of the backward one at ``-f``
    ``|conj c_x + i conj c_y|``, as :func:`contin.model.whirl.whirl_radii` of a
    periodic orbit and the spectral lines of a simulated ``z``
    (:func:`contin.timedomain.whirl_sweep.classify_whirl`).

    Returns
    -------
    dict
        ``forced`` (forward at ``+w``), ``self_excited`` (forward at ``+w2``), ``combination`` (backward at
        ``w2 - w``, the line ``(1, -1)``) and ``ratio`` ``w2 / w``.
    """
    return _whirl(circle_surface(problem, u, lam), ix, iy)


def _whirl(surface, ix: int, iy: int) -> dict:
    """:func:`circle_whirl` from the circle's trajectories (:func:`circle_surface`), and the backward whirl at
    ``-w`` (``forced_backward``)."""
    X, theta1, r = surface

    def radius(k1: int, k2: int, forward: bool) -> float:
        cx, cy = _line_coefficient(X[:, :, [ix, iy]], theta1, r, k1, k2)
        return float(abs(cx + 1j * cy) if forward else abs(np.conj(cx) + 1j * np.conj(cy)))

    return {"forced": radius(1, 0, True), "self_excited": radius(0, 1, True), "combination": radius(1, -1, False),
            "forced_backward": radius(1, 0, False), "ratio": float(r)}


def _vertex(a: float, b: float, c: float) -> float:
    """The extreme value of the parabola through ``(-1, a), (0, b), (1, c)`` (``b`` where it is flat)."""
    curv = a - 2.0 * b + c
    return b if curv == 0.0 else b - (c - a) ** 2 / (8.0 * curv)


def _extremes(xi, finer: int = 8) -> tuple[float, float]:
    """The largest and smallest value of the surface sampled as ``xi`` (N, S), between the trajectories too:
    the circle's interpolant in ``phi`` at ``finer`` times the angles at every sample in time, then 16 times
    finer again around the extreme sample, and the parabolas through the best value and its neighbours."""
    N, S = xi.shape
    freqs = np.fft.fftfreq(N, 1.0 / N)
    c = np.fft.fft(xi, axis=0) / N

    def at(phi, ks):  # the interpolant at the angles phi and the samples ks in time
        return np.real(np.exp(1j * np.outer(phi, freqs)) @ c[:, ks])

    coarse = at(2.0 * math.pi * np.arange(finer * N) / (finer * N), slice(None))
    out = []
    for sign in (1.0, -1.0):
        j, k = np.unravel_index(int(np.argmax(sign * coarse)), coarse.shape)
        ks = np.arange(max(k - 8, 0), min(k + 9, S))
        phi = 2.0 * math.pi * (j + np.linspace(-2.0, 2.0, 65)) / (finer * N)
        v = sign * at(phi, ks)
        a, b = np.unravel_index(int(np.argmax(v)), v.shape)
        best = v[a, b]
        gain = _vertex(v[a - 1, b], best, v[a + 1, b]) - best if 0 < a < len(phi) - 1 else 0.0
        if 0 < b < len(ks) - 1:  # the time direction is not periodic on one trajectory
            gain += _vertex(v[a, b - 1], best, v[a, b + 1]) - best
        out.append(sign * (best + max(gain, 0.0)))
    return out[0], out[1]


def circle_measures(problem, u, lam: float, dof_names, harmonic_columns: int = 5, whirl_parts=None) -> dict:
    """A circle's row: the columns of a periodic row and the torus' own (module docstring).

    ``amp``, ``max``, ``min`` over the sampled trajectories and the angles between them (the circle's
    interpolant in ``phi``, refined around the extreme sample); ``rms`` the RMS of
    the oscillating part over them (the torus average); ``h0`` the mean's modulus and
    ``hK`` the amplitude of the pair ``(K, 0)``, ``K <= harmonic_columns``;
    ``frequency2`` is ``w2 = |rho + winding| w``; ``forced``, ``free``, ``comb`` the lines
    ``(1, 0)``, ``(0, 1)``, ``(1, -1)``. With ``whirl_parts`` (part name -> dof indices ``(x, y)``) the rotor's
    whirl columns of each part (:func:`circle_whirl`): ``whirl_{fwd,bwd}_1`` at ``+w`` and ``-w``,
    ``whirl_{fwd,bwd}_half`` zero (a torus has no line at ``w/2``), ``whirl_fwd_free`` at ``+w2`` and
    ``whirl_bwd_comb`` at ``w2 - w``.
    """
    surface = circle_surface(problem, u, lam)
    X, theta1, r = surface
    x = X[:, :, :problem.n]
    mean = x.mean(axis=(0, 1))
    out = {"frequency2": float(r * problem.frequency_at(lam))}
    lines = {name: circle_line(x, theta1, r, *pair) for name, pair in COMPONENTS.items()}
    harmonics = [circle_line(x, theta1, r, k, 0) for k in range(1, harmonic_columns + 1)]
    for i, d in enumerate(dof_names):
        hi, lo = _extremes(x[:, :, i])
        out.update({f"amp_{d}": 0.5 * (hi - lo), f"max_{d}": hi, f"min_{d}": lo,
                    f"rms_{d}": float(np.sqrt(np.mean((x[:, :, i] - mean[i]) ** 2))), f"h0_{d}": abs(float(mean[i]))})
        for k, amp in enumerate(harmonics, start=1):
            out[f"h{k}_{d}"] = float(amp[i])
        for name, amp in lines.items():
            out[f"{name}_{d}"] = float(amp[i])
    for part, (ix, iy) in (whirl_parts or {}).items():
        wh = _whirl(surface, ix, iy)
        out.update({f"whirl_fwd_1_{part}": wh["forced"], f"whirl_bwd_1_{part}": wh["forced_backward"],
                    f"whirl_fwd_half_{part}": 0.0, f"whirl_bwd_half_{part}": 0.0,
                    f"whirl_fwd_free_{part}": wh["self_excited"], f"whirl_bwd_comb_{part}": wh["combination"]})
    return out
