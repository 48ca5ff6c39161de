"""Static equilibria of any model: the static load, the static problem and its one solve.

The static residual of a model is its harmonic balance with ``H = 0``
(:class:`contin.hb.problem.HarmonicBalance`):

    R(x, lambda) = K x + f_nl(x, 0) - f_0,        dR/dx = K_t (the tangent stiffness).

The static load
---------------
``f_0`` is the constant part of the excitation: its mean over one
excitation period, ``f_0 = (1/2 pi) int_0^{2 pi} f_ext(tau) dtau``. A constant
excitation is its own mean; a harmonic one, ``A cos(k tau + phase)`` with
``k > 0``, has mean zero; the custom-scene form ``P + F cos(tau)`` in one
expression loads the equilibrium with ``P``. So the periodic forcing of a
scene need not be switched off. The static analysis, the modal analysis
about the equilibrium and the backbone (the free vibration about it) all
take this one load (:func:`static_model`). Forces that vary explicitly in
time (parametric stiffness) have no static equilibrium and are refused.

The solve
---------
:func:`solve_equilibrium` is Newton with a halving line search on
``||R||_inf`` from the given guess, or from rest (``x = 0``); from rest, when
Newton stalls, a pseudo-transient continuation (Kelley & Keyes, SIAM J.
Numer. Anal. 35 (1998) 508-523) looks for a stable equilibrium. A converged
point gets one more Newton step, kept if it lowers the residual.

The static path (equilibria versus a parameter) and the linearisation about
each equilibrium, ``M y'' + C_t y' + K_t y = 0`` with ``K_t = dR/dx(x_e)`` and
``C_t = C + df_nl/dx'(x_e, 0)``, are in :mod:`contin.modal.static_path`.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from contin.engine.newton import NewtonResult
from contin.hb.factory import harmonic_balance
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.model.base import ExcitationElement, Model
from contin.model.elements.harmonic import HarmonicExcitation

__all__ = ["ModalError", "EquilibriumFailed", "MeanExcitation", "static_model", "time_varying_excitations",
           "static_problem", "solve_equilibrium", "static_equilibrium"]

#: Newton updates of a static solve
MAX_ITER = 60
#: largest number of step halvings of the line search
MAX_HALVINGS = 30
#: pseudo-transient iterations from rest before giving up
PTC_MAX_ITER = 300
#: first pseudo time step of the pseudo-transient continuation
PTC_FIRST_STEP = 1e-2
#: largest growth of the pseudo time step in one iteration
PTC_MAX_GROWTH = 10.0


class ModalError(ValueError):
    """A static, modal or backbone problem that cannot be set up or solved; the message says why."""


class EquilibriumFailed(ModalError):
    """No static equilibrium was found (at ``value`` of the parameter, where one is followed)."""

    def __init__(self, message: str, value: float | None = None):
        super().__init__(message)
        self.value = value


class MeanExcitation(ExcitationElement):
    """The period mean of other excitation elements: their part of the static load ``f_0``.

    Each element is averaged over ``samples`` equidistant phases of ``tau``.
    An element whose samples are all equal on a dof (constant in time) gives
    that value exactly; a pure oscillation gives exactly zero (the rounding
    residue of its sum is dropped).

    Parameters
    ----------
    elements : list of ExcitationElement
    samples : int, optional
        Phases per period (default: enough for their highest harmonic, at
        least 64).
    """

    kind = "mean"

    def __init__(self, elements, samples: int | None = None):
        self.elements = list(elements)
        top = max([el.max_order() for el in self.elements] + [0.0])
        self.samples = int(samples or max(64, 4 * math.ceil(top) + 2))
        self._tau = 2.0 * np.pi * np.arange(self.samples) / self.samples

    def _mean_of(self, g: np.ndarray) -> np.ndarray:
        """Mean over the phases of the samples ``g`` (samples, n), shape (n,)."""
        m = g.mean(axis=0)
        # a pure oscillation has mean zero: drop the rounding residue of the sum (~1e-17 of its amplitude)
        m[np.abs(m) <= 8 * self.samples * np.finfo(float).eps * np.max(np.abs(g), axis=0)] = 0.0
        constant = np.all(g == g[0], axis=0)
        m[constant] = g[0, constant]  # a constant is its own mean, without the rounding of the sum
        return m

    def _accumulate(self, n: int, fill) -> np.ndarray:
        out = np.zeros(n)
        for el in self.elements:
            g = np.zeros((self.samples, n))
            fill(el, g)
            out += self._mean_of(g)
        return out

    def evaluate(self, tau, p, f):
        f += self._accumulate(f.shape[1], lambda el, g: el.evaluate(self._tau, p, g))

    def evaluate_dp(self, tau, p, k, dfdp):
        dfdp += self._accumulate(dfdp.shape[1], lambda el, g: el.evaluate_dp(self._tau, p, k, g))

    def depends_on(self, k):
        return any(el.depends_on(k) for el in self.elements)

    def max_order(self):
        return 0.0

    def describe(self, dof_names, param_names):
        return "period mean of: " + "; ".join(el.describe(dof_names, param_names) for el in self.elements)


def _harmonic(el) -> bool:
    """A plain :class:`HarmonicExcitation` (a subclass may change what it evaluates)."""
    return type(el) is HarmonicExcitation


def static_model(model: Model) -> Model:
    """A copy of ``model`` whose excitation is the static load ``f_0`` (the module docstring).

    Constant harmonic elements (order 0) and means already taken stay as
    they are, harmonic elements of order ``k > 0`` (mean zero) are dropped,
    and every other element enters through its period mean
    (:class:`MeanExcitation`). The free vibration about the loaded
    equilibrium (a backbone) is this model's too.

    Raises
    ------
    ModalError
        If a force varies explicitly in time (``cos(k tau)`` factors): such a
        model has no static equilibrium and no free (autonomous) problem.
    """
    timed = [el for el in model.forces if el.tau_orders()]
    if timed:
        raise ModalError("forces that vary in time have no static equilibrium and no free (autonomous) problem: "
                         + "; ".join(f"{el.describe(model.dof_names, model.param_names)} varies explicitly in "
                                     f"time (cos of tau)" for el in timed)
                         + " (switch that effect off)")
    keep = [el for el in model.excitations if (_harmonic(el) and el.order == 0.0) or isinstance(el, MeanExcitation)]
    averaged = [el for el in model.excitations if not (_harmonic(el) or isinstance(el, MeanExcitation))]
    excitations = keep + ([MeanExcitation(averaged)] if averaged else [])
    if len(excitations) == len(model.excitations) and not averaged:
        return model
    out = dataclasses.replace(model, excitations=excitations)
    if hasattr(model, "dependent_parameters"):  # custom models: keep the record of derived parameters
        out.dependent_parameters = model.dependent_parameters
    return out


def time_varying_excitations(model: Model) -> list[str]:
    """Labels of the excitations that vary in time, of which the static load keeps only the mean."""
    return sorted({getattr(e, "label", e.kind) for e in model.excitations if e.max_order() != 0.0})


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

    Raises
    ------
    ModalError
        If a force varies in time (:func:`static_model`).
    """
    return harmonic_balance(static_model(model), parameter or None, HBOptions(harmonics=0), params)


