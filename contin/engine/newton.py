"""Newton solvers and dense LU factorisations used by the continuation engine.

Everything here is generic: a Newton iteration on ``F(x) = 0`` given a
callable returning ``(F, J)``, and :func:`solve_at_parameter`, the plain
Newton iteration in ``u`` at a fixed parameter for any object following the
:class:`contin.engine.continuation.Problem` protocol.

Numerical trouble (non-finite values, singular matrices, divergence, and
``ArithmeticError`` / ``numpy.linalg.LinAlgError`` raised by the evaluated
function) never raises: it is reported through ``NewtonResult.converged`` and
``NewtonResult.message``. Other exceptions (programming errors) propagate.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Callable

import numba as nb
import numpy as np
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


_GETRF, _GECON, _GETRS = get_lapack_funcs(("getrf", "gecon", "getrs"), (np.empty((1, 1)),))


@nb.njit(cache=True)
def _equilibrated_copy(a, equilibrate, work, row_scale):
    """Row-scale ``a`` into the Fortran-ordered ``work`` in one compiled pass.

    Returns ``(status, anorm)``: status 0 on success, -1 for a non-finite
    entry, ``i + 1`` for a zero row ``i`` (with ``equilibrate``); ``anorm`` is
    the 1-norm of the scaled matrix. One pass instead of the half dozen numpy
    sweeps (and their temporaries) that dominate the factorisation of small
    Jacobians.
    """
    n = a.shape[0]
    finite = True
    zero_row = -1
    colsum = np.zeros(n)
    # one sweep, row by row: the row's maximum, then its scaled copy while it is in cache. Rows are
    # read contiguously and the Fortran-ordered columns written with a stride, measured faster than
    # tiling or than numpy's multiply into the same array at orders 85 to 645.
    for i in range(n):
        m = 0.0
        for j in range(n):
            v = abs(a[i, j])
            if not v <= 1.7976931348623157e308:  # NaN or inf
                finite = False
            elif v > m:
                m = v
        s = 1.0
        if equilibrate:
            if m == 0.0:
                if zero_row < 0:
                    zero_row = i
            else:
                s = 1.0 / m
        row_scale[i] = s
        for j in range(n):
            w = a[i, j] * s
            work[i, j] = w
            colsum[j] += abs(w)
    if not finite:
        return -1, 0.0  # reported before a zero row, as the numpy version did
    if zero_row >= 0:
        return zero_row + 1, 0.0
    anorm = 0.0
    for j in range(n):
        if colsum[j] > anorm:
            anorm = colsum[j]
    return 0, anorm


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
    anorm : float
        1-norm of ``diag(row_scale) @ A`` (for the condition estimate).
    rcond : float
        LAPACK ``gecon`` estimate of the reciprocal 1-norm condition number of
        ``diag(row_scale) @ A``, computed on first access: a Newton
        iteration reads it only for the last factorisation, and each estimate
        costs several triangular solves.
    """

    lu: np.ndarray
    piv: np.ndarray
    row_scale: np.ndarray
    anorm: float = float("nan")
    _rcond: float | None = dataclasses.field(default=None, repr=False)

    @property
    def rcond(self) -> float:
        if self._rcond is None:
            if self.lu.shape[0] == 0:
                value = float("inf")
            else:
                value, _ = _GECON(self.lu, self.anorm, norm="1")
            object.__setattr__(self, "_rcond", float(value))  # a cache on a frozen record
        return self._rcond

    @property
    def n(self) -> int:
        """Order of the matrix."""
        return self.lu.shape[0]

    def solve(self, b: np.ndarray) -> np.ndarray:
        """Solve ``A x = b``; ``b`` has shape (n,) or (n, k)."""
        b = np.asarray(b, dtype=float)
        if b.shape[:1] != (self.lu.shape[0],) or b.ndim > 2:
            raise ValueError(f"LUFactor.solve: right-hand side of shape {b.shape} for a matrix of order {self.n}")
        rb = self.row_scale * b if b.ndim == 1 else self.row_scale[:, None] * b
        if rb.size == 0:
            return rb
        # LAPACK getrs directly: scipy.linalg.lu_solve adds checks and copies that cost as much as
        # the solve itself for the small systems of low harmonic counts
        x, info = _GETRS(self.lu, self.piv, rb, overwrite_b=True)
        if info != 0:  # pragma: no cover - invalid argument, cannot happen here
            raise ValueError(f"LAPACK getrs failed (info={info})")
        return x

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
    n = a.shape[0]
    if n == 0:
        return LUFactor(lu=np.zeros((0, 0), order="F"), piv=np.zeros(0, dtype=np.int32), row_scale=np.ones(0),
                        anorm=0.0)
    # getrf works in place on a Fortran-ordered array; handed a C-ordered one, f2py makes a
    # transposed copy that cost as much as the factorisation itself for orders of a few hundred
    work = np.empty((n, n), order="F")
    row_scale = np.empty(n)
    status, anorm = _equilibrated_copy(np.ascontiguousarray(a), bool(equilibrate), work, row_scale)
    if status < 0:
        raise SingularMatrixError("non-finite entries in the matrix")
    if status > 0:
        raise SingularMatrixError(f"zero row {status - 1}")
    lu, piv, info = _GETRF(work, overwrite_a=True)
    if info > 0:
        raise SingularMatrixError(f"zero pivot in column {info - 1}")
    if info < 0:  # pragma: no cover - invalid argument, cannot happen here
        raise SingularMatrixError(f"LAPACK getrf failed (info={info})")
    return LUFactor(lu=lu, piv=piv, row_scale=row_scale, anorm=anorm)


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
    factorizations : int
        LU factorisations performed (updates that reused the previous one are
        chord steps; ``factor_final`` counts one more).
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
    factorizations: int = 0


