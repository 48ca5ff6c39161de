"""Newton solvers and dense LU factorisations used by the continuation engine.

Everything here is generic: a Newton iteration on ``F(x) = 0`` given a
callable returning ``(F, J)``, and :func:`solve_at_parameter`, the plain
Newton iteration in ``u`` at a fixed parameter for any object following the
:class:`contin.continuation.Problem` protocol.

Numerical trouble (non-finite values, singular matrices, divergence, and
``ArithmeticError`` / ``numpy.linalg.LinAlgError`` raised by the evaluated
function) never raises: it is reported through ``NewtonResult.converged`` and
``NewtonResult.message``. Other exceptions (programming errors) propagate.
"""

from __future__ import annotations

import dataclasses
from typing import Callable

import numpy as np
from scipy.linalg import lu_solve
from scipy.linalg.lapack import get_lapack_funcs

__all__ = [
    "NUMERICAL_ERRORS",
    "LUFactor",
    "NewtonResult",
    "SingularMatrixError",
    "factorize",
    "newton",
    "solve_at_parameter",
]

#: Exceptions treated as a numerical failure of an evaluation (not as a bug).
NUMERICAL_ERRORS = (ArithmeticError, np.linalg.LinAlgError)


_GETRF_GECON_D = get_lapack_funcs(("getrf", "gecon"), (np.empty((1, 1)),))


class SingularMatrixError(np.linalg.LinAlgError):
    """Raised by :func:`factorize` for a matrix that cannot be factorised."""


@dataclasses.dataclass(frozen=True, eq=False)
class LUFactor:
    """LU factorisation of a row-equilibrated square matrix.

    The factorised matrix is ``diag(row_scale) @ A`` (positive row scaling
    changes neither the solution of ``A x = b`` nor the sign of ``det A``, but
    makes the condition estimate meaningful for rows of different units).

    Attributes
    ----------
    lu, piv : ndarray, shapes (n, n) and (n,)
        LAPACK ``getrf`` output (the same as :func:`scipy.linalg.lu_factor`).
    row_scale : ndarray, shape (n,)
        Positive row scaling applied before factorising.
    rcond : float
        LAPACK ``gecon`` estimate of the reciprocal 1-norm condition number of
        ``diag(row_scale) @ A``.
    """

    lu: np.ndarray
    piv: np.ndarray
    row_scale: np.ndarray
    rcond: float

    @property
    def n(self) -> int:
        """Order of the matrix."""
        return self.lu.shape[0]

    def solve(self, b: np.ndarray) -> np.ndarray:
        """Solve ``A x = b``; ``b`` has shape (n,) or (n, k)."""
        b = np.asarray(b, dtype=float)
        rb = self.row_scale * b if b.ndim == 1 else self.row_scale[:, None] * b
        return lu_solve((self.lu, self.piv), rb, check_finite=False)

    @property
    def det_sign(self) -> int:
        """Sign of ``det A`` (+1 or -1), without forming the determinant.

        Product of the signs of ``diag(U)`` times the parity of the row
        interchanges; immune to overflow.
        """
        d = np.diagonal(self.lu)
        negatives = int(np.count_nonzero(d < 0))
        swaps = int(np.count_nonzero(self.piv != np.arange(self.piv.size)))
        return -1 if (negatives + swaps) % 2 else 1

    @property
    def log_abs_det(self) -> float:
        """``log|det A|`` (the row scaling is undone)."""
        return float(np.sum(np.log(np.abs(np.diagonal(self.lu)))) - np.sum(np.log(self.row_scale)))