def _inf_norm(v: np.ndarray) -> float:
    return float(np.max(np.abs(v), initial=0.0))


def _damped_newton(hb: HarmonicBalance, lam: float, x: np.ndarray, tol: float, max_iter: int) -> NewtonResult:
    """Newton on ``R(x, lam) = 0`` with a halving line search on ``||R||_inf`` (up to :data:`MAX_HALVINGS`).

    Stops unconverged after ``max_iter`` updates or where no halving of the
    Newton step lowers the residual.
    """
    R, J, _ = hb.linearize(x, lam)
    r = _inf_norm(R)
    if not np.isfinite(r):
        return NewtonResult(x, False, 0, r, "non-finite residual at the start")
    it = 0
    message = ""
    while r > tol:
        if it >= max_iter:
            message = f"residual {r:.2e} after {it} iterations"
            break
        try:
            dx = np.linalg.solve(J, -R)
        except np.linalg.LinAlgError:
            dx = np.linalg.lstsq(J, -R, rcond=None)[0]
        t = 1.0
        for _ in range(MAX_HALVINGS):
            xt = x + t * dx
            Rt, Jt, _ = hb.linearize(xt, lam)
            rt = _inf_norm(Rt)
            if np.isfinite(rt) and rt < r:
                break
            t *= 0.5
        else:
            message = f"Newton stopped at residual {r:.2e}: no step along its direction lowers it"
            break
        x, R, J, r = xt, Rt, Jt, rt
        it += 1
    if r <= tol:
        message = f"converged: residual {r:.1e} after {it} iterations"
    return NewtonResult(x, r <= tol, it, r, message, residual=R, jacobian=J)