#: Within this factor of the tolerance an iteration at its rounding floor is not stopped as stalled.
STALL_FLOOR = 1e3


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
    reuse_lu: bool = True,
    lu0: LUFactor | None = None,
    backtrack: int = 0,
    stall: int | None = None,
) -> NewtonResult:
    """Newton's method for ``F(x) = 0``.

    Convergence criterion: ``||F(x)||_inf <= tol``. If ``xtol`` is given, the
    last update must in addition satisfy ``||dx / x_scale||_inf <= xtol``
    (a stricter test; an initial guess that already meets ``tol`` needs no
    update).

    The Jacobian is refactorised at every iterate (full Newton) except where
    a chord step with the previous factorisation is predicted to finish the
    iteration in the same number of updates (``reuse_lu``). With the
    observed contraction ``q = r_k / r_{k-1}`` of the residual, a full Newton
    step reduces the error by about ``q^2`` and a chord step with the
    factorisation of ``J(x_{k-1})`` by about ``q`` (the Jacobian error
    ``J(x_k) - J(x_{k-1})`` is of the order of the last update); the chord step
    is taken when ``q r_k <= tol / 10``, so it is expected to converge where
    Newton would (at most two chord steps in a row). Convergence is still
    decided on the residual itself; if a chord step falls short, its observed
    contraction decides the next update, which refactorises (the fall back
    to full Newton) unless that contraction predicts convergence. The LU is the dominant cost
    of an update for large systems, and a corrector that converges in two or
    three updates saves one factorisation out of three or four.

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
    reuse_lu : bool
        Allow the chord steps described here (False: full Newton throughout).
    lu0 : LUFactor, optional
        A factorisation of a matrix close to ``J(x0)``, for example the final
        one of the previous point of a continuation (whose Jacobian the
        predictor moved away from by one step): the first update is a chord
        step with it, saving the factorisation at ``x0``. If that update does
        not reduce the residual it is undone (one more evaluation, at ``x0``,
        restores the caller's state) and the iteration goes on as full Newton,
        so a poor ``lu0`` costs two evaluations, never convergence.
    stall : int, optional
        Stop, unconverged, after this many consecutive updates none of which
        reached a smaller residual than the best so far: Newton outside its
        basin, or cycling on a residual that is only piecewise smooth, rarely
        recovers, and a continuation step is cheaper to retry shorter. Even
        slow linear convergence makes a new best at every update; an
        iteration whose best is within ``STALL_FLOOR`` times ``tol`` (at the
        rounding floor of its residual) goes on to ``max_iter``.
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
    n_lu = 0
    lu = None  # the last factorisation made here (its rcond is reported)
    step_lu = None  # the factorisation used for chord steps

    def last_rcond():
        # the condition estimate of the last factorisation only (LUFactor computes it on access)
        return lu.rcond if lu is not None else float("nan")

    def fail(message, best, F=None, J=None, k=0, singular=False):
        return NewtonResult(
            x=best[0].copy(),
            converged=False,
            iterations=k,
            residual_norm=best[1],
            message=message,
            residual=F,
            jacobian=J,
            rcond=last_rcond(),
            residual_history=tuple(history),
            singular=singular,
            factorizations=n_lu,
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
    given = lu0 if reuse_lu else None  # the caller's factorisation, tried on the first update
    step_lu = given
    chords = 0  # consecutive chord steps
    no_best = 0  # consecutive updates without a new smallest residual
    while True:
        if r <= tol and (xtol is None or step_norm is None or step_norm <= xtol):
            break
        if k >= max_iter:
            return fail(f"residual {r:.1e} after {k} iterations", best, F, J, k)
        q = history[-1] / history[-2] if k >= 1 and history[-2] > 0 else math.inf
        trial = given is not None and k == 0
        if k == 1 and given is not None:
            # measured on the rotor: after a chord step with a factorisation from elsewhere, the
            # contraction of that step says nothing about the next one (it made the residual grow)
            step_lu = given = None
        chord = trial or (reuse_lu and step_lu is not None and chords < 2 and q < 1.0 and q * r <= 0.1 * tol)
        if not chord:
            try:
                lu = factorize(J, equilibrate=equilibrate)
            except SingularMatrixError as exc:
                return fail(f"singular Jacobian at iteration {k} ({exc})", best, F, J, k, True)
            n_lu += 1
            step_lu = lu
            chords = 0
            if rcond_min > 0 and lu.rcond < rcond_min:
                return fail(
                    f"singular Jacobian at iteration {k} (rcond={lu.rcond:.1e} < {rcond_min:.1e})",
                    best, F, J, k, True,
                )
        else:
            chords += 1
        dx = step_lu.solve(-F)
        if not np.all(np.isfinite(dx)):
            if trial:
                given = step_lu = None  # the caller's factorisation does not fit: factorise here
                chords = 0
                continue
            return fail(f"singular Jacobian at iteration {k} (non-finite update)", best, F, J, k, True)
        x_old, r_old = x.copy() if backtrack else None, r
        x += dx
        k += 1
        step_norm = _inf_norm(dx / scale)
        F, J, err = evaluate(x)
        if trial and (err is not None or not np.all(np.isfinite(F)) or _inf_norm(F) >= r):
            # the caller's factorisation did not reduce the residual: undo the step (one evaluation
            # more to restore the caller's state at x0) and go on as full Newton from x0
            x -= dx
            k -= 1
            step_norm = None
            given = step_lu = None
            chords = 0
            F, J, err = evaluate(x)
            if err is not None:  # pragma: no cover - evaluated fine a moment ago
                return fail(f"evaluation failed at the initial guess ({err})", best, None, None, k)
            continue
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
            no_best = 0
        else:
            no_best += 1
            if stall is not None and no_best >= stall and best[1] > STALL_FLOOR * tol:
                return fail(f"residual {best[1]:.1e} not improved in {no_best} iterations (stalled; at {r:.1e} "
                            f"after {k} iterations)", best, F, J, k)
        if r > divergence_factor * max(r0, tol):
            return fail(
                f"residual grew from {r0:.1e} to {r:.1e} at iteration {k} (diverging)", best, F, J, k
            )

    message = f"converged: residual {r:.1e} after {k} iterations"
    lu_final = None
    if factor_final:
        try:
            lu_final = factorize(J, equilibrate=equilibrate)
            n_lu += 1
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
        rcond=lu_final.rcond if lu_final is not None else last_rcond(),
        residual_history=tuple(history),
        factorizations=n_lu,
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
