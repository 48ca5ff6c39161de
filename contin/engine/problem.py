"""What the engine asks of a problem, and how it evaluates one.

- :class:`Problem`: the protocol (``linearize``, optional ``unknown_scale`` and
  ``unknown_groups``) and :data:`Monitor`, the signature of the monitors;
- :class:`ScaledProblem`: the problem in the scaled variables
  ``x = (u / su, lam / sl)`` of shape (m+1,) that the step control, the
  tangents and the arclength use;
- helpers building what the rest of the engine passes around: the bordered
  matrix ``[[Ju su, Jlam sl], [row]]``, the monitors' values at a point
  (:func:`evaluate_monitors`, :class:`LazyData`) and the
  :class:`~contin.engine.events.PointInfo` handed to the events.
"""

from __future__ import annotations

import collections.abc
import math
from typing import Any, Callable, Iterable, Mapping, Protocol, runtime_checkable

import numpy as np

from contin.engine.events import Event, PointInfo
from contin.engine.newton import LUFactor

__all__ = ["LAZY_COST", "LazyData", "Monitor", "Problem", "ScaledProblem", "bordered_matrix", "checked_start", "evaluate_monitors",
           "point_info", "scaled_jacobian", "solve_at"]


@runtime_checkable
class Problem(Protocol):
    """What the engine needs from a problem (duck-typed).

    Methods
    -------
    residual(u, lam) -> ndarray, shape (m,)
        ``R(u, lam)``. Not called by the engine itself (which always needs
        the Jacobians too) but part of the protocol for users and tests.
    linearize(u, lam) -> (R, Ju, Jlam)
        Residual (m,), ``dR/du`` (m, m) and ``dR/dlam`` (m,), all analytic:
        the engine never uses finite differences.

    Optional
    --------
    unknown_scale() -> ndarray of shape (m,), float or None
        Typical magnitudes of the unknowns, used for scaling when
        ``ContinuationOptions.scaling`` is ``AUTO`` and
        ``ContinuationOptions.unknown_scale`` is not given. Non-positive
        components are replaced by the largest one.
    unknown_groups() -> ndarray of shape (m,) or None
        Labels of unknowns sharing a unit (e.g. one degree of freedom's
        harmonic coefficients): with ``AUTO`` scaling and no explicit scale,
        groups whose magnitudes at the start are more than
        :data:`contin.engine.stepsize.GROUP_SPREAD` apart are scaled separately.
    jacobian_cost : float attribute
        What a linearisation costs in evaluations of ``residual`` (default 1).
        From :data:`LAZY_COST` on, the engine's Newton solves evaluate the
        iterates by ``residual`` and the Jacobian only where they factorise it
        and at the solution, taking chord steps with the Jacobian of a nearby
        point in between (a lazy Jacobian: :func:`contin.engine.newton.newton`).

    Numerical failures inside these methods should show up as non-finite
    values or as ``ArithmeticError`` / ``numpy.linalg.LinAlgError``; the
    engine treats both as a failed evaluation (the step is retried with a
    smaller step). Other exceptions are programming errors and propagate.
    """

    def residual(self, u: np.ndarray, lam: float) -> np.ndarray: ...

    def linearize(self, u: np.ndarray, lam: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]: ...


#: A problem whose linearisation costs this many residuals or more is solved with a lazy Jacobian.
LAZY_COST = 3.0

#: ``monitor(u, lam, Ju, Jlam) -> {name: float or ndarray}``, evaluated at every
#: stored and located point; values go to ``Branch.point_data`` and ``PointInfo.data``.
Monitor = Callable[[np.ndarray, float, np.ndarray, np.ndarray], Mapping[str, Any]]


