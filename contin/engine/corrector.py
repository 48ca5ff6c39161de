"""The corrector: Newton on the bordered system, and the tests a converged step must pass.

A step from the point ``x`` (scaled, shape (m+1,)) with unit tangent ``t``
predicts ``xp = x + ds t`` and solves the bordered system
``[R(u, lam) = 0; t . (x - xp) = 0]``. The result is a :class:`Candidate`
if it passes the checks of :meth:`Corrector.check` (it stayed within a step
of the prediction, lies ahead, its tangent turned less than
``max_angle_deg``, its chord is an arc of the branch: :func:`secant_offset`);
otherwise the step raises :class:`StepFailed` and is retried shorter.
:class:`Failure` ends the branch with a status.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from contin.engine.branch import BranchStatus
from contin.engine.events import Event
from contin.engine.newton import LUFactor, NewtonResult, SingularMatrixError, factorize, newton
from contin.engine.predictor import last_unit_vector, predict, unit_tangent
from contin.engine.problem import ScaledProblem, bordered_matrix

__all__ = ["Candidate", "Corrector", "Failure", "StepFailed", "cycles", "format_parameter", "secant_offset"]

#: Slack (radians) and corrector accuracy (scaled length) of the chord test of :func:`secant_offset`.
SECANT_SLACK = 2e-3
SECANT_ACCURACY = 1e-8
#: Smallest tangent component and chord fraction for the monotonicity test of the chord.
SECANT_MONOTONE = 1e-3

#: A corrector stops after this many updates without a new smallest residual (the step is then
#: retried shorter): Newton meandering on a piecewise-smooth residual costs more than a shorter step.
NEWTON_STALL = 3
#: Step halvings of the retry of a cycling corrector.
BACKTRACK_HALVINGS = 4

#: Newton updates of a solve expected to fail where there is no solution (beyond a barrier), and
#: its stall limit.
QUICK_ITER = 8
QUICK_STALL = 2

#: A converged corrector may lie this many ``ds_min`` from its prediction, however short the step.
DISTANCE_FLOOR = 10


def format_parameter(name: str, lam: float) -> str:
    """``name=value`` as the engine's messages write a parameter value."""
    return f"{name}={lam:.10g}"


def cycles(history) -> bool:
    """Whether a residual history went up at least twice (Newton cycling, not slow convergence)."""
    h = np.asarray(history, dtype=float)
    return h.size >= 4 and int(np.count_nonzero(h[1:] > h[:-1])) >= 2


class Failure(Exception):
    """A numerical failure ending the branch with a status."""

    def __init__(self, status: BranchStatus, message: str):
        super().__init__(message)
        self.status = status
        self.message = message


@dataclasses.dataclass(eq=False)
class Candidate:
    """A converged, checked new point (not yet stored)."""

    x: np.ndarray  # scaled (m+1,)
    u: np.ndarray
    lam: float
    tangent: np.ndarray
    lu: LUFactor
    R: np.ndarray
    Ju: np.ndarray
    Jlam: np.ndarray
    iterations: int
    h: float  # pseudo-arclength from the previous point
    ds: float
    landed: bool = False
    kink: tuple | None = None  # (angle, ds, first angle, first ds) when accepted as a corner
    barrier: Event | None = None  # the barrier event this point was located on


class StepFailed(Exception):
    """A step that failed (the step control retries it shorter).

    Attributes
    ----------
    reason : str
    rcond : float
        Condition estimate of the last bordered matrix (NaN if none).
    turn : tuple or None
        ``(angle_deg, ds, candidate)`` when the only fault was the tangent's
        turn (the corner test reads it).
    """

    def __init__(self, reason: str, rcond: float = math.nan, turn=None):
        super().__init__(reason)
        self.reason = reason
        self.rcond = rcond
        self.turn = turn


