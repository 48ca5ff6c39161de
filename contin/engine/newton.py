"""Newton's method for ``F(x) = 0``, as the continuation engine uses it.

Everything here is generic: a Newton iteration on ``F(x) = 0`` given a
callable returning ``(F, J)`` (:func:`newton`), and :func:`solve_at_parameter`,
the plain Newton iteration in ``u`` at a fixed parameter for any object
following the :class:`contin.engine.problem.Problem` protocol. The dense
factorisations live in :mod:`contin.engine.linalg` (re-exported here).

:func:`newton` is a short loop over the pieces of one iteration
(:class:`_Iteration`): the convergence test, the choice between a full
Newton update and a chord step reusing a factorisation (Jacobian reuse,
including a factorisation the caller hands in), the update with its
optional step halving (a backtracking line search), and the residual's
bookkeeping (best iterate, stall and divergence tests).

Numerical trouble (non-finite values, singular matrices, divergence, and
``ArithmeticError`` / ``numpy.linalg.LinAlgError`` raised by the evaluated
function) never raises: it is reported through ``NewtonResult.converged`` and
``NewtonResult.message``. Other exceptions (programming errors) propagate.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Callable

import numpy as np

from contin.engine.linalg import LUFactor, SingularMatrixError, factorize

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
    jacobians : int
        Evaluations of the Jacobian (with a lazy Jacobian, fewer than the
        evaluations of the residual).
    chord_steps : int
        Updates that reused a factorisation.
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
    jacobians: int = 0
    chord_steps: int = 0


#: Within this factor of the tolerance an iteration at its rounding floor is not stopped as stalled.
STALL_FLOOR = 1e3


#: A chord step is taken when the observed contraction predicts convergence within this fraction of ``tol``.
CHORD_MARGIN = 0.1
#: Largest number of chord steps in a row.
MAX_CHORDS = 2
#: With a lazy Jacobian (a residual much cheaper than the Jacobian: shooting), chord steps go on while
#: each reduces the residual by at least this factor and the iterations left suffice at that rate ...
LAZY_CONTRACTION = 0.5
#: ... at most this many in a row.
LAZY_MAX_CHORDS = 10


def _inf_norm(v: np.ndarray) -> float:
    """``||v||_inf`` (0 for an empty vector)."""
    return float(np.max(np.abs(v))) if v.size else 0.0


def _evaluate(fun_and_jac, x: np.ndarray, residual=None):
    """``(F, J, None)`` at ``x`` (``F`` flattened, both float arrays), or ``(None, None, why)`` when the
    evaluation raised one of :data:`NUMERICAL_ERRORS`. With ``residual`` (``F`` alone) ``J`` is None."""
    try:
        if residual is not None:
            return np.asarray(residual(x), dtype=float).reshape(-1), None, None
        F, J = fun_and_jac(x)
    except NUMERICAL_ERRORS as exc:
        return None, None, f"{type(exc).__name__}: {exc}"
    return np.asarray(F, dtype=float).reshape(-1), np.asarray(J, dtype=float), None


class _Iteration:
    """The state of one run of :func:`newton` and the pieces of its loop.

    ``x`` is updated in place (the array ``fun_and_jac`` sees); ``F`` and
    ``J`` are the latest evaluation, ``r = ||F||_inf`` the residual of the
    accepted iterate, ``history`` all of them, ``best`` the finite iterate
    with the smallest residual, ``k`` the number of updates. With a lazy
    Jacobian (``residual`` given) the iterates are evaluated by ``residual``
    and ``J`` is None until a factorisation or the result needs it.
    """

    def __init__(self, fun_and_jac, x: np.ndarray, scale, reuse_lu: bool, lu0: LUFactor | None, max_iter: int,
                 residual=None):
        self.fun_and_jac = fun_and_jac
        self.max_iter = max_iter
        self.residual = residual
        self.lazy = residual is not None
        self.x = x
        self.scale = scale
        self.reuse_lu = reuse_lu
        self.history: list[float] = []
        self.n_lu = 0
        self.lu: LUFactor | None = None  # the last factorisation made here (its rcond is reported)
        self.F = self.J = None
        self.err: str | None = None  # why the latest evaluation failed
        self.r = self.r0 = math.inf
        self.best = (x, math.inf)
        self.k = 0
        self.step_norm: float | None = None
        self.given = lu0 if reuse_lu else None  # the caller's factorisation, tried on the first update
        self.step_lu = self.given  # the factorisation used for chord steps
        self.chords = 0  # consecutive chord steps
        self.no_best = 0  # consecutive updates without a new smallest residual
        self.jacobians = 0  # evaluations of the Jacobian
        self.chord_steps = 0  # updates with a factorisation made before

    def evaluate(self, x: np.ndarray, jacobian: bool = False):
        """``(F, J, why)`` at ``x``: ``J`` None in lazy mode unless ``jacobian``."""
        lazy = self.lazy and not jacobian
        if not lazy:
            self.jacobians += 1
        return _evaluate(self.fun_and_jac, x, self.residual if lazy else None)

    def ensure_jacobian(self) -> str | None:
        """Evaluate the Jacobian at ``x`` if it is not at hand (lazy mode); why it failed, else None."""
        if self.J is not None:
            return None
        F, J, err = self.evaluate(self.x, jacobian=True)
        if err is None:
            self.F, self.J = F, J
        return err

    # -- results ---------------------------------------------------------
    def failure(self, message: str, F=None, J=None, singular: bool = False) -> NewtonResult:
        """The unconverged result: the best iterate, with ``F`` and ``J`` as given."""
        return NewtonResult(
            x=self.best[0].copy(),
            converged=False,
            iterations=self.k,
            residual_norm=self.best[1],
            message=message,
            residual=F,
            jacobian=J,
            rcond=self.last_rcond(),
            residual_history=tuple(self.history),
            singular=singular,
            factorizations=self.n_lu,
            jacobians=self.jacobians,
            chord_steps=self.chord_steps,
        )

    def success(self, factor_final: bool, equilibrate: bool, jacobian_at_solution: bool = True) -> NewtonResult:
        """The converged result (with the factorisation at the solution when ``factor_final``).

        A lazy iteration evaluates the Jacobian at the solution here (the
        result carries it, and the caller reads the linearisation there),
        unless ``jacobian_at_solution`` is False and its updates used a
        factorisation: the result then has no Jacobian and, as ``lu``, that
        factorisation (of a nearby point's matrix).
        """
        message = f"converged: residual {self.r:.1e} after {self.k} iterations"
        if self.lazy and not jacobian_at_solution and self.step_lu is not None:
            lu_final, jacobian = self.step_lu, None
            message += " (no Jacobian at the solution)"
        else:
            err = self.ensure_jacobian()
            if err is not None:
                return self.failure(f"evaluation of the Jacobian failed at the solution ({err})", self.F)
            lu_final, jacobian = None, self.J
            if factor_final:
                try:
                    lu_final = factorize(self.J, equilibrate=equilibrate)
                    self.n_lu += 1
                except SingularMatrixError as exc:
                    message += f"; singular Jacobian at the solution ({exc})"
        return NewtonResult(
            x=self.x,
            converged=True,
            iterations=self.k,
            residual_norm=self.r,
            message=message,
            residual=self.F,
            jacobian=jacobian,
            lu=lu_final,
            rcond=lu_final.rcond if lu_final is not None else self.last_rcond(),
            residual_history=tuple(self.history),
            factorizations=self.n_lu,
            jacobians=self.jacobians,
            chord_steps=self.chord_steps,
        )

    def last_rcond(self) -> float:
        """The condition estimate of the last factorisation only (LUFactor computes it on access)."""
        return self.lu.rcond if self.lu is not None else float("nan")

    # -- the pieces of an iteration -----------------------------------------
    def start(self) -> NewtonResult | None:
        """Evaluate at the initial guess; the failure if the iteration cannot start, else None.

        A lazy iteration without a factorisation of its own needs the
        Jacobian at the guess for its first update anyway: evaluated at once.
        """
        self.F, self.J, self.err = self.evaluate(self.x, jacobian=self.given is None)
        if self.err is not None:
            return self.failure(f"evaluation failed at the initial guess ({self.err})")
        if not np.all(np.isfinite(self.F)):
            return self.failure("non-finite residual at the initial guess", self.F, self.J)
        self.r = _inf_norm(self.F)
        self.history.append(self.r)
        self.r0 = self.r
        self.best = (self.x.copy(), self.r)
        return None

    def converged(self, tol: float, xtol: float | None) -> bool:
        """``||F||_inf <= tol``, and with ``xtol`` the last scaled update within it (none needed at the guess)."""
        return self.r <= tol and (xtol is None or self.step_norm is None or self.step_norm <= xtol)

    def chord_step(self, tol: float) -> tuple[bool, bool]:
        """Whether the next update reuses a factorisation; ``(chord, trial)``.

        ``trial``: the first update, with the caller's factorisation. Else a
        chord step with the last factorisation is taken when the observed
        contraction ``q = r_k / r_{k-1}`` predicts convergence (``q r_k``
        within ``CHORD_MARGIN`` of ``tol``), at most ``MAX_CHORDS`` in a row.
        """
        history, k = self.history, self.k
        q = history[-1] / history[-2] if k >= 1 and history[-2] > 0 else math.inf
        trial = self.given is not None and k == 0
        if self.lazy:
            return trial or self.lazy_chord(q, tol), trial
        if k == 1 and self.given is not None:
            # measured on the rotor: after a chord step with a factorisation from elsewhere, the
            # contraction of that step says nothing about the next one (it made the residual grow)
            self.step_lu = self.given = None
        chord = trial or (self.reuse_lu and self.step_lu is not None and self.chords < MAX_CHORDS and q < 1.0
                          and q * self.r <= CHORD_MARGIN * tol)
        return chord, trial

    def lazy_chord(self, q: float, tol: float) -> bool:
        """With a lazy Jacobian: a chord step while the last update contracted the residual by ``q <=
        LAZY_CONTRACTION`` and the iterations left would finish at that rate (a step after a fresh
        factorisation contracts faster still), at most ``LAZY_MAX_CHORDS`` in a row."""
        if self.step_lu is None or self.chords >= LAZY_MAX_CHORDS or not q <= LAZY_CONTRACTION:
            return False
        if self.r <= tol:
            return True
        needed = math.log(tol / self.r) / math.log(q) if q > 0 else 1.0
        return needed <= self.max_iter - self.k

    def refactorize(self, equilibrate: bool, rcond_min: float) -> NewtonResult | None:
        """Factorise ``J`` here for a full Newton update; the failure if it is singular, else None."""
        err = self.ensure_jacobian()
        if err is not None:
            return self.failure(f"evaluation failed at iteration {self.k} ({err})", self.F)
        try:
            lu = factorize(self.J, equilibrate=equilibrate)
        except SingularMatrixError as exc:
            return self.failure(f"singular Jacobian at iteration {self.k} ({exc})", self.F, self.J, True)
        self.lu = lu
        self.n_lu += 1
        self.step_lu = lu
        self.chords = 0
        if rcond_min > 0 and lu.rcond < rcond_min:
            return self.failure(f"singular Jacobian at iteration {self.k} (rcond={lu.rcond:.1e} < {rcond_min:.1e})",
                                self.F, self.J, True)
        return None

    def drop_given(self) -> None:
        """Stop using the caller's factorisation: the next update factorises here."""
        self.given = self.step_lu = None
        self.chords = 0

    def update(self, dx: np.ndarray, backtrack: int) -> tuple[np.ndarray | None, float]:
        """Take the update ``dx`` and evaluate there; returns the iterate before it (a copy, only when
        backtracking) and its residual."""
        x = self.x
        x_old, r_old = x.copy() if backtrack else None, self.r
        x += dx
        self.k += 1
        self.step_norm = _inf_norm(dx / self.scale)
        self.F, self.J, self.err = self.evaluate(x)
        return x_old, r_old

    def trial_failed(self) -> bool:
        """Whether the update with the caller's factorisation failed to reduce the residual."""
        return self.err is not None or not np.all(np.isfinite(self.F)) or _inf_norm(self.F) >= self.r

    def undo(self, dx: np.ndarray) -> NewtonResult | None:
        """Undo the update ``dx`` with the caller's factorisation and go on as full Newton from the guess.

        One evaluation more restores the caller's state at the guess; returns
        the failure if it failed, else None.
        """
        self.x -= dx
        self.k -= 1
        self.step_norm = None
        self.drop_given()
        self.F, self.J, self.err = self.evaluate(self.x, jacobian=True)
        if self.err is not None:  # pragma: no cover - evaluated fine a moment ago
            return self.failure(f"evaluation failed at the initial guess ({self.err})")
        return None

    def line_search(self, x_old: np.ndarray | None, r_old: float, dx: np.ndarray, backtrack: int) -> None:
        """Halve the update (at most ``backtrack`` times) until the residual decreases below ``r_old``.

        An update that no halving improves is taken in full, as in plain
        Newton. ``dx`` is halved in place.
        """
        x = self.x
        halvings = 0
        while (backtrack and halvings < backtrack and self.err is None
               and not (np.all(np.isfinite(self.F)) and _inf_norm(self.F) < r_old)):
            halvings += 1
            dx *= 0.5
            np.add(x_old, dx, out=x)
            F2, J2, err2 = self.evaluate(x)
            if err2 is None and np.all(np.isfinite(F2)) and _inf_norm(F2) < r_old:
                self.F, self.J, self.err = F2, J2, None
                self.step_norm = _inf_norm(dx / self.scale)
                break
            if halvings == backtrack:  # nothing better: the full update, as plain Newton would
                x[:] = x_old + 2.0 ** backtrack * dx
                self.F, self.J, self.err = self.evaluate(x)

    def record(self, tol: float, stall: int | None, divergence_factor: float) -> NewtonResult | None:
        """Take the new residual into the history and the best iterate; the failure if the iteration
        stops here (a failed evaluation, a non-finite residual, a stall, divergence), else None."""
        if self.err is not None:
            return self.failure(f"evaluation failed at iteration {self.k} ({self.err})")
        if not np.all(np.isfinite(self.F)):
            return self.failure(f"non-finite residual at iteration {self.k}", self.F, self.J)
        r = self.r = _inf_norm(self.F)
        self.history.append(r)
        if r < self.best[1]:
            self.best = (self.x.copy(), r)
            self.no_best = 0
        else:
            self.no_best += 1
            if stall is not None and self.no_best >= stall and self.best[1] > STALL_FLOOR * tol:
                return self.failure(f"residual {self.best[1]:.1e} not improved in {self.no_best} iterations "
                                    f"(stalled; at {r:.1e} after {self.k} iterations)", self.F, self.J)
        if r > divergence_factor * max(self.r0, tol):
            return self.failure(f"residual grew from {self.r0:.1e} to {r:.1e} at iteration {self.k} (diverging)",
                                self.F, self.J)
        return None


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
    residual: Callable[[np.ndarray], np.ndarray] | None = None,
    jacobian_at_solution: bool = True,
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
    residual : callable, optional
        ``residual(x) -> F`` alone, for a problem whose Jacobian costs many
        residuals (shooting: a variational integration against a plain one).
        The Jacobian is then lazy: iterates are evaluated by ``residual``, the
        Jacobian only where an update factorises it (and at the solution,
        which the result carries), and chord steps go on while each reduces
        the residual by ``LAZY_CONTRACTION`` and the iterations left suffice
        (with ``lu0``, from the first update). Needs ``reuse_lu``.
    jacobian_at_solution : bool
        With a lazy Jacobian, False skips its evaluation at the solution: the
        result has ``jacobian`` None and, as ``lu``, the factorisation of the
        last updates (a point solved only for values that need no
        linearisation, such as an event's test while it is located).

    Returns
    -------
    NewtonResult
    """
    it = _Iteration(fun_and_jac, np.array(x0, dtype=float, copy=True).reshape(-1),
                    1.0 if x_scale is None else np.asarray(x_scale, dtype=float), reuse_lu, lu0, max_iter,
                    residual if reuse_lu else None)
    failed = it.start()
    if failed is not None:
        return failed
    while not it.converged(tol, xtol):
        if it.k >= max_iter:
            return it.failure(f"residual {it.r:.1e} after {it.k} iterations", it.F, it.J)
        chord, trial = it.chord_step(tol)
        if chord:
            it.chords += 1
            it.chord_steps += 1
        else:
            failed = it.refactorize(equilibrate, rcond_min)
            if failed is not None:
                return failed
        dx = it.step_lu.solve(-it.F)
        if not np.all(np.isfinite(dx)):
            if trial:
                it.drop_given()  # the caller's factorisation does not fit: factorise here
                continue
            return it.failure(f"singular Jacobian at iteration {it.k} (non-finite update)", it.F, it.J, singular=True)
        x_old, r_old = it.update(dx, backtrack)
        if trial and it.trial_failed():
            # the caller's factorisation did not reduce the residual: undo the step and go on as
            # full Newton from the guess
            failed = it.undo(dx)
            if failed is not None:  # pragma: no cover - evaluated fine a moment ago
                return failed
            continue
        it.line_search(x_old, r_old, dx, backtrack)
        failed = it.record(tol, stall, divergence_factor)
        if failed is not None:
            return failed
    return it.success(factor_final, equilibrate, jacobian_at_solution)


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
