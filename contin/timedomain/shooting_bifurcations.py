"""What the flow's multipliers say along a shooting branch: its stability monitor, and the start of the
branch of twice the period at a period doubling.

:class:`ShootingStability` reads the multipliers of the linearisation the
engine has just made (:class:`contin.timedomain.multiple_shooting.ShootingProblem`
caches its factors), so a verdict costs no integration;
:func:`period_doubling_start` turns a located period doubling into the first
point and tangent of the doubled branch.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from contin.stability.options import StabilityOptions
from contin.stability.verdict import FloquetResult, monodromy_result
from contin.timedomain.multiple_shooting import ShootingProblem, flip_test
from contin.timedomain.shooting_events import graze_data

__all__ = ["ShootingStability", "period_doubling_start"]


class ShootingStability:
    """Stability monitor of a :class:`ShootingProblem` branch: the multipliers of the integrated flow.

    The multipliers come from the factors of the linearisation the engine has
    just made at the point (cached by the problem), so the verdict costs no
    integration. The returned data are those of
    :class:`contin.stability.StabilityMonitor` (``stable``, ``n_unstable``,
    ``n_plus``, ``n_minus``, ``n_complex``, ``max_multiplier``,
    ``multipliers``, ...) plus ``flip_test`` and, for a model with contacts,
    ``graze`` (the signed extremum of a switching function nearest to zero),
    so the classified events of :func:`contin.stability.stability_events`
    locate the period doublings, Neimark-Sacker points and branch points of
    the flow. Pass the same object in ``monitors`` and to ``stability_events``.

    Parameters
    ----------
    problem : ShootingProblem
    options : StabilityOptions, optional
        Its ``tolerance`` and ``real_angle_tol`` decide the verdict.
    """

    #: no harmonic-balance problem: located points carry no Hill eigenvector
    hb = None

    def __init__(self, problem: ShootingProblem, options: StabilityOptions | None = None):
        self.problem = problem
        self.options = StabilityOptions(method="floquet") if options is None else options

    def analyze(self, u: np.ndarray, lam: float, Ju: np.ndarray | None = None) -> FloquetResult:
        """The verdict at ``(u, lam)`` (``Ju`` is accepted for the monitor signature; the factors are cached)."""
        return monodromy_result(self.problem.multipliers(u, lam), self.problem.period_at(lam), self.options)

    def __call__(self, u, lam, Ju=None, Jlam=None) -> dict:
        res = self.analyze(u, lam, Ju)
        return {**res.monitor_data(), "flip_test": flip_test(res.multipliers), **graze_data(self.problem, u, lam)}


def period_doubling_start(problem: ShootingProblem, u, lam: float, eps: float = 1e-3, segments: int | None = None):
    """The first point of the branch of period ``2 nu`` born at a period doubling of ``problem``'s branch.

    At a period doubling the monodromy ``Phi`` at ``z_0`` has a multiplier
    ``-1`` with real eigenvector ``v``; seen over twice the period the orbit
    has the double multiplier ``+1`` and the new branch leaves it tangent to
    ``v`` at ``t = 0`` and to ``-v`` one period later (a pitchfork in the
    parameter; Kuznetsov, *Elements of Applied Bifurcation Theory*, 3rd ed.,
    2004, sec. 7.4). Pass the returned point and tangent to
    :func:`contin.engine.continuation.continuation` with ``solve_start=False``:
    the engine corrects the point on the hyperplane through it normal to the
    tangent, which cuts the new branch and not the old one.

    Parameters
    ----------
    problem : ShootingProblem
        The problem of the period-``nu`` branch (``M`` segments).
    u : array_like, shape (problem.size,)
        The located period-doubling orbit (a located ``pd`` special point, or
        for ``M = 1`` a point of :func:`contin.timedomain.shooting.period_doubling_scan`).
    lam : float
    eps : float
        Offset along ``v``, relative to ``max(1, max |z_0|)``.
    segments : int, optional
        Segments of the doubled problem (default ``2 M``: the same segment length).

    Returns
    -------
    doubled : ShootingProblem
        Period ``2 nu``; its segment starts of the second lap by integrating the first.
    u0 : ndarray, shape (doubled.size,)
        The segment starts of the orbit from ``z_0 + eps v``.
    tangent : ndarray, shape (doubled.size + 1,)
        The segment starts' derivative along ``v``, and 0 in the parameter; unit length.

    Raises
    ------
    ValueError
        If no multiplier lies within 1e-3 of ``-1`` (not a period doubling).
    """
    Z = problem._blocks(u)
    factors = problem.factors(np.asarray(u, dtype=float), lam)
    per_seg = factors.shape[0] // problem.segments
    Phis = []
    for k in range(problem.segments):
        P = factors[k * per_seg]
        for F in factors[k * per_seg + 1:(k + 1) * per_seg]:
            P = F @ P
        Phis.append(P)
    mono = np.eye(Z.shape[1])
    for P in Phis:
        mono = P @ mono
    mu, V = np.linalg.eig(mono)
    j = int(np.argmin(np.abs(mu + 1.0)))
    if abs(mu[j] + 1.0) > 1e-3:
        raise ValueError(f"no multiplier near -1 at {problem.parameter} = {lam:.10g} (closest {complex(mu[j]):.6g}): "
                         "not a period doubling")
    v = np.real(V[:, j]) if np.linalg.norm(np.real(V[:, j])) >= np.linalg.norm(np.imag(V[:, j])) else np.imag(V[:, j])
    v = v / np.linalg.norm(v)
    M2 = 2 * problem.segments if segments is None else int(segments)
    opts = dataclasses.replace(problem.options, subharmonic=2 * problem.nu, segments=M2)
    doubled = ShootingProblem(problem.model, problem.parameter, problem.base, opts)
    z0 = Z[0] + eps * max(1.0, float(np.max(np.abs(Z[0])))) * v
    u0 = doubled.section_unknowns(z0, lam)  # the doubled orbit keeps the section (start_step) of this one
    # the tangent: v carried along the first lap by the segment Jacobians, -v along the second
    lap = [v]
    for P in Phis[:-1]:
        lap.append(P @ lap[-1])
    if M2 == 2 * problem.segments:
        vs = np.concatenate(lap + [-x for x in lap])  # at the doubled orbit's starts k T / M (2M of them)
    else:
        # other segment counts: the starts lie at other times, the tangent by differences of the start
        d = 1e-6 * max(1.0, float(np.max(np.abs(Z[0]))))
        vs = (doubled.section_unknowns(Z[0] + d * v, lam) - doubled.section_unknowns(Z[0] - d * v, lam)) / (2 * d)
    tangent = np.r_[vs, 0.0]
    return doubled, u0, tangent / np.linalg.norm(tangent)
