"""Equilibria of an autonomous model, their eigenvalues and their Hopf points.

An autonomous model (no term depends on the phase ``tau``, e.g. a rotor in
the frame turning with it, :func:`contin.model.rotating_frame.rotating_frame`)
is at rest where

    R(x, lam) = K x + f_nl(x, 0) - f_ext = 0,          x of shape (n,),

with ``f_ext`` its constant forces. :class:`EquilibriumProblem` gives the
engine this residual with its exact derivatives: ``dR/dx = K + df/dx``
from the elements' own laws, ``dR/dlam`` from the parameter derivatives of the
matrices, the elements and the excitations (no finite difference). The
equilibrium's stability is that of the state matrix

    A = [[0, I], [-M^-1 (K + df/dx), -M^-1 (C + df/dx')]]      (2n, 2n).

A Hopf point is where a complex pair of eigenvalues of ``A`` crosses the
imaginary axis, ``lambda = +- i omega_H`` (Kuznetsov, *Elements of Applied
Bifurcation Theory*, 3rd ed., 2004, sec. 3.4). Its test function is the
largest real part among the eigenvalues with a positive imaginary part
(:func:`hopf_test`); :func:`follow_equilibrium` passes it to the engine as an
event, and :func:`locate_hopf` brackets its zero in ``lam`` and finds it by
Brent's method, each evaluation a Newton-converged equilibrium.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping

import numpy as np
from scipy.optimize import brentq

from contin.engine.branch import SpecialKind
from contin.engine.continuation import ContinuationOptions, continuation
from contin.engine.events import FunctionEvent
from contin.engine.problem import solve_at

__all__ = ["EquilibriumProblem", "HopfPoint", "follow_equilibrium", "hopf_test", "locate_hopf"]

#: an eigenvalue is complex when its imaginary part exceeds this times its modulus
COMPLEX_TOL = 1e-9


def _autonomous(model) -> None:
    for el in list(model.forces) + list(model.excitations):
        orders = el.tau_orders() if hasattr(el, "tau_orders") else ()
        if getattr(el, "order", 0.0) != 0.0 or orders:
            raise ValueError(f"model '{model.name}': element '{getattr(el, 'label', el.kind)}' varies in time "
                             f"(phase tau): the model is not autonomous and has no equilibria")


class EquilibriumProblem:
    """``R(x, lam) = K x + f_nl(x, 0) - f_ext`` of an autonomous model, for the continuation engine.

    Parameters
    ----------
    model : Model
        Autonomous: its forces and excitations do not depend on ``tau``.
    parameter : str
        The continuation parameter.
    params : dict, optional
        The other parameter overrides.

    Raises
    ------
    ValueError
        An unknown parameter, a structural one varied, or a model with a
        time-dependent element.

    Attributes
    ----------
    size : int
        ``n``, the displacements.
    """

    def __init__(self, model, parameter: str, params: Mapping[str, float] | None = None):
        model.parameter_index(parameter)  # names an unknown parameter
        model.check_variable(parameter, params)
        _autonomous(model)
        self.model, self.parameter = model, parameter
        self.base = dict(params or {})
        self.n = self.size = model.n_dof
        self._k = model.parameter_index(parameter)

    def p_at(self, lam: float) -> np.ndarray:
        """The parameter vector at ``lam``, shape (P,)."""
        return self.model.parameter_vector({**self.base, self.parameter: float(lam)})

    def _forces(self, x, p):
        n = self.n
        X, V = np.asarray(x, dtype=float).reshape(1, n), np.zeros((1, n))
        tau = np.zeros(1)
        f, dfdx, dfdxd = np.zeros((1, n)), np.zeros((1, n, n)), np.zeros((1, n, n))
        for el in self.model.forces:
            el.evaluate(X, V, tau, p, f, dfdx, dfdxd)
        fext = np.zeros((1, n))
        for el in self.model.excitations:
            el.evaluate(tau, p, fext)
        return f[0], dfdx[0], dfdxd[0], fext[0]

    def residual(self, u, lam: float) -> np.ndarray:
        """``R(x, lam)``, shape (n,)."""
        p = self.p_at(lam)
        f, _, _, fext = self._forces(u, p)
        return self.model.stiffness.value(p) @ np.asarray(u, dtype=float) + f - fext

    def linearize(self, u, lam: float):
        """Residual (n,), ``dR/dx`` (n, n) and ``dR/dlam`` (n,), all exact."""
        x = np.asarray(u, dtype=float)
        p = self.p_at(lam)
        f, dfdx, _, fext = self._forces(x, p)
        K = self.model.stiffness.value(p)
        R = K @ x + f - fext
        Jlam = self.model.stiffness.derivative(p, self._k) @ x
        X, V, tau = x.reshape(1, -1), np.zeros((1, self.n)), np.zeros(1)
        dp = np.zeros((1, self.n))
        for el in self.model.forces:
            if el.depends_on(self._k):
                el.evaluate_dp(X, V, tau, p, self._k, dp)
        for el in self.model.excitations:
            if el.depends_on(self._k):
                e = np.zeros((1, self.n))
                el.evaluate_dp(tau, p, self._k, e)
                dp -= e
        return R, K + dfdx, Jlam + dp[0]

    def state_matrix(self, u, lam: float) -> np.ndarray:
        """``A`` of the linearised motion about the equilibrium ``u`` (module docstring), shape (2n, 2n)."""
        x = np.asarray(u, dtype=float)
        p = self.p_at(lam)
        _, dfdx, dfdxd, _ = self._forces(x, p)
        M, C, K = self.model.linear(p)
        Minv = np.linalg.inv(M)
        n = self.n
        A = np.zeros((2 * n, 2 * n))
        A[:n, n:] = np.eye(n)
        A[n:, :n] = -Minv @ (K + dfdx)
        A[n:, n:] = -Minv @ (C + dfdxd)
        return A

    def eigenvalues(self, u, lam: float) -> np.ndarray:
        """Eigenvalues of :meth:`state_matrix`, by decreasing real part, shape (2n,)."""
        ev = np.linalg.eigvals(self.state_matrix(u, lam))
        return ev[np.argsort(-ev.real, kind="stable")]

    def solve(self, x0, lam: float, tol: float = 1e-12, max_iter: int = 30) -> np.ndarray:
        """The equilibrium near ``x0`` at ``lam`` by Newton, shape (n,).

        Raises
        ------
        ArithmeticError
            If Newton does not reach ``max |R| <= tol max(1, max |x|)``.
        """
        return solve_at(self, x0, lam, tol=tol, max_iter=max_iter,
                        what=f"no equilibrium found near the guess ({self.parameter})")


def hopf_test(eigenvalues) -> float:
    """The largest real part among the eigenvalues with a positive imaginary part (``-inf``: none)."""
    ev = np.asarray(eigenvalues)
    cx = ev[ev.imag > COMPLEX_TOL * np.maximum(np.abs(ev), 1.0)]
    return float(np.max(cx.real)) if cx.size else -math.inf


@dataclasses.dataclass(frozen=True)
class HopfPoint:
    """A Hopf point of an equilibrium branch.

    Attributes
    ----------
    parameter : str
    lam : float
        Its parameter value.
    state : ndarray, shape (n,)
        The equilibrium's displacements there.
    omega : float
        ``omega_H > 0``: the critical pair is ``+- i omega_H``.
    eigenvector : ndarray of complex, shape (2n,)
        Of ``+ i omega_H`` in the state ``(x, x')``, unit norm.
    real_part : float
        The critical pair's real part at ``lam`` (zero up to the location's accuracy).
    slope : float
        ``d Re(lambda) / d lam`` there (its sign says on which side the equilibrium is unstable).
    """

    parameter: str
    lam: float
    state: np.ndarray
    omega: float
    eigenvector: np.ndarray
    real_part: float
    slope: float


def _critical(A: np.ndarray):
    ev, V = np.linalg.eig(A)
    cx = np.flatnonzero(ev.imag > COMPLEX_TOL * np.maximum(np.abs(ev), 1.0))
    j = int(cx[np.argmax(ev[cx].real)])
    return ev[j], V[:, j] / np.linalg.norm(V[:, j])


def locate_hopf(problem: EquilibriumProblem, x0, lam_a: float, lam_b: float, xtol: float = 1e-13) -> HopfPoint:
    """The Hopf point between ``lam_a`` and ``lam_b`` (module docstring).

    Parameters
    ----------
    problem : EquilibriumProblem
    x0 : array_like, shape (n,)
        An equilibrium (or a guess) at ``lam_a``.
    lam_a, lam_b : float
        A bracket: :func:`hopf_test` has opposite signs at its ends.
    xtol : float
        Brent's tolerance in ``lam`` (relative to ``max(1, |lam|)``).

    Raises
    ------
    ValueError
        If the test does not change sign over the bracket.
    """
    last = {"x": problem.solve(x0, lam_a)}

    def test(lam):
        last["x"] = problem.solve(last["x"], lam)
        return hopf_test(problem.eigenvalues(last["x"], lam))

    ga, gb = test(lam_a), test(lam_b)
    if not (np.isfinite(ga) and np.isfinite(gb)) or ga * gb > 0:
        raise ValueError(f"locate_hopf: the critical real part does not change sign between {problem.parameter} = "
                         f"{lam_a:.10g} ({ga:.3g}) and {lam_b:.10g} ({gb:.3g}): no Hopf point bracketed")
    last["x"] = problem.solve(x0, lam_a)
    lam = brentq(test, lam_a, lam_b, xtol=xtol * max(1.0, abs(lam_a)), rtol=4 * np.finfo(float).eps, maxiter=200)
    x = problem.solve(last["x"], lam)
    ev, v = _critical(problem.state_matrix(x, lam))
    d = 1e-6 * max(1.0, abs(lam))
    slope = (test(lam + d) - test(lam - d)) / (2 * d)  # reported only, not used by a Newton iteration
    return HopfPoint(problem.parameter, float(lam), x, float(ev.imag), v, float(ev.real), float(slope))


def follow_equilibrium(problem: EquilibriumProblem, x0, lam0: float, lam_range,
                       options: ContinuationOptions | None = None):
    """Follow the equilibria from ``(x0, lam0)`` over ``lam_range`` with the Hopf test as an event.

    Each Hopf point the engine locates (kind ``ns``: in a rotating frame it is
    the Neimark-Sacker point of the forced whirl) is refined by
    :func:`locate_hopf` between the stored points around it.

    Returns
    -------
    branch : contin.engine.branch.Branch
        With the monitor ``hopf_test`` in its point data.
    hopf : list of HopfPoint
    """
    def monitor(u, lam, Ju=None, Jlam=None):
        return {"hopf_test": hopf_test(problem.eigenvalues(u, lam))}

    event = FunctionEvent(lambda pt: pt.data["hopf_test"], name="hopf", kind=SpecialKind.NS)
    br = continuation(problem, np.asarray(x0, dtype=float), lam0, lam_range,
                      options or ContinuationOptions(ds=0.02, ds_max=0.05), parameter_name=problem.parameter,
                      events=[event], monitors=[monitor])
    lams = np.asarray(br.parameter)
    hopf = []
    for sp in br.special_points:
        if sp.kind != SpecialKind.NS:
            continue
        lo, hi = sp.index, min(sp.index + 1, len(lams) - 1)
        try:
            hopf.append(locate_hopf(problem, br.unknowns[lo], float(lams[lo]), float(lams[hi])))
        except ValueError:  # the engine's change was not one of the critical pair (told by the branch)
            continue
    return br, hopf
