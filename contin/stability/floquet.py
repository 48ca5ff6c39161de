"""Floquet multipliers of one harmonic-balance solution: Hill's method, the monodromy, and their cross-checks.

:func:`floquet_multipliers` computes the multipliers by the method of
:class:`~contin.stability.options.StabilityOptions`: Hill's method
(:mod:`contin.stability.hill`), the monodromy matrix by time integration
(:mod:`contin.stability.monodromy`; RK4 with its steps refined for the
stiffest mode up to a cap, beyond it the adaptive integration where
affordable), or both, the monodromy checking Hill where Hill's verdict
changes, where its selection is ambiguous, near ``+-1``, and where the orbit
crosses a switching surface at which the force jumps (which Hill's matrices
miss).

Verdicts are those of the harmonic-balance orbit: with too few harmonics the
HB orbit and its stability can both be wrong. Method BOTH exposes this where
Hill's verdict changes (the monodromy integrates the exact variational
equations along the orbit, not the truncated Hill problem).
"""

from __future__ import annotations

import dataclasses
import math
import warnings

import numpy as np

from contin.util.warning import ContinWarning
from contin.stability.hill import hill_spectrum
from contin.stability.monodromy import monodromy_orbit_ivp, monodromy_reference, monodromy_rk4, switching_events
from contin.stability.multiplier_pairing import multiplier_distance
from contin.stability.options import StabilityMethod, StabilityOptions
from contin.stability.rk4_step_limit import RK4StepError
from contin.stability.saltation import solution_period, switching_elements
from contin.stability.verdict import FloquetResult, log_exponents, floquet_result, classify_multipliers

__all__ = ["floquet_multipliers", "IVP_FALLBACK_EVALUATIONS"]

#: Largest estimated cost, in right-hand sides, of the adaptive integration used where RK4 would need
#: more than ``max_steps_per_period`` steps (its cost: docs/validation/stability-notes.md)
IVP_FALLBACK_EVALUATIONS = 20000
#: Right-hand sides DOP853 takes per radian of the stiffest mode (``int |eigenvalue| dt`` over the
#: period) at tolerances near 1e-10, with a margin over the count measured in
#: docs/validation/stability-notes.md
_IVP_EVALUATIONS_PER_RADIAN = 30.0

#: Largest multiplier discrepancy between Hill and the monodromy that still
#: counts as agreement in accuracy: at a boundary where multipliers are double
#: (undamped Mathieu), an error e of either method moves them by ~sqrt(e).
_MARGINAL_GAP = 1e-3


def _monodromy(hb, u, lam, options):
    """The monodromy of ``options``: RK4 with its steps refined up to the cap, else the adaptive fallback.

    Raises
    ------
    ArithmeticError
        Neither can be made at this point (the message says why).
    """
    if options.integrator == "dop853":
        return monodromy_reference(hb, u, lam, rtol=options.rtol, atol=options.rtol * 0.1)
    steps = max(options.steps_per_period, hb.H + 1)
    try:
        return monodromy_rk4(hb, u, lam, steps, max_steps=max(options.max_steps_per_period, steps))
    except RK4StepError as exc:
        return _adaptive_monodromy(hb, u, lam, options, steps, exc)


def _adaptive_monodromy(hb, u, lam, options, steps, exc):
    """:func:`monodromy_orbit_ivp` where RK4 needs more steps than allowed, if affordable."""
    phase = exc.phase if math.isfinite(exc.phase) else exc.rate * solution_period(hb, lam)
    cost = _IVP_EVALUATIONS_PER_RADIAN * phase
    if not cost <= IVP_FALLBACK_EVALUATIONS:
        raise ArithmeticError(f"{exc} (the adaptive integration would take about {cost:.2g} right-hand sides, "
                              f"more than {IVP_FALLBACK_EVALUATIONS})") from None
    try:
        return monodromy_orbit_ivp(hb, u, lam, rtol=options.rtol, atol=options.rtol * 0.1, samples=2 * steps)
    except ArithmeticError as exc2:
        raise ArithmeticError(f"{exc}; the adaptive integration failed as well ({exc2})") from None


def _force_jumps(hb, u, lam, options) -> bool:
    """Whether the HB orbit crosses a switching surface where the force law jumps.

    Hill's matrices come from the Jacobian sampled on the orbit, which cannot
    hold the contribution of a jump (a delta function at the surface, which the
    saltation matrix carries in the monodromy): at such orbits Hill's
    multipliers are wrong whatever ``H`` (how far: docs/validation/stability-notes.md).
    """
    if not switching_elements(hb.model):
        return False
    try:
        events = switching_events(hb, u, lam, 2 * max(options.steps_per_period, hb.H + 1))
    except ArithmeticError:
        return True  # a grazing switch with a jump
    return any(np.abs(e.saltation - np.eye(e.saltation.shape[0])).max() > 0.0 for e in events)


