"""Static equilibria of any model and its linearisation there.

The static residual of a model is its harmonic balance with ``H = 0``
(:class:`contin.hb.problem.HarmonicBalance`):
``R(x) = K x + f_nl(x, 0) - f_0`` with ``dR/dx`` the tangent stiffness. The
static load ``f_0`` is the mean over one period of the model's excitation
(the constant part of ``F cos(w t) + P`` is ``P``), so the periodic forcing of
a scene does not have to be switched off. Forces that vary explicitly in time
(parametric stiffness) have no static equilibrium and are refused.

About an equilibrium ``x_e`` the small motions obey
``M y'' + C_t y' + K_t y = 0`` with ``K_t = dR/dx(x_e)`` and
``C_t = C + df_nl/dx'(x_e, 0)``: the input of :mod:`contin.modal.modes`.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from contin.hb.problem import HarmonicBalance, HBOptions
from contin.model.base import ExcitationElement, Model
from contin.engine.newton import NewtonResult, newton

__all__ = ["MeanExcitation", "static_model", "static_problem", "Equilibrium", "solve_equilibrium",
           "equilibrium_path", "tangent_matrices", "EquilibriumFailed"]


class EquilibriumFailed(RuntimeError):
    """Newton found no equilibrium (at ``value``), even with subdivided parameter steps."""

    def __init__(self, message: str, value: float | None = None):
        super().__init__(message)
        self.value = value


class MeanExcitation(ExcitationElement):
    """The period mean of other excitation elements: the static load ``f_0``.

    Parameters
    ----------
    elements : list of ExcitationElement
    samples : int, optional
        Phases per period for the mean (default: enough for their highest
        harmonic, at least 64).
    """

    kind = "mean"

    def __init__(self, elements, samples: int | None = None):
        self.elements = list(elements)
        top = max([el.max_order() for el in self.elements] + [0.0])
        self.samples = int(samples or max(64, 4 * math.ceil(top) + 2))
        self._tau = 2.0 * np.pi * np.arange(self.samples) / self.samples

    def _mean_of(self, g):
        m = g.mean(axis=0)
        # a pure oscillation has mean zero: drop the rounding residue of the sum (~1e-17 of its amplitude)
        m[np.abs(m) <= 8 * self.samples * np.finfo(float).eps * np.max(np.abs(g), axis=0)] = 0.0
        return m

    def evaluate(self, tau, p, f):
        g = np.zeros((self.samples, f.shape[1]))
        for el in self.elements:
            el.evaluate(self._tau, p, g)
        f += self._mean_of(g)

    def evaluate_dp(self, tau, p, k, dfdp):
        g = np.zeros((self.samples, dfdp.shape[1]))
        for el in self.elements:
            el.evaluate_dp(self._tau, p, k, g)
        dfdp += self._mean_of(g)

    def depends_on(self, k):
        return any(el.depends_on(k) for el in self.elements)

    def max_order(self):
        return 0.0

    def describe(self, dof_names, param_names):
        return "period mean of: " + "; ".join(el.describe(dof_names, param_names) for el in self.elements)


def static_model(model: Model) -> Model:
    """A copy of ``model`` whose excitation is its period mean (the static load).

    Raises
    ------
    ValueError
        If a force varies explicitly in time (``cos(k tau)`` factors): such a
        model has no static equilibrium.
    """
    timed = [el for el in model.forces if el.tau_orders()]
    if timed:
        raise ValueError("forces that vary in time have no static equilibrium: "
                         + "; ".join(el.describe(model.dof_names, model.param_names) for el in timed)
                         + " (switch that effect off)")
    exc = [MeanExcitation(model.excitations)] if model.excitations else []
    out = dataclasses.replace(model, excitations=exc)
    if hasattr(model, "dependent_parameters"):  # custom models: keep the record of derived parameters
        out.dependent_parameters = model.dependent_parameters
    return out


def static_problem(model: Model, parameter: str | None = None, params=None) -> HarmonicBalance:
    """``R(x, lambda) = K x + f_nl(x, 0) - f_0`` as a harmonic balance with ``H = 0``.

    Parameters
    ----------
    model : Model
    parameter : str, optional
        The parameter ``lambda`` (default the model's frequency, which the
        static residual does not depend on).
    params : dict, optional
        Parameter overrides.
    """
    return HarmonicBalance(static_model(model), parameter or model.frequency, HBOptions(harmonics=0), params)


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


def solve_equilibrium(hb: HarmonicBalance, lam: float, guess=None, rtol: float = 1e-10,
                      max_iter: int = 30) -> NewtonResult:
    """Newton on ``R(x, lam) = 0`` from ``guess`` (default zeros).

    The tolerance is ``rtol`` times the larger of the static load and the
    residual at the guess (``R`` is in force units).
    """
    x0 = np.zeros(hb.size) if guess is None else np.asarray(guess, dtype=float)
    fext, _ = hb.excitation(hb.params_at(lam))
    R0 = hb.residual(x0, lam)
    scale = max(float(np.max(np.abs(fext), initial=0.0)), float(np.max(np.abs(R0), initial=0.0)), 1e-300)

    def fun_and_jac(x):
        R, Ju, _ = hb.linearize(x, lam)
        return R, Ju

    res = newton(fun_and_jac, x0, rtol * scale, max_iter)
    if res.converged and res.iterations < max_iter:
        # one more step, kept if it lowers the residual: the tolerance bounds the residual, and the
        # displacement error is then up to rtol/cond; a converged Newton step costs little and gains digits
        R, J = fun_and_jac(res.x.copy())
        try:
            x1 = res.x - np.linalg.solve(J, R)
        except np.linalg.LinAlgError:
            return res
        r1 = float(np.max(np.abs(hb.residual(x1, lam)), initial=0.0))
        if np.all(np.isfinite(x1)) and r1 < res.residual_norm:
            res = dataclasses.replace(res, x=x1, residual_norm=r1, iterations=res.iterations + 1)
    return res


def _equilibrium(hb, lam, res: NewtonResult) -> Equilibrium:
    M, C, K = tangent_matrices(hb, res.x, lam)
    return Equilibrium(float(lam), res.x.copy(), M, C, K, res.iterations, res.residual_norm)


def equilibrium_path(hb: HarmonicBalance, values, guess=None, rtol: float = 1e-10, max_iter: int = 30):
    """Equilibria at successive parameter values, each followed from the previous one.

    The first value is solved by Newton from ``guess``. From value to value
    the equilibrium of a nonlinear model is followed by pseudo-arclength
    continuation (:func:`contin.engine.continuation.continuation`), which lands
    exactly on the next value and detects folds: where the path folds back
    before the next value, the run stops with the fold location instead of
    jumping silently to another equilibrium. A linear model (no nonlinear
    force) has one equilibrium per value and is solved directly.

    Parameters
    ----------
    hb : HarmonicBalance
        From :func:`static_problem`.
    values : sequence of float
    guess : array_like, shape (n,), optional
        Start of the first solve (default zeros).
    rtol : float
        Newton tolerance relative to the static load (see :func:`solve_equilibrium`).

    Yields
    ------
    Equilibrium
        One per value, in order.

    Raises
    ------
    EquilibriumFailed
        With the value where no equilibrium was found, or where the path folds.
    """
    from contin.engine.continuation import ContinuationOptions, continuation

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
            fext, _ = hb.excitation(hb.params_at(prev))
            scale = max(float(np.max(np.abs(fext), initial=0.0)),
                        float(np.max(np.abs(hb.residual(np.zeros(hb.size), v)), initial=0.0)), 1e-300)
            # scale the unknowns by the displacement itself or by the first-order change over the step
            # (the default, |x| at the start, is useless on an unloaded start x = 0)
            _, Ju, Jlam = hb.linearize(x, prev)
            try:
                move = float(np.max(np.abs(np.linalg.solve(Ju, Jlam)))) * abs(v - prev)
            except np.linalg.LinAlgError:
                move = 0.0
            su = max(float(np.max(np.abs(x), initial=0.0)), move if np.isfinite(move) else 0.0)
            su = su if su > 0 else 1.0
            opts = ContinuationOptions(direction=1 if v > prev else -1, newton_tol=rtol * scale,
                                       newton_max_iter=max_iter, detect_branch_points=False, max_points=10000,
                                       unknown_scale=su)
            br = continuation(hb, x, prev, (min(prev, v), max(prev, v)), opts, parameter_name=hb.parameter,
                              solve_start=False)
            folds = [sp for sp in br.special_points if sp.kind.value == "fold"]
            if folds or len(br) == 0 or br.parameter[-1] != v:
                where = (f"folds at {hb.parameter} = {folds[0].parameter:.10g}" if folds else
                         f"is lost ({br.message})")
                raise EquilibriumFailed(f"between {hb.parameter} = {prev:g} and {v:g} the static equilibrium "
                                        f"{where}; beyond it this equilibrium does not exist", v)
            res = solve_equilibrium(hb, v, br.unknowns[-1], rtol, max_iter)
            if not res.converged:  # pragma: no cover - the engine stored a converged end point
                raise EquilibriumFailed(f"no static equilibrium at {hb.parameter} = {v:g}: {res.message}", v)
        x, prev = res.x, v
        yield _equilibrium(hb, v, res)