def secant_offset(x: np.ndarray, t: np.ndarray, x_new: np.ndarray, t_new: np.ndarray, theta: float,
                  name: str) -> str | None:
    """Why the chord from ``x`` to ``x_new`` is not an arc of the branch, or None.

    Along a smooth arc whose tangent turns by ``theta`` (from ``t`` to
    ``t_new``) the chord lies between the end tangents (along their bisector
    for a circular arc). A corrector that landed on a neighbouring sheet (two
    branches closer than one step, as beside the backbone of a lightly damped
    resonance) has both end tangents nearly parallel yet a chord leaning
    sideways: the angle between the chord and the bisector exceeds
    ``2 theta`` plus a slack for the corrector's accuracy.

    Parameters
    ----------
    x, t, x_new, t_new : ndarray, shape (m+1,)
        Scaled end points and their unit tangents.
    theta : float
        Angle between the tangents, radians.
    name : str
        The parameter's name (for the message).
    """
    d = x_new - x
    L = float(np.linalg.norm(d))
    b = t + t_new
    nb = float(np.linalg.norm(b))
    if L == 0.0 or nb == 0.0:
        return None
    phi = math.acos(float(np.clip(abs(d @ b) / (L * nb), -1.0, 1.0)))
    if phi > 2.0 * theta + SECANT_SLACK + SECANT_ACCURACY / L:
        return (f"the chord leans {math.degrees(phi):.2f} deg off the tangents, which turned by "
                f"{math.degrees(theta):.2f} deg (a jump to a neighbouring branch?)")
    # a variable that both end tangents say increases (by a clear margin) cannot decrease
    # along a resolved arc: either the step holds two turning points of that variable, or
    # it jumped across a gap between two sheets (beside the backbone of a lightly damped
    # resonance: the response sheets on either side of a1 = 0); a shorter step tells which
    # (when the tangent turns along a great circle, as over a short arc, each component
    # stays between its end values: same signs at both ends, the same sign all along)
    against = (t * t_new > 0) & (np.minimum(np.abs(t), np.abs(t_new)) >= SECANT_MONOTONE) \
        & (d * t < 0) & (np.abs(d) >= SECANT_MONOTONE * L + SECANT_ACCURACY)
    if against.any():
        i = int(np.flatnonzero(against)[0])
        what = name if i == x.size - 1 else f"unknown {i}"
        return f"{what} moved against both end tangents over the step (a jump, or two turns in one step)"
    return None


