"""Static equilibria of any model and its linearisation there.

The static residual of a model is its harmonic balance with ``H = 0``
(:class:`contin.harmonic_balance.HarmonicBalance`):
``R(x) = K x + f_nl(x, 0) - f_0`` with ``dR/dx`` the tangent stiffness. The
static load ``f_0`` is the mean over one period of the model's excitation
(the constant part of ``F cos(w t) + P`` is ``P``), so the periodic forcing of
a scene does not have to be switched off. Forces that vary explicitly in time
(parametric stiffness) have no static equilibrium and are refused.

About an equilibrium ``x_e`` the small motions obey
``M y'' + C_t y' + K_t y = 0`` with ``K_t = dR/dx(x_e)`` and
``C_t = C + df_nl/dx'(x_e, 0)``: the input of :mod:`contin.modal`.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from contin.harmonic_balance import HarmonicBalance, HBOptions
from contin.model import ExcitationElement, Model
from contin.newton import NewtonResult, newton

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

    def evaluate(self, tau, p, f):
        g = np.zeros((self.samples, f.shape[1]))
        for el in self.elements:
            el.evaluate(self._tau, p, g)
        f += g.mean(axis=0)

    def evaluate_dp(self, tau, p, k, dfdp):
        g = np.zeros((self.samples, dfdp.shape[1]))
        for el in self.elements:
            el.evaluate_dp(self._tau, p, k, g)
        dfdp += g.mean(axis=0)

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

    return newton(fun_and_jac, x0, rtol * scale, max_iter)


def _equilibrium(hb, lam, res: NewtonResult) -> Equilibrium:
    M, C, K = tangent_matrices(hb, res.x, lam)
    return Equilibrium(float(lam), res.x.copy(), M, C, K, res.iterations, res.residual_norm)


def equilibrium_path(hb: HarmonicBalance, values, guess=None, rtol: float = 1e-10, max_iter: int = 30,
                     max_halvings: int = 12):
    """Equilibria at successive parameter values, each started from the previous one.

    A step whose Newton iteration fails is subdivided (halved up to
    ``max_halvings`` times), so a strongly nonlinear path is followed as long
    as it does not fold.

    Parameters
    ----------
    hb : HarmonicBalance
        From :func:`static_problem`.
    values : sequence of float
    guess : array_like, shape (n,), optional
        Start of the first solve (default zeros).

    Yields
    ------
    Equilibrium
        One per value, in order.

    Raises
    ------
    EquilibriumFailed
        With the value where no equilibrium was found (after the halvings).
    """
    x = None if guess is None else np.asarray(guess, dtype=float)
    prev = None
    for v in values:
        v = float(v)
        if prev is None:
            res = solve_equilibrium(hb, v, x, rtol, max_iter)
            if not res.converged:
                raise EquilibriumFailed(f"no static equilibrium found at {hb.parameter} = {v:g} from the "
                                        f"{'given guess' if guess is not None else 'zero displacement'}: "
                                        f"{res.message}", v)
        else:
            lam, target, h, halvings = prev, v, v - prev, 0
            while True:
                nxt = target if abs(target - lam) <= abs(h) * (1 + 1e-12) else lam + h
                res = solve_equilibrium(hb, nxt, x, rtol, max_iter)
                if res.converged:
                    x, lam = res.x, nxt
                    if nxt == target:
                        break
                    continue
                halvings += 1
                if halvings > max_halvings:
                    raise EquilibriumFailed(f"the static equilibrium is lost between {hb.parameter} = {lam:g} and "
                                            f"{nxt:g} (a fold or a singular tangent stiffness?): {res.message}", v)
                h /= 2.0
        x, prev = res.x, v
        yield _equilibrium(hb, v, res)