def _pseudo_transient(hb: HarmonicBalance, lam: float, tol: float):
    """A stable equilibrium by pseudo-transient continuation from rest (``x = 0``), or None.

    Steps ``(M/delta + K_t) dx = -R`` with the pseudo time step ``delta``
    grown as the residual falls (switched evolution relaxation; Kelley &
    Keyes, SIAM J. Numer. Anal. 35 (1998) 508-523): at first a heavily damped
    motion towards a stable equilibrium, at the end Newton. It finds the
    equilibrium where Newton from rest does not (a magnet whose negative
    stiffness sends the first Newton step the wrong way).
    """
    M0 = hb.model.linear(hb.params_at(lam))[0]
    # the pseudo-mass sets the path only: the model's M first, then a plain scaled identity
    for M in (M0, np.eye(hb.size) * np.trace(M0) / hb.size):
        x = _ptc_path(hb, lam, tol, M)
        if x is not None:
            return x
    return None


def _ptc_path(hb, lam, tol, M):
    x = np.zeros(hb.size)
    R, J, _ = hb.linearize(x, lam)
    r = _inf_norm(R)
    delta = PTC_FIRST_STEP
    for _ in range(PTC_MAX_ITER):
        if r <= tol:
            return x
        try:
            dx = np.linalg.solve(M / delta + J, -R)
        except np.linalg.LinAlgError:
            return None
        x = x + dx
        R, J, _ = hb.linearize(x, lam)
        rn = _inf_norm(R)
        if not np.isfinite(rn):
            return None
        delta = delta * min(r / rn, PTC_MAX_GROWTH) if rn > 0 else 1e300
        r = rn
    return x if r <= tol else None


def _polished(hb: HarmonicBalance, lam: float, res: NewtonResult) -> NewtonResult:
    """One more Newton step from a converged point, kept if it lowers the residual.

    The tolerance bounds the residual, and the displacement error is then up
    to ``rtol/cond``; a converged Newton step costs little and gains digits.
    """
    _, J, _ = hb.linearize(res.x, lam)
    try:
        x1 = res.x - np.linalg.solve(J, hb.residual(res.x, lam))
    except np.linalg.LinAlgError:
        return res
    r1 = _inf_norm(hb.residual(x1, lam))
    if np.all(np.isfinite(x1)) and r1 < res.residual_norm:
        return dataclasses.replace(res, x=x1, residual_norm=r1, iterations=res.iterations + 1)
    return res


def solve_equilibrium(hb: HarmonicBalance, lam: float, guess=None, rtol: float = 1e-10,
                      max_iter: int = MAX_ITER) -> NewtonResult:
    """The static equilibrium ``R(x, lam) = 0`` of a static problem (:func:`static_problem`).

    Newton with a halving line search from ``guess``, else from rest; from
    rest, if Newton does not converge, a pseudo-transient continuation looks
    for a stable equilibrium. A converged point gets one more Newton step,
    kept if it lowers the residual.

    Parameters
    ----------
    hb : HarmonicBalance
        With ``H = 0``.
    lam : float
    guess : array_like, shape (n,), optional
    rtol : float
        Tolerance on ``||R||_inf`` relative to the larger of the static load
        and the residual at the start (``R`` is in force units).
    max_iter : int
        Newton updates.

    Returns
    -------
    NewtonResult
        Unconverged with the reason in ``message`` (never raises for a
        numerical failure).
    """
    x0 = np.zeros(hb.size) if guess is None else np.array(guess, dtype=float)
    fext, _ = hb.excitation(hb.params_at(lam))
    R0 = hb.residual(x0, lam)
    tol = rtol * max(_inf_norm(fext), _inf_norm(R0), 1e-300)
    res = _damped_newton(hb, lam, x0, tol, max_iter)
    if not res.converged and guess is None:
        x = _pseudo_transient(hb, lam, tol)
        if x is not None:
            res = _damped_newton(hb, lam, x, tol, max_iter)
    return _polished(hb, lam, res) if res.converged else res


def static_equilibrium(model: Model, params=None, guess=None, *, rtol: float = 1e-10,
                       max_iter: int = MAX_ITER) -> np.ndarray:
    """The static equilibrium of ``model`` under its static load, by :func:`solve_equilibrium`.

    Parameters
    ----------
    model : Model
    params : dict, optional
        Parameter overrides.
    guess : array_like, shape (n,), optional
        Default: rest.

    Returns
    -------
    ndarray, shape (n,)

    Raises
    ------
    ModalError
        If a force varies in time.
    EquilibriumFailed
        If none is found (with the residual reached).
    """
    hb = static_problem(model, params=params)
    res = solve_equilibrium(hb, float(hb.p0[hb.k]), guess, rtol, max_iter)
    if not res.converged:
        raise EquilibriumFailed(f"no static equilibrium of '{model.name}' found: {res.message}")
    return res.x