class ScaledProblem:
    """Evaluates the problem in scaled variables ``x = (u / su, lam / sl)``.

    Parameters
    ----------
    problem : Problem
    m : int
        Number of unknowns.
    su : ndarray, shape (m,)
        Scales of the unknowns (updated in place when the automatic scale grows).
    sl : float
        Scale of the parameter.

    Attributes
    ----------
    calls : int
        Linearisations so far.
    residuals : int
        Evaluations of the residual alone so far (a lazy Jacobian's iterates).
    lazy : bool
        The problem's ``jacobian_cost`` reaches :data:`LAZY_COST`: the
        corrector evaluates iterates by :meth:`residual_at`.
    last : tuple or None
        ``(u, lam, R, Ju, Jlam)`` of the latest evaluation: a corrector's
        converged point is read from it.
    """

    def __init__(self, problem, m: int, su: np.ndarray, sl: float):
        self.problem = problem
        self.m = m
        self.su = su
        self.sl = sl
        self.calls = 0
        self.residuals = 0
        self.lazy = float(getattr(problem, "jacobian_cost", 1.0)) >= LAZY_COST
        self.last = None  # (u, lam, R, Ju, Jlam) of the latest evaluation
        self._Jh = np.empty((m, m + 1))

    def residual_at(self, u: np.ndarray, lam: float) -> np.ndarray:
        """``R(u, lam)`` alone, shape (m,), with a shape check (``last`` is not changed)."""
        self.residuals += 1
        R = np.asarray(self.problem.residual(u, lam), dtype=float).reshape(-1)
        if R.shape != (self.m,):
            raise ValueError(f"problem.residual returned shape {R.shape}; expected ({self.m},)")
        return R

    def evaluate(self, u: np.ndarray, lam: float):
        """Raw linearisation ``(R, Ju, Jlam)``, shapes (m,), (m, m), (m,), with shape checks; recorded as ``last``."""
        self.calls += 1
        R, Ju, Jlam = self.problem.linearize(u, lam)
        R = np.asarray(R, dtype=float).reshape(-1)
        Ju = np.asarray(Ju, dtype=float)
        Jlam = np.asarray(Jlam, dtype=float).reshape(-1)
        m = self.m
        if R.shape != (m,) or Ju.shape != (m, m) or Jlam.shape != (m,):
            raise ValueError(
                f"problem.linearize returned shapes R{R.shape}, Ju{Ju.shape}, Jlam{Jlam.shape}; "
                f"expected ({m},), ({m}, {m}), ({m},)"
            )
        self.last = (u, lam, R, Ju, Jlam)
        return R, Ju, Jlam

    def scaled(self, x: np.ndarray):
        """``R`` (m,) and the scaled Jacobian ``[Ju su, Jlam sl]`` (m, m+1) at ``x`` (m+1,).

        The Jacobian is a buffer overwritten by the next call.
        """
        m = self.m
        u = x[:m] * self.su
        lam = float(x[m] * self.sl)
        R, Ju, Jlam = self.evaluate(u, lam)
        Jh = self._Jh
        np.multiply(Ju, self.su, out=Jh[:, :m])
        np.multiply(Jlam, self.sl, out=Jh[:, m])
        return R, Jh


def scaled_jacobian(Ju: np.ndarray, Jlam: np.ndarray, su: np.ndarray, sl: float) -> np.ndarray:
    """``[Ju su, Jlam sl]``, shape (m, m+1), from ``Ju`` (m, m) and ``Jlam`` (m,)."""
    m = Jlam.shape[0]
    Jh = np.empty((m, m + 1))
    Jh[:, :m] = Ju * su
    Jh[:, m] = Jlam * sl
    return Jh


def bordered_matrix(Ju: np.ndarray, Jlam: np.ndarray, su: np.ndarray, sl: float, row: np.ndarray) -> np.ndarray:
    """The bordered matrix ``[[Ju su, Jlam sl], [row]]``, shape (m+1, m+1).

    ``row`` (m+1,) is the bordering row: the tangent of the point the step
    started from, whose orientation the new tangent keeps.
    """
    m = Jlam.shape[0]
    A = np.empty((m + 1, m + 1))
    A[:m, :m] = Ju * su
    A[:m, m] = Jlam * sl
    A[m] = row
    return A


def evaluate_monitors(monitors: Iterable[Monitor], u: np.ndarray, lam: float, Ju: np.ndarray,
                      Jlam: np.ndarray) -> dict:
    """The monitors' values at a point, merged into one dict (two monitors may not share a name)."""
    data: dict[str, Any] = {}
    for mon in monitors:
        values = mon(u, lam, Ju, Jlam)
        for key, value in dict(values).items():
            if key in data:
                raise ValueError(f"two monitors return the same name {key!r}")
            data[key] = value
    return data


