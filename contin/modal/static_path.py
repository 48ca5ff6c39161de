"""The static path: equilibria versus a parameter, and the linearisation about each one.

Each equilibrium ``x_e`` of the static problem (:mod:`contin.modal.equilibrium`,
the one static load and the one solve) comes with the matrices of the small
motions about it, ``M y'' + C_t y' + K_t y = 0``:

- ``K_t = dR/dx(x_e)``, the tangent stiffness (the Jacobian of the static
  residual);
- ``C_t = C + df_nl/dx'(x_e, 0)``, the tangent damping;

(:func:`tangent_matrices`), whose modal algebra is :mod:`contin.modal.modes`.
:func:`linear_modes` gives the undamped modes of a conservative model about
its equilibrium (the start of a backbone); :func:`equilibrium_path` follows
the equilibrium from one parameter value to the next by continuation.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from contin.engine.continuation import ContinuationOptions, continuation
from contin.hb.problem import HarmonicBalance
from contin.modal.equilibrium import (MAX_ITER, EquilibriumFailed, ModalError, solve_equilibrium, static_equilibrium,
                                      static_problem)
from contin.modal.modes import natural_modes
from contin.model.base import Model

__all__ = ["Equilibrium", "tangent_matrices", "linear_modes", "equilibrium_path"]

#: relative asymmetry of the tangent stiffness and of the mass matrix above which a model is not conservative
STIFFNESS_SYMMETRY_RTOL = 1e-9
MASS_SYMMETRY_RTOL = 1e-12


@dataclass(frozen=True)
class Equilibrium:
    """A static equilibrium and the linearisation about it.

    Attributes
    ----------
    value : float
        The parameter value.
    x : ndarray, shape (n,)
    M, C, K : ndarray, shape (n, n)
        Mass, tangent damping ``C + df/dx'`` and tangent stiffness ``dR/dx`` at ``x``.
    iterations : int
        Newton updates used.
    residual_norm : float
    """

    value: float
    x: np.ndarray
    M: np.ndarray
    C: np.ndarray
    K: np.ndarray
    iterations: int
    residual_norm: float


def tangent_matrices(hb: HarmonicBalance, x: np.ndarray, lam: float):
    """``(M, C_t, K_t)`` about ``x``: the model's ``M``, ``C + mean df/dx'`` and ``dR/dx``, each (n, n)."""
    p = hb.params_at(lam)
    M, C, _ = hb.model.linear(p)
    _, K, _ = hb.linearize(np.asarray(x, dtype=float), lam)
    if hb.model.forces:
        _, _, dfdxd = hb.sample_jacobians(np.asarray(x, dtype=float), lam)
        C = C + dfdxd.mean(axis=0)  # all samples agree for time-invariant forces
    return M, C, np.array(K)


def linear_modes(model: Model, params=None, x0=None):
    """Natural frequencies and mass-normalised mode shapes of a conservative model about its equilibrium.

    Solves ``K_t phi = omega^2 M phi`` with ``K_t`` the tangent stiffness at
    ``x0`` (default :func:`contin.modal.equilibrium.static_equilibrium`), by
    :func:`contin.modal.modes.natural_modes` on the symmetric part.

    Returns
    -------
    omega : ndarray, shape (n,)
        Ascending; negative values stand for ``-sqrt(-omega^2)`` (an unstable
        equilibrium).
    phi : ndarray, shape (n, n)
        Columns ``phi_j`` with ``phi_j^T M phi_j = 1``.
    x0 : ndarray, shape (n,)

    Raises
    ------
    ModalError
        If ``K_t`` or ``M`` is not symmetric (not a conservative system) or
        ``M`` is not positive definite; :class:`EquilibriumFailed` if no
        equilibrium is found.
    """
    if x0 is None:
        x0 = static_equilibrium(model, params)
    x0 = np.asarray(x0, dtype=float)
    hb = static_problem(model, params=params)
    _, Kt, _ = hb.linearize(x0, float(hb.p0[hb.k]))
    M, _, _ = model.linear(model.parameter_vector(params))
    scale = max(float(np.abs(Kt).max()), 1e-300)
    if (np.abs(Kt - Kt.T).max() > STIFFNESS_SYMMETRY_RTOL * scale
            or np.abs(M - M.T).max() > MASS_SYMMETRY_RTOL * np.abs(M).max()):
        raise ModalError(f"model '{model.name}': the tangent stiffness or the mass matrix is not symmetric; "
                         f"linear modes and backbones here are for conservative systems")
    try:
        nm = natural_modes(M, 0.5 * (Kt + Kt.T))
    except (ValueError, np.linalg.LinAlgError) as exc:
        raise ModalError(f"model '{model.name}': the mass matrix is not positive definite ({exc})") from None
    omega = np.sign(nm.omega2) * np.sqrt(np.abs(nm.omega2))
    return omega, nm.modes, x0


def _equilibrium(hb, lam, res) -> Equilibrium:
    M, C, K = tangent_matrices(hb, res.x, lam)
    return Equilibrium(float(lam), res.x.copy(), M, C, K, res.iterations, res.residual_norm)


def _inf_norm(v) -> float:
    return float(np.max(np.abs(v), initial=0.0))


def equilibrium_path(hb: HarmonicBalance, values, guess=None, rtol: float = 1e-10, max_iter: int = MAX_ITER):
    """Equilibria at successive parameter values, each followed from the previous one.

    The first value is solved by :func:`contin.modal.equilibrium.solve_equilibrium`
    from ``guess`` (default rest). From value to value the equilibrium of a
    nonlinear model is followed by pseudo-arclength continuation
    (:func:`contin.engine.continuation.continuation`), which lands exactly on
    the next value and detects folds: where the path folds back before the
    next value, the run stops with the fold location instead of jumping
    silently to another equilibrium. A linear model (no nonlinear force) has
    one equilibrium per value and is solved directly.

    Parameters
    ----------
    hb : HarmonicBalance
        From :func:`contin.modal.equilibrium.static_problem`.
    values : sequence of float
    guess : array_like, shape (n,), optional
        Start of the first solve (default rest).
    rtol : float
        Newton tolerance relative to the static load.
    max_iter : int
        Newton updates per solve.

    Yields
    ------
    Equilibrium
        One per value, in order.

    Raises
    ------
    EquilibriumFailed
        With the value where no equilibrium was found, or where the path folds.
    """
    x = None if guess is None else np.asarray(guess, dtype=float)
    prev = None
    linear = not hb.model.forces
    for v in values:
        v = float(v)
        if prev is None or linear or v == prev:
            res = solve_equilibrium(hb, v, x, rtol, max_iter)
            if not res.converged:
                start = "the previous value" if prev is not None else (
                    "the given guess" if guess is not None else "zero displacement")
                raise EquilibriumFailed(f"no static equilibrium found at {hb.parameter} = {v:g} from {start}: "
                                        f"{res.message}", v)
        else:
            res = _follow(hb, x, prev, v, rtol, max_iter)
        x, prev = res.x, v
        yield _equilibrium(hb, v, res)


def _follow(hb: HarmonicBalance, x: np.ndarray, prev: float, v: float, rtol: float, max_iter: int):
    """The equilibrium at ``v`` continued from ``x`` at ``prev`` (:func:`equilibrium_path`)."""
    fext, _ = hb.excitation(hb.params_at(prev))
    scale = max(_inf_norm(fext), _inf_norm(hb.residual(np.zeros(hb.size), v)), 1e-300)
    # scale the unknowns by the displacement itself or by the first-order change over the step
    # (the default, |x| at the start, is useless on an unloaded start x = 0)
    _, Ju, Jlam = hb.linearize(x, prev)
    try:
        move = _inf_norm(np.linalg.solve(Ju, Jlam)) * abs(v - prev)
    except np.linalg.LinAlgError:
        move = 0.0
    su = max(_inf_norm(x), move if np.isfinite(move) else 0.0)
    su = su if su > 0 else 1.0
    opts = ContinuationOptions(direction=1 if v > prev else -1, newton_tol=rtol * scale, newton_max_iter=max_iter,
                               detect_branch_points=False, max_points=10000, unknown_scale=su)
    br = continuation(hb, x, prev, (min(prev, v), max(prev, v)), opts, parameter_name=hb.parameter,
                      solve_start=False)
    folds = [sp for sp in br.special_points if sp.kind.value == "fold"]
    if folds or len(br) == 0 or br.parameter[-1] != v:
        where = f"folds at {hb.parameter} = {folds[0].parameter:.10g}" if folds else f"is lost ({br.message})"
        raise EquilibriumFailed(f"between {hb.parameter} = {prev:g} and {v:g} the static equilibrium {where}; "
                                f"beyond it this equilibrium does not exist", v)
    res = solve_equilibrium(hb, v, br.unknowns[-1], rtol, max_iter)
    if not res.converged:  # pragma: no cover - the engine stored a converged end point
        raise EquilibriumFailed(f"no static equilibrium at {hb.parameter} = {v:g}: {res.message}", v)
    return res