def factorize(a: np.ndarray, *, equilibrate: bool = True) -> LUFactor:
    """LU-factorise a square matrix and estimate its condition.

    Parameters
    ----------
    a : ndarray, shape (n, n)
        Real matrix; it is not modified.
    equilibrate : bool
        Scale each row by the inverse of its largest absolute entry first.

    Returns
    -------
    LUFactor

    Raises
    ------
    SingularMatrixError
        Non-finite entries, a zero row, or an exactly zero pivot.
    """
    a = np.asarray(a, dtype=float)
    if a.ndim != 2 or a.shape[0] != a.shape[1]:
        raise ValueError(f"factorize expects a square matrix, got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise SingularMatrixError("non-finite entries in the matrix")
    n = a.shape[0]
    if equilibrate:
        rmax = np.max(np.abs(a), axis=1) if n else np.ones(0)
        zero = np.flatnonzero(rmax == 0.0)
        if zero.size:
            raise SingularMatrixError(f"zero row {int(zero[0])}")
        row_scale = 1.0 / rmax
        work = a * row_scale[:, None]
    else:
        row_scale = np.ones(n)
        work = a.copy()
    getrf, gecon = _GETRF_GECON_D if work.dtype == np.float64 else get_lapack_funcs(("getrf", "gecon"), (work,))
    anorm = float(np.max(np.sum(np.abs(work), axis=0))) if n else 0.0
    lu, piv, info = getrf(work, overwrite_a=True)
    if info > 0:
        raise SingularMatrixError(f"zero pivot in column {info - 1}")
    if info < 0:  # pragma: no cover - invalid argument, cannot happen here
        raise SingularMatrixError(f"LAPACK getrf failed (info={info})")
    rcond, _ = gecon(lu, anorm, norm="1")
    return LUFactor(lu=lu, piv=piv, row_scale=row_scale, rcond=float(rcond))


@dataclasses.dataclass(frozen=True, eq=False)
class NewtonResult:
    """Outcome of a Newton iteration.

    Attributes
    ----------
    x : ndarray, shape (n,)
        The solution if converged, otherwise the finite iterate with the
        smallest residual seen (the best estimate).
    converged : bool
    iterations : int
        Number of Newton updates (linear solves) performed.
    residual_norm : float
        ``||F(x)||_inf`` at ``x``.
    message : str
        Human-readable reason: ``"converged: residual 3.1e-13 after 3
        iterations"``, ``"residual 3.2e-01 after 12 iterations"``,
        ``"singular Jacobian at iteration 2 (zero pivot in column 0)"``,
        ``"non-finite residual at iteration 3"``, ...
    residual : ndarray or None, shape (n,)
        ``F(x)``.
    jacobian : ndarray or None, shape (n, n)
        ``J(x)`` (the last evaluated Jacobian, at ``x`` when converged).
    lu : LUFactor or None
        Factorisation of ``jacobian`` when ``factor_final=True`` was requested
        and it is not singular.
    rcond : float
        Reciprocal condition estimate of the last factorised Jacobian
        (``nan`` if none was factorised).
    residual_history : tuple of float
        ``||F||_inf`` at the initial guess and after every update.
    singular : bool
        True if the iteration stopped on a singular Jacobian.
    """

    x: np.ndarray
    converged: bool
    iterations: int
    residual_norm: float
    message: str
    residual: np.ndarray | None = None
    jacobian: np.ndarray | None = None
    lu: LUFactor | None = None
    rcond: float = float("nan")
    residual_history: tuple = ()
    singular: bool = False


def _inf_norm(v: np.ndarray) -> float:
    return float(np.max(np.abs(v))) if v.size else 0.0


def newton(
    fun_and_jac: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]],
    x0: np.ndarray,
    tol: float = 1e-10,
    max_iter: int = 12,
    *,
    xtol: float | None = None,
    x_scale: np.ndarray | float | None = None,
    divergence_factor: float = 1e6,
    rcond_min: float = 0.0,
    factor_final: bool = False,
    equilibrate: bool = True,
    backtrack: int = 0,
) -> NewtonResult:
    """Newton's method for ``F(x) = 0``.

    Convergence criterion: ``||F(x)||_inf <= tol``. If ``xtol`` is given, the
    last update must in addition satisfy ``||dx / x_scale||_inf <= xtol``
    (a stricter test; an initial guess that already meets ``tol`` needs no
    update). The Jacobian is refactorised at every iterate (full Newton).

    The iteration stops unconverged, with a message, when

    - ``max_iter`` updates did not reach the tolerance;
    - the residual becomes non-finite, or the evaluation raises one of
      :data:`NUMERICAL_ERRORS`;
    - the residual grows above ``divergence_factor * max(||F(x0)||, tol)``;
    - the Jacobian is singular (non-finite entries, zero row, exactly zero
      pivot, or ``rcond < rcond_min``): the message contains
      ``"singular Jacobian"``.

    Parameters
    ----------
    fun_and_jac : callable
        ``fun_and_jac(x) -> (F, J)`` with ``F`` of shape (n,) and ``J`` of
        shape (n, n). ``x`` must not be kept: it is updated in place.
    x0 : array_like, shape (n,)
        Initial guess (not modified).
    tol : float
        Tolerance on ``||F||_inf``.
    max_iter : int
        Maximum number of updates.
    xtol : float, optional
        Additional tolerance on the scaled update.
    x_scale : float or ndarray of shape (n,), optional
        Typical magnitudes of ``x`` for ``xtol`` (default 1).
    divergence_factor : float
        Growth factor of the residual taken as divergence.
    rcond_min : float
        Jacobians with a reciprocal condition estimate below this are treated
        as singular (0 = only exact singularity).
    factor_final : bool
        Factorise the Jacobian at the converged point and return it as
        ``lu`` (useful for tangents and determinant signs).
    equilibrate : bool
        Row-equilibrate the Jacobian before factorising (see
        :func:`factorize`).
    backtrack : int
        Largest number of step halvings when a full update does not
        decrease ``||F||_inf`` (0 = plain Newton). A residual that is only
        piecewise smooth (a contact sampled by the AFT: the Jacobian jumps
        whenever a sample crosses the clearance) can make full Newton cycle
        between two pieces; halving the update breaks the cycle. An update
        that no halving improves is taken in full, as in plain Newton.

    Returns
    -------
    NewtonResult
    """
    x = np.array(x0, dtype=float, copy=True).reshape(-1)
    scale = 1.0 if x_scale is None else np.asarray(x_scale, dtype=float)
    history: list[float] = []
    rcond = float("nan")

    def fail(message, best, F=None, J=None, k=0, singular=False):
        return NewtonResult(
            x=best[0].copy(),
            converged=False,
            iterations=k,
            residual_norm=best[1],
            message=message,
            residual=F,
            jacobian=J,
            rcond=rcond,
            residual_history=tuple(history),
            singular=singular,
        )

    def evaluate(xk):
        try:
            F, J = fun_and_jac(xk)
        except NUMERICAL_ERRORS as exc:
            return None, None, f"{type(exc).__name__}: {exc}"
        return np.asarray(F, dtype=float).reshape(-1), np.asarray(J, dtype=float), None

    F, J, err = evaluate(x)
    nan_best = (x, float("inf"))
    if err is not None:
        return fail(f"evaluation failed at the initial guess ({err})", nan_best)
    if not np.all(np.isfinite(F)):
        return fail("non-finite residual at the initial guess", nan_best, F, J)
    r = _inf_norm(F)
    history.append(r)
    r0 = r
    best = (x.copy(), r)
    k = 0
    step_norm = None
    while True:
        if r <= tol and (xtol is None or step_norm is None or step_norm <= xtol):
            break
        if k >= max_iter:
            return fail(f"residual {r:.1e} after {k} iterations", best, F, J, k)
        try:
            lu = factorize(J, equilibrate=equilibrate)
        except SingularMatrixError as exc:
            return fail(f"singular Jacobian at iteration {k} ({exc})", best, F, J, k, True)
        rcond = lu.rcond
        if rcond < rcond_min:
            return fail(
                f"singular Jacobian at iteration {k} (rcond={rcond:.1e} < {rcond_min:.1e})",
                best, F, J, k, True,
            )
        dx = lu.solve(-F)
        if not np.all(np.isfinite(dx)):
            return fail(f"singular Jacobian at iteration {k} (non-finite update)", best, F, J, k, True)
        x_old, r_old = x.copy() if backtrack else None, r
        x += dx
        k += 1
        step_norm = _inf_norm(dx / scale)
        F, J, err = evaluate(x)
        halvings = 0
        while (backtrack and halvings < backtrack and err is None
               and not (np.all(np.isfinite(F)) and _inf_norm(F) < r_old)):
            halvings += 1
            dx *= 0.5
            np.add(x_old, dx, out=x)
            F2, J2, err2 = evaluate(x)
            if err2 is None and np.all(np.isfinite(F2)) and _inf_norm(F2) < r_old:
                F, J, err = F2, J2, None
                step_norm = _inf_norm(dx / scale)
                break
            if halvings == backtrack:  # nothing better: the full update, as plain Newton would
                x[:] = x_old + 2.0 ** backtrack * dx
                F, J, err = evaluate(x)
        if err is not None:
            return fail(f"evaluation failed at iteration {k} ({err})", best, None, None, k)
        if not np.all(np.isfinite(F)):
            return fail(f"non-finite residual at iteration {k}", best, F, J, k)
        r = _inf_norm(F)
        history.append(r)
        if r < best[1]:
            best = (x.copy(), r)
        if r > divergence_factor * max(r0, tol):
            return fail(
                f"residual grew from {r0:.1e} to {r:.1e} at iteration {k} (diverging)", best, F, J, k
            )

    message = f"converged: residual {r:.1e} after {k} iterations"
    lu_final = None
    if factor_final:
        try:
            lu_final = factorize(J, equilibrate=equilibrate)
            rcond = lu_final.rcond
        except SingularMatrixError as exc:
            message += f"; singular Jacobian at the solution ({exc})"
    return NewtonResult(
        x=x,
        converged=True,
        iterations=k,
        residual_norm=r,
        message=message,
        residual=F,
        jacobian=J,
        lu=lu_final,
        rcond=rcond,
        residual_history=tuple(history),
    )


def solve_at_parameter(problem, u0: np.ndarray, lam: float, options=None, **newton_kwargs) -> NewtonResult:
    """Plain Newton iteration in ``u`` at a fixed parameter value.

    Parameters
    ----------
    problem : Problem
        Object with ``linearize(u, lam) -> (R, Ju, Jlam)``.
    u0 : array_like, shape (m,)
        Initial guess.
    lam : float
        Parameter value, kept fixed.
    options : ContinuationOptions, optional
        Supplies ``newton_tol`` and ``newton_max_iter`` (defaults 1e-10, 12).
    **newton_kwargs
        Forwarded to :func:`newton` (``factor_final``, ``xtol``, ...).

    Returns
    -------
    NewtonResult
        ``x`` has shape (m,); ``jacobian`` is ``Ju`` at ``x``.
    """
    tol = float(getattr(options, "newton_tol", 1e-10))
    max_iter = int(getattr(options, "newton_max_iter", 12))
    lam = float(lam)

    def fun_and_jac(u):
        R, Ju, _ = problem.linearize(u, lam)
        return R, Ju

    return newton(fun_and_jac, u0, tol, max_iter, **newton_kwargs)