class LazyData(collections.abc.Mapping):
    """Monitored values computed on first access (for the points solved while locating an event)."""

    def __init__(self, compute: Callable[[], Mapping[str, Any]]):
        self._compute = compute
        self._values: dict | None = None

    def _get(self) -> dict:
        if self._values is None:
            self._values = dict(self._compute())
        return self._values

    def __getitem__(self, key):
        return self._get()[key]

    def __iter__(self):
        return iter(self._get())

    def __len__(self) -> int:
        return len(self._get())


def point_info(u: np.ndarray, lam: float, tangent: np.ndarray, lu: LUFactor, Ju: np.ndarray, Jlam: np.ndarray,
               s: float, data: Mapping[str, Any]) -> PointInfo:
    """The :class:`~contin.engine.events.PointInfo` of a converged point.

    ``u`` (m,), ``Ju`` (m, m) and ``Jlam`` (m,) are copied; ``lu`` is the
    factorisation of its bordered matrix, which gives the determinant's sign
    and the condition estimate.
    """
    return PointInfo(
        u=np.array(u, dtype=float),
        lam=float(lam),
        tangent=tangent,
        Ju=np.array(Ju, dtype=float),
        Jlam=np.array(Jlam, dtype=float),
        det_sign=lu.det_sign,
        data=data,
        s=float(s),
        lu=lu,
        rcond=lu.rcond,
    )


def checked_start(u0, lam0: float, lam_range, tangent, events: Iterable[Event]):
    """The start arguments of a continuation, checked and converted.

    Returns
    -------
    u0 : ndarray, shape (m,)
        A copy.
    lam0 : float
    lam_range : (float, float)
    tangent : ndarray of shape (m+1,) or None
    events : list of Event

    Raises
    ------
    ValueError, TypeError
        Naming the argument at fault.
    """
    u0 = np.array(u0, dtype=float, copy=True)
    if u0.ndim != 1 or u0.size == 0:
        raise ValueError(f"u0 must be a non-empty 1-D array, got shape {u0.shape}")
    if not np.all(np.isfinite(u0)):
        raise ValueError("u0 contains non-finite values")
    lam0 = float(lam0)
    if not math.isfinite(lam0):
        raise ValueError(f"lam0 must be finite, got {lam0}")
    try:
        lo, hi = (float(v) for v in lam_range)
    except (TypeError, ValueError):
        raise ValueError(f"lam_range must be a pair (lo, hi), got {lam_range!r}") from None
    if not lo < hi:
        raise ValueError(f"lam_range must satisfy lo < hi, got ({lo}, {hi})")
    if not lo <= lam0 <= hi:
        raise ValueError(f"lam0={lam0} is outside lam_range ({lo}, {hi})")
    if tangent is not None:
        tangent = np.array(tangent, dtype=float).reshape(-1)
        if tangent.shape != (u0.size + 1,) or not np.all(np.isfinite(tangent)) or not np.any(tangent):
            raise ValueError(f"tangent must be a finite non-zero array of shape ({u0.size + 1},)")
    events = list(events)
    for ev in events:
        if not isinstance(ev, Event):
            raise TypeError(f"events must be Event instances, got {type(ev).__name__}")
    return u0, lam0, (lo, hi), tangent, events


def solve_at(problem, u0, lam: float, *, tol: float = 1e-11, max_iter: int = 20, what: str = "the problem") -> np.ndarray:
    """The solution near ``u0`` of ``R(u, lam) = 0`` at fixed ``lam``: Newton on a square ``Ju``.

    Converged where ``max |R| <= tol max(1, max |u|)``; ``problem.residual`` tests each iterate and
    ``problem.linearize`` gives the update where it is not converged.

    Raises
    ------
    ArithmeticError
        Naming ``what`` and the residual, if that is not reached in ``max_iter`` updates.
    """
    u = np.array(u0, dtype=float)
    res = math.inf
    for k in range(max_iter + 1):
        R = problem.residual(u, lam)
        res = float(np.max(np.abs(R)))
        if res <= tol * max(1.0, float(np.max(np.abs(u)))):
            return u
        if k < max_iter:
            R, Ju, _ = problem.linearize(u, lam)
            u = u - np.linalg.solve(Ju, R)
    raise ArithmeticError(f"{what}: Newton did not converge at lambda = {lam:.12g} (residual {res:.2e} after "
                          f"{max_iter} updates)")