def floquet_multipliers(hb, u: np.ndarray, lam: float, options: StabilityOptions | None = None, *, previous=None) -> FloquetResult:
    """Floquet multipliers and stability of an HB solution.

    Method BOTH computes Hill's multipliers and confirms them with the
    monodromy when Hill's selection is ambiguous, when ``previous`` is None
    (first point of a branch) or when Hill's counts differ from
    ``previous``. If the two verdicts (counts ``(n_plus, n_minus,
    n_complex)``) differ, the monodromy's multipliers are reported with
    ``disagreement=True`` (``marginal=True`` when a multiplier lies on the
    threshold within the methods' small discrepancy, as happens right at a
    bifurcation).

    The monodromy needs an invertible mass matrix; Hill's method accepts a
    singular one (massless dofs) and then returns ``2 rank(M)`` multipliers.

    Where the orbit crosses a switching surface at which the force jumps,
    Hill's multipliers miss the saltation: method BOTH then reports the
    monodromy's (``disagreement`` when the counts differ), and method HILL
    flags the result ``ambiguous`` with a :class:`~contin.util.warning.ContinWarning`.

    Parameters
    ----------
    hb : HarmonicBalance
    u : ndarray, shape (hb.size,)
        A converged solution.
    lam : float
    options : StabilityOptions, optional
    previous : tuple of int or FloquetResult, optional
        Counts ``(n_plus, n_minus, n_complex)`` of the previous point of a
        branch (method BOTH: a change triggers the monodromy check; ``None``
        also triggers it).

    Returns
    -------
    FloquetResult
    """
    options = StabilityOptions() if options is None else options
    method = options.method
    if method is StabilityMethod.NONE:
        raise ValueError("StabilityOptions.method is 'none': no stability computation requested")
    u = np.asarray(u, dtype=float)
    if method is StabilityMethod.FLOQUET:
        mono = _monodromy(hb, u, lam, options)
        mu = np.linalg.eigvals(mono.matrix)
        ex = log_exponents(mu, mono.period)
        return floquet_result(mu, ex, StabilityMethod.FLOQUET, mono.period, options, monodromy_multipliers=mu.copy())
    spec = hill_spectrum(hb, u, lam, vectors=options.eigenvectors, shift_tol=options.shift_tol)
    ambiguous = spec.quality < options.ambiguity_threshold
    hill = floquet_result(
        spec.multipliers.copy(), spec.exponents.copy(), StabilityMethod.HILL, spec.period, options,
        ambiguous=ambiguous, quality=spec.quality, hill_multipliers=spec.multipliers.copy(),
        eigenvectors=spec.vectors,
    )
    jumps = _force_jumps(hb, u, lam, options)
    if method is StabilityMethod.HILL:
        if jumps:
            warnings.warn(
                f"at {hb.parameter}={lam:.10g} the orbit crosses a contact surface where the force jumps: Hill's "
                "multipliers miss the saltation there (use stability 'both' or 'floquet')", ContinWarning,
                stacklevel=2)
            return dataclasses.replace(hill, ambiguous=True)
        return hill
    prev = previous.counts if isinstance(previous, FloquetResult) else previous
    near_unit = bool(spec.multipliers.size) and options.unit_check > 0 and float(
        np.min(np.minimum(np.abs(spec.multipliers - 1.0), np.abs(spec.multipliers + 1.0)))) <= options.unit_check
    if not (jumps or ambiguous or near_unit or prev is None or tuple(prev) != hill.counts):
        return hill
    mono = _monodromy(hb, u, lam, options)
    mu = np.linalg.eigvals(mono.matrix)
    counts = classify_multipliers(mu, options.tolerance, options.real_angle_tol)
    gap = multiplier_distance(spec.multipliers, mu)
    # near +-1 the multipliers themselves are compared, not only the counts: a wrong
    # selection among Hill's shifted exponents can keep the counts and still be wrong
    fallback = bool(near_unit and not jumps and gap > options.agreement)
    if counts == hill.counts and not jumps and not fallback:
        return dataclasses.replace(hill, confirmed=True, monodromy_multipliers=mu.copy(), gap=gap)
    # Hill and the monodromy disagree, or Hill misses a force jump: the time integration is trusted
    near = np.abs(np.abs(np.concatenate([spec.multipliers, mu])) - 1.0 - options.tolerance)
    ex = log_exponents(mu, mono.period)
    return floquet_result(
        mu, ex, StabilityMethod.FLOQUET, mono.period, options, ambiguous=ambiguous, quality=spec.quality,
        confirmed=True, disagreement=counts != hill.counts, fallback=fallback, gap=gap,
        marginal=bool(counts != hill.counts and gap <= _MARGINAL_GAP and near.min() <= 2.0 * gap + options.tolerance),
        hill_multipliers=spec.multipliers.copy(), monodromy_multipliers=mu.copy(),
    )