class Corrector:
    """Newton solves of the engine, on the problem in scaled variables.

    Parameters
    ----------
    options : ContinuationOptions
    name : str
        The parameter's name (for messages).
    m : int
        Number of unknowns.

    Attributes
    ----------
    sp : ScaledProblem or None
        The problem in the current scales (set by the engine at the start
        and on a restart).
    n_newton : int
        Newton updates so far.
    n_backtracked : int
        Correctors retried with step halving.
    """

    def __init__(self, options, name: str, m: int):
        self.opt = options
        self.name = name
        self.m = m
        self.sp: ScaledProblem | None = None
        self.n_newton = 0
        self.n_backtracked = 0
        self.e_last = last_unit_vector(m)

    # -- solves ----------------------------------------------------------
    def newton(self, fun_and_jac, guess: np.ndarray, **kw) -> NewtonResult:
        """Newton, retried with step halving when plain Newton cycles.

        A residual that is only piecewise smooth (stiff contact sampled by the
        AFT: the Jacobian jumps where a sample crosses the clearance) makes
        full Newton alternate between two pieces, the residual going up and
        down without converging; halving the updates breaks most cycles.
        Smooth problems never pay for it: the retry happens only after such
        a failure. A lazy Jacobian (shooting) is not retried: its residual is
        the flow map, piecewise smooth only where the step crosses a grazing
        corner, which a shorter step passes (the engine's corner step) and
        halved updates seldom do, at the cost of more flows
        (docs/benchmarks.md).
        """
        opt = self.opt
        res = newton(fun_and_jac, guess, opt.newton_tol, opt.newton_max_iter, stall=NEWTON_STALL, **kw)
        self.n_newton += res.iterations
        if res.converged or res.singular or not cycles(res.residual_history):
            return res
        if "residual" in kw:  # a lazy Jacobian
            return res
        self.n_backtracked += 1
        res = newton(fun_and_jac, guess, opt.newton_tol, opt.newton_max_iter, backtrack=BACKTRACK_HALVINGS,
                     stall=NEWTON_STALL, **kw)
        self.n_newton += res.iterations
        return res

    def _chord_lu(self, chord, normal: np.ndarray | None = None) -> LUFactor | None:
        """With a lazy Jacobian, the factorisation of the Jacobian ``chord = (Ju, Jlam)`` of a nearby point
        (bordered by ``normal`` when given) for the first chord steps; None otherwise or if singular."""
        sp = self.sp
        if chord is None or not sp.lazy:
            return None
        Ju, Jlam = chord
        try:
            return factorize(Ju if normal is None else bordered_matrix(Ju, Jlam, sp.su, sp.sl, normal))
        except SingularMatrixError:
            return None

    def bordered_solve(self, guess: np.ndarray, x_ref: np.ndarray, normal: np.ndarray, offset: float, lu0=None,
                       quick: bool = False, chord=None, light: bool = False) -> NewtonResult:
        """Newton on ``[R = 0; normal . (x - x_ref) = offset]`` from ``guess`` (all (m+1,), scaled).

        ``lu0``: see :func:`~contin.engine.newton.newton`; ``quick``: a solve
        expected to fail where there is no solution, given fewer updates and
        no retry; ``chord``: ``(Ju, Jlam)`` (unscaled) of a nearby point, whose
        bordered matrix a lazy Jacobian starts with (:data:`~contin.engine.problem.LAZY_COST`).
        The result's ``lu`` factorises the bordered matrix at the solution; with a lazy Jacobian and ``light``,
        the solution is not linearised (``jacobian`` None, ``sp.last`` unchanged) and ``lu`` is the
        factorisation the last updates used.
        """
        sp, m = self.sp, self.m
        F = np.empty(m + 1)
        A = np.empty((m + 1, m + 1))
        A[m] = normal

        def fun_and_jac(x):
            R, Jh = sp.scaled(x)
            F[:m] = R
            F[m] = normal @ (x - x_ref) - offset
            A[:m] = Jh
            return F, A

        def residual(x):
            F[:m] = sp.residual_at(x[:m] * sp.su, float(x[m] * sp.sl))
            F[m] = normal @ (x - x_ref) - offset
            return F

        lazy = {"residual": residual} if sp.lazy else {}
        if lu0 is None:
            lu0 = self._chord_lu(chord, normal)
        if quick:
            opt = self.opt
            res = newton(fun_and_jac, guess, opt.newton_tol, min(opt.newton_max_iter, QUICK_ITER), stall=QUICK_STALL,
                         factor_final=True, lu0=lu0, **lazy)
            self.n_newton += res.iterations
            return res
        if light and sp.lazy:
            lazy["jacobian_at_solution"] = False
        return self.newton(fun_and_jac, guess, factor_final=True, lu0=lu0, **lazy)

    def fixed_solve(self, lam: float, u_guess: np.ndarray, chord=None) -> NewtonResult:
        """Newton in ``u`` (m,) at the fixed parameter ``lam`` (unscaled); ``chord`` as for
        :meth:`bordered_solve`."""
        sp = self.sp

        def fun_and_jac(u):
            R, Ju, _ = sp.evaluate(u, lam)
            return R, Ju

        lazy = {"residual": lambda u: sp.residual_at(u, lam)} if sp.lazy else {}
        return self.newton(fun_and_jac, u_guess, lu0=self._chord_lu(chord), **lazy)

    # -- steps -----------------------------------------------------------
    def effort(self, res: NewtonResult) -> int:
        """The updates a solve counts for the step control: with a lazy Jacobian, whose chord steps go on at
        a contraction plain Newton would have ended with a new factorisation, two chord steps count one."""
        return res.iterations - res.chord_steps // 2 if self.sp.lazy else res.iterations

    def check(self, x: np.ndarray, t: np.ndarray, x_new: np.ndarray, xp: np.ndarray, ds: float,
              lu: LUFactor | None, rcond: float, iterations: int, *, landed: bool = False,
              across: bool = False) -> Candidate:
        """Tangent, angle and distance checks of a converged corrector; the candidate, or :class:`StepFailed`.

        Parameters
        ----------
        x, t : ndarray, shape (m+1,)
            The point the step started from and its unit tangent.
        x_new, xp : ndarray, shape (m+1,)
            The converged point (``sp.last`` holds its evaluation) and the prediction.
        ds : float
            The step.
        lu : LUFactor or None
            The bordered matrix at ``x_new`` (None: singular).
        rcond : float
            Reported with a failure.
        iterations : int
        landed : bool
            A solve at a fixed parameter onto a range end: the point may be
            within rounding of ``x``, and the chord test does not apply.
        across : bool
            A step across a corner (no chord test either).
        """
        if lu is None:
            raise StepFailed("singular bordered Jacobian at the new point", 0.0)
        dist = float(np.linalg.norm(x_new - xp))
        if dist > max(ds, DISTANCE_FLOOR * self.opt.ds_min):
            raise StepFailed(f"corrector moved {dist / ds:.2g} step lengths from the prediction", rcond)
        t_new = unit_tangent(lu, self.e_last)
        if t_new is None:
            raise StepFailed("non-finite tangent", lu.rcond)
        cosang = float(np.clip(t @ t_new, -1.0, 1.0))
        angle = math.degrees(math.acos(cosang))
        u, lam, R, Ju, Jlam = self.sp.last
        h = float(t @ (x_new - x))
        if landed or across:
            h = max(h, 0.0)  # the end may be within rounding of the current point
        elif not h > 0:
            raise StepFailed("the new point is not ahead of the previous one", rcond)
        cand = Candidate(
            x=x_new, u=np.array(u, dtype=float), lam=float(lam), tangent=t_new, lu=lu, R=R, Ju=Ju, Jlam=Jlam,
            iterations=iterations, h=h, ds=ds, landed=landed,
        )
        if angle > self.opt.max_angle_deg:
            raise StepFailed(f"tangent turned by {angle:.1f} deg > {self.opt.max_angle_deg:g} deg", rcond,
                             turn=(angle, ds, cand))
        if not (landed or across):
            off = secant_offset(x, t, x_new, t_new, math.radians(angle), self.name)
            if off is not None:
                raise StepFailed(off, rcond)
        return cand

    def step(self, x: np.ndarray, t: np.ndarray, ds: float, chord=None) -> Candidate:
        """The pseudo-arclength step of length ``ds`` from ``x`` along ``t`` (both (m+1,)); ``chord``: the
        linearisation ``(Ju, Jlam)`` at ``x`` (see :meth:`bordered_solve`)."""
        xp = predict(x, t, ds)
        res = self.bordered_solve(xp.copy(), xp, t, 0.0, chord=chord)
        if not res.converged:
            raise StepFailed(f"Newton did not converge ({res.message})", res.rcond)
        return self.check(x, t, res.x, xp, ds, res.lu, res.rcond, self.effort(res))

    def land(self, x: np.ndarray, t: np.ndarray, end: float, ds: float, guess_x: np.ndarray, *, landed: bool = True,
             across: bool = False, chord=None) -> Candidate:
        """Newton at the fixed parameter ``lam = end`` from ``guess_x`` (scaled, (m+1,), its parameter ``end``).

        ``x``, ``t``: the point the step started from and its tangent (the
        bordering row of the new point's matrix); ``landed``: onto a range
        end; ``across``: a step across a corner (see :meth:`check`);
        ``chord``: as for :meth:`step`.
        """
        sp, m = self.sp, self.m
        res = self.fixed_solve(end, guess_x[:m] * sp.su, chord=chord)
        if not res.converged:
            where = "at the range end" if landed else "at"
            raise StepFailed(f"Newton did not converge {where} {format_parameter(self.name, end)} ({res.message})",
                             res.rcond)
        u, _, R, Ju, Jlam = sp.last  # evaluated at the converged u
        x_new = np.empty(m + 1)
        x_new[:m] = u / sp.su
        x_new[m] = end / sp.sl
        try:
            lu = factorize(bordered_matrix(Ju, Jlam, sp.su, sp.sl, t))
        except SingularMatrixError:
            lu = None
        return self.check(x, t, x_new, guess_x, ds, lu, res.rcond, self.effort(res), landed=landed, across=across)
