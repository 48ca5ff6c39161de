"""Pseudo-arclength continuation of ``R(u, lam) = 0`` for any problem object.

The engine knows nothing about the origin of ``R``: it only calls the
:class:`Problem` protocol. It traces a branch of solutions ``(u, lam)``,
``u`` of shape (m,), from a start point, passing folds, detecting and locating
special points (events) and ending with a :class:`~contin.engine.branch.BranchStatus`
instead of raising on numerical trouble.

Method
------
- Scaled variables ``x = (u / su, lam / sl)`` (see :class:`Scaling`); the step
  size, the arclength and the tangents are in these coordinates.
- Predictor: Euler step ``x_pred = x + ds t`` along the unit tangent.
- Corrector: Newton on the bordered system
  ``[R(u, lam) = 0; t . (x - x_pred) = 0]`` (LU of the (m+1)x(m+1) matrix).
- New tangent: ``[[Ju su, Jlam sl], [t_old^T]] z = [0, 1]``, ``t = z/|z|``,
  which keeps the orientation through folds. The same factorisation gives
  the sign of the bordered determinant (branch-point test) and a condition
  estimate.
- Step control: growth by ``grow`` after easy steps, shrinking by ``shrink``
  after a failure (no convergence, a corrector moving farther than ``ds``
  from the prediction, or a tangent turning by more than ``max_angle_deg``,
  which prevents jumping onto another branch).
- Corners: a non-smooth problem (a contact that opens or closes, grazing)
  has branches whose tangent jumps. A smooth curve's turn shrinks with the
  step (``angle ~ curvature * ds``); a corner's does not. When the turn over
  a step ``corner_ratio`` times shorter than an earlier rejected one is still
  more than half as large, the step is accepted and a ``kink`` special point
  is recorded (``corners=True``); otherwise the step keeps shrinking.
- Range ends are landed on exactly (Newton at fixed ``lam = end``).
- Against jumps between neighbouring sheets closer than one step (a lightly
  damped resonance beside its backbone), a converged step is also rejected
  when its chord leans off the bisector of its end tangents by more than
  twice their turn, or when a variable moves against both end tangents; a
  branch that passes again through one of its earlier points, in the same
  direction, stops with ``CLOSED_LOOP`` and says so.
- Scaling: the automatic scalar scale follows the unknowns when they grow
  100-fold; dofs whose magnitudes differ by more than ``GROUP_SPREAD`` are
  scaled separately (``problem.unknown_groups()``).
- Newton that cycles between two pieces of a piecewise-smooth residual is
  retried with step halving (:meth:`_Engine._newton`).
- ``Branch.info`` reports ``max_condition`` (where: ``max_condition_parameter``)
  and ``last_condition``, LAPACK ``gecon`` estimates of the scaled bordered
  Jacobian, ``n_backtracked`` and ``rescalings``;
  :func:`connection_report` checks a finished branch for jumps.
"""

from __future__ import annotations

import collections
import collections.abc
import dataclasses
import difflib
import enum
import math
import numbers
from typing import Any, Callable, Iterable, Mapping, Protocol, runtime_checkable

import numpy as np

from contin.engine.branch import Branch, BranchBuilder, BranchStatus, PointRejected, SpecialKind, SpecialPoint
from contin.engine.events import (
    BranchPointEvent,
    Event,
    FoldEvent,
    PointInfo,
    changed_components,
    evaluate_test,
    narrow,
    predicted_zero,
)
from contin.util.naming import is_real
from contin.engine.newton import NUMERICAL_ERRORS, LUFactor, SingularMatrixError, factorize, newton

__all__ = ["ContinuationOptions", "Monitor", "Problem", "Scaling", "connection_report", "continuation"]


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
        groups whose magnitudes at the start are more than ``GROUP_SPREAD``
        apart are scaled separately.

    Numerical failures inside these methods should show up as non-finite
    values or as ``ArithmeticError`` / ``numpy.linalg.LinAlgError``; the
    engine treats both as a failed evaluation (the step is retried with a
    smaller step). Other exceptions are programming errors and propagate.
    """

    def residual(self, u: np.ndarray, lam: float) -> np.ndarray: ...

    def linearize(self, u: np.ndarray, lam: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]: ...


#: ``monitor(u, lam, Ju, Jlam) -> {name: float or ndarray}``, evaluated at every
#: stored and located point; values go to ``Branch.point_data`` and ``PointInfo.data``.
Monitor = Callable[[np.ndarray, float, np.ndarray, np.ndarray], Mapping[str, Any]]


class Scaling(str, enum.Enum):
    """Scaling of the variables.

    AUTO
        ``sl = hi - lo`` for a finite non-empty range, else ``max(|lam0|, 1)``;
        ``su = problem.unknown_scale()`` if available, else the single scalar
        ``||u_start||_inf`` (1 if the start is exactly zero, at least 1e-12)
        for all components.
    NONE
        ``su = 1``, ``sl = 1``.

    Explicit ``parameter_scale`` / ``unknown_scale`` options override both.
    """

    AUTO = "auto"
    NONE = "none"

    def __str__(self) -> str:
        return self.value


def _is_int(v) -> bool:
    return isinstance(v, numbers.Integral) and not isinstance(v, bool)


@dataclasses.dataclass(frozen=True)
class ContinuationOptions:
    """Options of :func:`continuation` (validated; use :meth:`replace` or
    :func:`dataclasses.replace` for changes, :meth:`from_dict` for
    configuration files).

    Attributes
    ----------
    ds : float
        Initial step, in scaled arclength units.
    ds_min, ds_max : float
        Step bounds; the branch stops with ``STEP_TOO_SMALL`` below ``ds_min``.
    max_points : int
        Maximum number of stored points (including the start).
    newton_tol : float
        Tolerance on ``||R||_inf`` (unscaled residual).
    newton_max_iter : int
        Maximum Newton updates per corrector.
    newton_easy : int
        A step converging in at most this many updates lets ``ds`` grow.
    grow, shrink : float
        Step growth (>= 1) and shrink (in (0, 1)) factors.
    max_angle_deg : float
        Largest accepted angle between consecutive tangents (scaled
        coordinates); larger turns reject the step.
    direction : int
        +1 or -1: sign of ``dlam`` at the start (ignored if a start tangent
        is given).
    scaling : Scaling
        ``AUTO`` or ``NONE`` (strings accepted).
    parameter_scale : float or None
        Explicit ``sl``.
    unknown_scale : float, sequence of float, or None
        Explicit ``su`` (scalar or one value per unknown; stored as a tuple).
    locate_tol : float
        Relative tolerance on the parameter for event location.
    locate_max_iter : int
        Maximum solves per located event.
    detect_folds, detect_branch_points : bool
        Enable the built-in fold / branch-point events.
    corners : bool
        Accept a tangent jump that persists as the step shrinks by
        ``corner_ratio`` (a corner of a non-smooth branch) and record it as a
        ``kink`` special point; False stops the branch there instead.
    corner_ratio : float
        Step reduction (> 1) over which a turn must persist to be a corner.
    stall_points : int
        The branch stops with ``STEP_TOO_SMALL`` when this many consecutive
        stored points together advanced less than ``ds_max`` (a crawl at a
        point the steps cannot pass, for example a tangential contact).
    """

    ds: float = 0.02
    ds_min: float = 1e-8
    ds_max: float = 0.2
    max_points: int = 2000
    newton_tol: float = 1e-10
    newton_max_iter: int = 12
    newton_easy: int = 4
    grow: float = 1.5
    shrink: float = 0.5
    max_angle_deg: float = 20.0
    direction: int = 1
    scaling: Scaling = Scaling.AUTO
    parameter_scale: float | None = None
    unknown_scale: Any = None
    locate_tol: float = 1e-10
    locate_max_iter: int = 60
    detect_folds: bool = True
    detect_branch_points: bool = True
    corners: bool = True
    corner_ratio: float = 8.0
    stall_points: int = 50

    def __post_init__(self):
        def bad(field, requirement, value):
            raise ValueError(f"ContinuationOptions.{field} must be {requirement}, got {value!r}")

        def positive(field):
            v = getattr(self, field)
            if not is_real(v) or not (math.isfinite(v) and v > 0):
                bad(field, "a positive finite number", v)

        positive("ds")
        if not is_real(self.ds_min) or not (self.ds_min > 0 and self.ds_min <= self.ds):
            bad("ds_min", "positive and <= ds", self.ds_min)
        if not is_real(self.ds_max) or not (math.isfinite(self.ds_max) and self.ds_max >= self.ds):
            bad("ds_max", "finite and >= ds", self.ds_max)
        if not _is_int(self.max_points) or self.max_points < 1:
            bad("max_points", "an integer >= 1", self.max_points)
        if not _is_int(self.stall_points) or self.stall_points < 2:
            bad("stall_points", "an integer >= 2", self.stall_points)
        positive("newton_tol")
        if not _is_int(self.newton_max_iter) or self.newton_max_iter < 1:
            bad("newton_max_iter", "an integer >= 1", self.newton_max_iter)
        if not _is_int(self.newton_easy) or self.newton_easy < 0:
            bad("newton_easy", "an integer >= 0", self.newton_easy)
        if not is_real(self.grow) or not (math.isfinite(self.grow) and self.grow >= 1):
            bad("grow", "a finite number >= 1", self.grow)
        if not is_real(self.shrink) or not (0 < self.shrink < 1):
            bad("shrink", "in (0, 1)", self.shrink)
        if not is_real(self.max_angle_deg) or not (0 < self.max_angle_deg < 180):
            bad("max_angle_deg", "in (0, 180)", self.max_angle_deg)
        if not is_real(self.direction) or self.direction not in (1, -1):
            bad("direction", "+1 or -1", self.direction)
        try:
            scaling = Scaling(self.scaling.lower() if isinstance(self.scaling, str) else self.scaling)
        except ValueError:
            bad("scaling", "'auto' or 'none'", self.scaling)
        object.__setattr__(self, "scaling", scaling)
        if self.parameter_scale is not None:
            positive("parameter_scale")
            object.__setattr__(self, "parameter_scale", float(self.parameter_scale))
        if self.unknown_scale is not None:
            try:
                arr = np.asarray(self.unknown_scale, dtype=float)
            except (TypeError, ValueError):
                bad("unknown_scale", "None, a positive number or a sequence of positive numbers", self.unknown_scale)
            if arr.ndim > 1 or arr.size == 0 or not np.all(np.isfinite(arr)) or not np.all(arr > 0):
                bad("unknown_scale", "None, a positive number or a sequence of positive numbers", self.unknown_scale)
            value = float(arr) if arr.ndim == 0 else tuple(float(v) for v in arr)
            object.__setattr__(self, "unknown_scale", value)
        positive("locate_tol")
        if not _is_int(self.locate_max_iter) or self.locate_max_iter < 1:
            bad("locate_max_iter", "an integer >= 1", self.locate_max_iter)
        if not is_real(self.corner_ratio) or not (math.isfinite(self.corner_ratio) and self.corner_ratio > 1):
            bad("corner_ratio", "a finite number > 1", self.corner_ratio)
        for field in ("detect_folds", "detect_branch_points", "corners"):
            v = getattr(self, field)
            if not isinstance(v, (bool, np.bool_)):
                bad(field, "a bool", v)
            object.__setattr__(self, field, bool(v))
        for field in ("max_points", "newton_max_iter", "newton_easy", "locate_max_iter", "direction", "stall_points"):
            object.__setattr__(self, field, int(getattr(self, field)))
        for field in ("ds", "ds_min", "ds_max", "newton_tol", "grow", "shrink", "max_angle_deg", "locate_tol",
                      "corner_ratio"):
            object.__setattr__(self, field, float(getattr(self, field)))

    @classmethod
    def field_names(cls) -> list[str]:
        return [f.name for f in dataclasses.fields(cls)]

    @classmethod
    def _check_keys(cls, keys: Iterable[str]) -> None:
        valid = cls.field_names()
        for key in keys:
            if key not in valid:
                close = difflib.get_close_matches(str(key), valid, n=1)
                hint = f"; did you mean {close[0]!r}?" if close else f"; valid options: {', '.join(valid)}"
                raise ValueError(f"ContinuationOptions: unknown option {key!r}{hint}")

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> "ContinuationOptions":
        """Build from a mapping; unknown keys raise ``ValueError`` naming the
        closest valid option."""
        cls._check_keys(d)
        return cls(**dict(d))

    def replace(self, **changes) -> "ContinuationOptions":
        """Copy with some fields changed (validated, unknown names rejected)."""
        self._check_keys(changes)
        return dataclasses.replace(self, **changes)

    def to_dict(self) -> dict:
        d = dataclasses.asdict(self)
        d["scaling"] = self.scaling.value
        return d


# ---------------------------------------------------------------------------
# engine internals
# ---------------------------------------------------------------------------

_ILL_RCOND = 1e-15


#: Growth of ``||u||_inf`` (of a group) over its automatic scale that updates the scale.
RESCALE_FACTOR = 100.0

#: Spread of the groups' magnitudes at the start beyond which each group gets its own scale.
GROUP_SPREAD = 1e3

#: Slack (radians) and corrector accuracy (scaled length) of the chord test of
#: :meth:`_Engine._secant_offset`.
SECANT_SLACK = 2e-3
SECANT_ACCURACY = 1e-8
#: Smallest tangent component and chord fraction for the monotonicity test of the chord.
SECANT_MONOTONE = 1e-3

#: Growth of the scaled Jacobian since the start that a stop message points out.
JACOBIAN_GROWTH = 1e3

#: A corrector stops after this many updates without a new smallest residual (the step is then
#: retried shorter): Newton meandering on a piecewise-smooth residual costs more than a shorter step.
NEWTON_STALL = 3

#: A step capped by an event's prediction is never below this fraction of the uncapped step.
EVENT_FLOOR = 1e-3
#: A barrier event is located from the current point when its predicted zero lies within the failed
#: step (times BARRIER_REACH) and within BARRIER_AHEAD last steps.
BARRIER_REACH = 1.0
BARRIER_AHEAD = 2.0
#: Solves spent locating a barrier, and its accuracy (relative to its distance where the steps failed).
BARRIER_SOLVES = 12
BARRIER_GTOL = 1e-9
#: Newton updates of a solve expected to fail where there is no solution (beyond a barrier).
QUICK_ITER = 8
#: Past a barrier's point the branch passes it when, over the next PASS_POINTS points, a step of
#: PASS_FRACTION of the step that reached it is taken again, fewer than PASS_FAILURES steps fail and
#: the event does not change again; otherwise it cannot pass it and ends there. A single grazing
#: with a corner (a stop's contact onset) is passed in a step or two of the corner machinery; a
#: bouncing cascade, each tangential touch opening the next, is not.
PASS_FRACTION = 1.0 / 16.0
PASS_POINTS = 8
PASS_FAILURES = 8


def _condition(rcond: float) -> float:
    """Condition estimate from a reciprocal one (``inf`` for a singular matrix, NaN if none)."""
    if not math.isfinite(rcond):
        return math.nan
    return math.inf if rcond <= 0 else 1.0 / rcond


def _cycles(history) -> bool:
    """Whether a residual history went up at least twice (Newton cycling, not slow convergence)."""
    h = np.asarray(history, dtype=float)
    return h.size >= 4 and int(np.count_nonzero(h[1:] > h[:-1])) >= 2


class _Failure(Exception):
    """Internal: a numerical failure ending the branch with a status."""

    def __init__(self, status: BranchStatus, message: str):
        super().__init__(message)
        self.status = status
        self.message = message


class _ScaledProblem:
    """Evaluates the problem in scaled variables ``x = (u / su, lam / sl)``."""

    def __init__(self, problem, m: int, su: np.ndarray, sl: float):
        self.problem = problem
        self.m = m
        self.su = su
        self.sl = sl
        self.calls = 0
        self.last = None  # (u, lam, R, Ju, Jlam) of the latest evaluation
        self._Jh = np.empty((m, m + 1))

    def evaluate(self, u: np.ndarray, lam: float):
        """Raw linearisation with shape checks; records it as ``last``."""
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
        """``R`` and the scaled Jacobian ``[Ju su, Jlam sl]`` (m, m+1) at ``x``."""
        m = self.m
        u = x[:m] * self.su
        lam = float(x[m] * self.sl)
        R, Ju, Jlam = self.evaluate(u, lam)
        Jh = self._Jh
        np.multiply(Ju, self.su, out=Jh[:, :m])
        np.multiply(Jlam, self.sl, out=Jh[:, m])
        return R, Jh


@dataclasses.dataclass(eq=False)
class _Candidate:
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


class _LazyData(collections.abc.Mapping):
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


class HermiteArc:
    """The cubic Hermite curve through two points of a branch with their unit tangents.

    ``x(q) = h00(q) xa + h10(q) L ta + h01(q) xb + h11(q) L tb`` for ``q`` in
    ``[0, 1]``, ``L`` the chord length (the arclength of a nearly straight
    arc); it lies ``O(L^4)`` off a smooth branch, where the chord lies
    ``O(L^2)`` off. :meth:`at` returns its point on the hyperplane
    ``ta . (x - xa) = sigma`` used by the engine's location.

    Parameters
    ----------
    xa, ta, xb, tb : ndarray, shape (m+1,)
        End points and unit tangents (scaled coordinates, oriented along the branch).
    h : float
        ``ta . (xb - xa)``.
    """

    def __init__(self, xa, ta, xb, tb, h):
        self.xa, self.ta, self.xb, self.tb, self.h = xa, ta, xb, tb, float(h)
        self.L = float(np.linalg.norm(xb - xa))
        # sigma(q) = ta . (x(q) - xa), a cubic in q
        self._c = (self.L, self.h, self.L * float(ta @ tb))

    def _sigma(self, q):
        L, hb, Ltb = self._c
        h10, h01, h11 = q ** 3 - 2 * q ** 2 + q, -2 * q ** 3 + 3 * q ** 2, q ** 3 - q ** 2
        d10, d01, d11 = 3 * q ** 2 - 4 * q + 1, -6 * q ** 2 + 6 * q, 3 * q ** 2 - 2 * q
        return h10 * L + h01 * hb + h11 * Ltb, d10 * L + d01 * hb + d11 * Ltb

    def at(self, sigma: float) -> np.ndarray:
        """The curve's point with ``ta . (x - xa) = sigma`` (the chord's if the cubic is not monotone there)."""
        q = sigma / self.h if self.h > 0 else 0.0
        for _ in range(8):
            f, df = self._sigma(q)
            if not df > 0:
                q = sigma / self.h if self.h > 0 else 0.0
                break
            dq = (sigma - f) / df
            q += dq
            if abs(dq) < 1e-14:
                break
        if not 0.0 <= q <= 1.0:
            q = min(max(sigma / self.h if self.h > 0 else 0.0, 0.0), 1.0)
        h00, h10 = 2 * q ** 3 - 3 * q ** 2 + 1, q ** 3 - 2 * q ** 2 + q
        h01, h11 = -2 * q ** 3 + 3 * q ** 2, q ** 3 - q ** 2
        return h00 * self.xa + h10 * self.L * self.ta + h01 * self.xb + h11 * self.L * self.tb


@dataclasses.dataclass
class _Barrier:
    """A located point of a barrier event that the branch has yet to show it passes."""

    event: Event
    parameter: float
    reach: float  # the step that reached it
    index: int  # the stored point at it (near side) or just past it
    near_side: bool = False
    later: int = 0  # more of them located before the branch showed it passes the first
    last_parameter: float = math.nan
    failures: int = 0  # failed steps since
    recovered: bool = False  # a step of PASS_FRACTION of the reaching one was taken since


class _StepFailed(Exception):
    def __init__(self, reason: str, rcond: float = math.nan, turn=None):
        super().__init__(reason)
        self.reason = reason
        self.rcond = rcond
        #: (angle_deg, ds, candidate) when the only fault was the tangent's turn
        self.turn = turn


#: the engine's attributes an engine state holds as they are: arrays, and plain values (see ``_Engine.state``)
STATE_ARRAYS = ("x", "t", "t_prev", "prev_x", "x_start", "t_start", "groups")
STATE_SCALARS = ("s", "jac_norm_start", "max_dist", "n_rejected", "n_newton", "n_backtracked", "adaptive_scale",
                 "min_rcond", "min_rcond_index", "last_rcond", "last_failure", "event_cap", "ds_free", "barrier_tried")
#: every key of an engine state (what a ``restart`` reads)
RESTART_KEYS = ("points", "ds", "recent", "turns", "su", "sl", "calls", "rescalings", "tests", "monitors",
                "barrier") + STATE_ARRAYS + STATE_SCALARS


class _Engine:
    def __init__(self, problem, u0, lam0, lam_range, options, parameter_name, events, monitors, tangent, callback,
                 solve_start, checkpoint=None):
        self.problem = problem
        self.checkpoint = checkpoint
        self.opt = options
        self.name = parameter_name
        self.u0 = u0
        self.lam0 = lam0
        self.lo, self.hi = lam_range
        self.user_tangent = tangent
        self.callback = callback
        self.solve_start = solve_start
        self.monitors = list(monitors)
        evs = []
        if options.detect_folds:
            evs.append(FoldEvent())
        if options.detect_branch_points:
            evs.append(BranchPointEvent())
        evs.extend(events)
        self.events = evs
        self.m = u0.size
        self.builder = BranchBuilder(parameter_name, self.m)
        self.branch = self.builder.branch
        self.n_rejected = 0
        self.turns: list = []  # (angle or None, ds) of the failed steps from the current point
        self.across = False  # a fixed-parameter step across a corner is being tried
        self.n_newton = 0
        self.n_backtracked = 0  # correctors retried with step halving
        self.adaptive_scale = False
        self.groups = np.zeros(u0.size, dtype=np.intp)
        self.rescalings: list = []  # (parameter, old scale, new scale)
        self.min_rcond = math.inf
        self.min_rcond_index = -1
        self.last_rcond = math.nan
        self.last_failure = ""
        self._options_dict = options.to_dict()
        self._e_last = np.zeros(self.m + 1)
        self._e_last[-1] = 1.0
        self.event_cap = math.inf  # the longest next step the events allow
        self.ds_free = options.ds  # the step the step control wants (before an event's cap)
        self.prev_info: PointInfo | None = None
        self.barrier_tried = -1  # branch length at the last barrier location
        self.at_barrier: _Barrier | None = None  # a barrier's point the branch has not yet shown it passes

    # -- helpers ---------------------------------------------------------
    def fmt(self, lam: float) -> str:
        return f"{self.name}={lam:.10g}"

    def _scales(self, u: np.ndarray) -> tuple[np.ndarray, float]:
        opt, m = self.opt, self.m
        auto = opt.scaling is Scaling.AUTO
        if opt.parameter_scale is not None:
            sl = opt.parameter_scale
        elif auto and math.isfinite(self.hi - self.lo) and self.hi > self.lo:
            sl = self.hi - self.lo
        elif auto:
            sl = max(abs(self.lam0), 1.0)
        else:
            sl = 1.0
        su = None
        if opt.unknown_scale is not None:
            su = np.broadcast_to(np.asarray(opt.unknown_scale, dtype=float), (m,)).copy()
            if np.asarray(opt.unknown_scale).ndim == 1 and len(opt.unknown_scale) != m:
                raise ValueError(f"ContinuationOptions.unknown_scale has {len(opt.unknown_scale)} values for {m} unknowns")
        elif auto:
            getter = getattr(self.problem, "unknown_scale", None)
            given = getter() if callable(getter) else None
            if given is not None:
                arr = np.asarray(given, dtype=float)
                if arr.ndim == 0:
                    arr = np.full(m, float(arr))
                if arr.shape != (m,) or not np.all(np.isfinite(arr)):
                    raise ValueError(f"problem.unknown_scale() must return {m} finite values or None")
                if np.any(arr > 0):
                    su = np.where(arr > 0, arr, arr.max())
            if su is None:
                norm = float(np.max(np.abs(u))) if m else 0.0
                su = np.full(m, max(norm, 1e-12) if norm > 0 else 1.0)
                self.adaptive_scale = True  # a guess from one point: updated as the unknowns grow
                self.groups = np.zeros(m, dtype=np.intp)
                grouped = self._grouped_scale(u, norm)
                if grouped is not None:
                    su = grouped
        else:
            su = np.ones(m)
        return su, float(sl)

    def _grouped_scale(self, u: np.ndarray, norm: float):
        """One scale per group of unknowns when their magnitudes are far apart, else None.

        ``problem.unknown_groups()`` (optional) labels the unknowns that share
        a unit (for harmonic balance, the coefficients of one degree of
        freedom). When the groups' magnitudes at the start span more than
        ``GROUP_SPREAD``, a single scale would make the small ones invisible
        to the step control (a fold of a dof measured in micrometres next
        to one in kilometres is passed blindly), so each group gets its own.
        """
        getter = getattr(self.problem, "unknown_groups", None)
        groups = getter() if callable(getter) else None
        if groups is None or not norm > 0:
            return None
        groups = np.asarray(groups)
        if groups.shape != (self.m,):
            raise ValueError(f"problem.unknown_groups() must return {self.m} labels")
        _, groups = np.unique(groups, return_inverse=True)
        mags = np.zeros(groups.max() + 1)
        np.maximum.at(mags, groups, np.abs(u))
        if mags.size < 2 or not np.all(mags > 0) or norm <= GROUP_SPREAD * mags.min():
            return None
        self.groups = groups
        return mags[groups]

    def _monitor(self, u, lam, Ju, Jlam) -> dict:
        data: dict[str, Any] = {}
        for mon in self.monitors:
            values = mon(u, lam, Ju, Jlam)
            for key, value in dict(values).items():
                if key in data:
                    raise ValueError(f"two monitors return the same name {key!r}")
                data[key] = value
        return data

    def _tests(self, info: PointInfo) -> list[np.ndarray]:
        """Test values of all events; a numerical failure gives NaN (ignored)."""
        out = []
        for ev in self.events:
            try:
                out.append(evaluate_test(ev, info))
            except NUMERICAL_ERRORS:
                out.append(np.full(1, np.nan))
        return out

    def _tangent_from(self, lu: LUFactor) -> np.ndarray:
        z = lu.solve(self._e_last)
        nz = float(np.linalg.norm(z))
        if not (math.isfinite(nz) and nz > 0):
            raise _StepFailed("non-finite tangent", lu.rcond)
        return z / nz

    def _bordered_solve(self, guess, x_ref, normal, offset, lu0=None, quick=False):
        """Newton on ``[R = 0; normal . (x - x_ref) = offset]`` from ``guess`` (``lu0``: see :func:`newton`;
        ``quick``: a solve expected to fail where there is no solution, given fewer updates and no retry)."""
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

        if quick:
            opt = self.opt
            res = newton(fun_and_jac, guess, opt.newton_tol, min(opt.newton_max_iter, QUICK_ITER), stall=2,
                         factor_final=True)
            self.n_newton += res.iterations
            return res
        return self._newton(fun_and_jac, guess, factor_final=True, lu0=lu0)

    def _newton(self, fun_and_jac, guess, **kw):
        """Newton, retried with step halving when plain Newton cycles.

        A residual that is only piecewise smooth (stiff contact sampled by the
        AFT: the Jacobian jumps where a sample crosses the clearance) makes
        full Newton alternate between two pieces, the residual going up and
        down without converging; halving the updates breaks most cycles.
        Smooth problems never pay for it: the retry happens only after such
        a failure.
        """
        opt = self.opt
        res = newton(fun_and_jac, guess, opt.newton_tol, opt.newton_max_iter, stall=NEWTON_STALL, **kw)
        self.n_newton += res.iterations
        if res.converged or res.singular or not _cycles(res.residual_history):
            return res
        self.n_backtracked += 1
        res = newton(fun_and_jac, guess, opt.newton_tol, opt.newton_max_iter, backtrack=4, stall=NEWTON_STALL, **kw)
        self.n_newton += res.iterations
        return res

    def _fixed_solve(self, lam: float, u_guess: np.ndarray):
        sp = self.sp

        def fun_and_jac(u):
            R, Ju, _ = sp.evaluate(u, lam)
            return R, Ju

        return self._newton(fun_and_jac, u_guess)

    def _point_info(self, cand_u, lam, tangent, lu, Ju, Jlam, s, data) -> PointInfo:
        return PointInfo(
            u=np.array(cand_u, dtype=float),
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

    # -- start -------------------------------------------------------------
    def start(self) -> bool:
        opt, m, lam0 = self.opt, self.m, self.lam0
        if self.solve_start:
            self.sp = _ScaledProblem(self.problem, m, np.ones(m), 1.0)  # shape checks only
            res = self._fixed_solve(lam0, self.u0)
            if not res.converged:
                self.builder.finish(
                    BranchStatus.START_FAILED,
                    f"Newton did not converge at the start parameter {self.fmt(lam0)}: {res.message}",
                )
                return False
            u = res.x
            iterations = res.iterations
        else:
            u = self.u0.copy()
            iterations = 0
        calls = self.sp.calls if hasattr(self, "sp") else 0
        su, sl = self._scales(u)
        self.sp = sp = _ScaledProblem(self.problem, m, su, sl)
        sp.calls = calls
        x = np.empty(m + 1)
        x[:m] = u / su
        x[m] = lam0 / sl
        try:
            R, Ju, Jlam = sp.evaluate(u, lam0)  # exact lam0, not lam0 / sl * sl
            Jh = np.empty((m, m + 1))
            Jh[:, :m] = Ju * su
            Jh[:, m] = Jlam * sl
        except NUMERICAL_ERRORS as exc:
            return self._start_failed(f"evaluation failed at the start point ({type(exc).__name__}: {exc})")
        if not (np.all(np.isfinite(R)) and np.all(np.isfinite(Jh))):
            return self._start_failed("non-finite residual or Jacobian at the start point")
        t = self._initial_tangent(Jh)
        if t is None:
            return self._start_failed("could not compute the initial tangent (non-finite Jacobian)")
        lam = lam0
        if float(np.max(np.abs(R), initial=0.0)) > opt.newton_tol:
            # solve_start=False with an inexact guess: correct on the hyperplane
            # normal to the tangent (works at folds, where fixed-lam Newton fails)
            cres = self._bordered_solve(x.copy(), x.copy(), t, 0.0)
            if not cres.converged or cres.lu is None:
                return self._start_failed(
                    f"Newton did not converge near the start point {self.fmt(lam0)}: {cres.message}"
                )
            iterations = cres.iterations
            x = cres.x.copy()
            u, lam = sp.last[0].copy(), sp.last[1]
        u_, lam_, R, Ju, Jlam = sp.last
        A = np.empty((m + 1, m + 1))
        A[:m, :m] = Ju * su
        A[:m, m] = Jlam * sl
        A[m] = t
        try:
            lu = factorize(A)
        except SingularMatrixError as exc:
            return self._start_failed(
                f"the bordered Jacobian is singular at the start point {self.fmt(lam)} ({exc}); "
                "the start is a singular point of the branch: start nearby"
            )
        try:
            t = self._tangent_from(lu)
        except _StepFailed as exc:
            return self._start_failed(exc.reason)
        self.x = x
        self.u = np.array(u, dtype=float)
        self.lam = float(lam)
        self.t = t
        self.s = 0.0
        self.x_start = x.copy()
        self.t_start = t.copy()
        self.jac_norm_start = float(np.max(np.abs(Ju * su), initial=0.0))
        self.max_dist = 0.0
        try:
            data = self._monitor(self.u, self.lam, Ju, Jlam)
        except NUMERICAL_ERRORS as exc:
            raise _Failure(BranchStatus.START_FAILED,
                           f"a monitor failed at the start {self.fmt(self.lam)} ({type(exc).__name__}: {exc})")
        self.info = self._point_info(self.u, self.lam, t, lu, Ju, Jlam, 0.0, data)
        res_norm = float(np.max(np.abs(R), initial=0.0))
        self._store(self.info, iterations, 0.0, res_norm)
        self.g = self._tests(self.info)
        self.builder.add_special(
            SpecialPoint(SpecialKind.START, self.lam, self.u.copy(), (self.lam, self.lam), 0, 0.0,
                         located=True, message="start point", event="start", tangent=t.copy())
        )
        return self._after_store()

    # -- restart -----------------------------------------------------------
    def state(self, ds: float, recent) -> dict:
        """What the main loop carries from the last stored point to the next step (see :meth:`restart`).

        JSON-able except for numpy arrays (:func:`contin.output.checkpoint.encode`);
        ``points`` is the number of stored points it belongs to.
        """
        bar = self.at_barrier
        out = {"points": len(self.branch), "ds": float(ds), "recent": [float(v) for v in recent],
               "turns": [[a, d] for a, d in self.turns], "su": self.sp.su.copy(), "sl": float(self.sp.sl),
               "calls": int(self.sp.calls), "rescalings": [list(r) for r in self.rescalings],
               "tests": [np.asarray(g, dtype=float).copy() for g in self.g],
               "monitors": [mon.state() if hasattr(mon, "state") else None for mon in self.monitors],
               "barrier": None if bar is None else {**{f.name: getattr(bar, f.name) for f in dataclasses.fields(bar)},
                                                    "event": self.events.index(bar.event)}}
        for name in STATE_ARRAYS:
            out[name] = np.array(getattr(self, name))
        for name in STATE_SCALARS:
            v = getattr(self, name)
            out[name] = v if isinstance(v, (str, bool, int)) else float(v)
        return out

    def restart(self, branch: Branch, state: Mapping[str, Any]) -> tuple[float, list]:
        """Take up ``branch`` (the points stored so far) where :meth:`state` left it.

        The last two points are linearized again (their test values come from
        ``state``), so the next step is the one the interrupted run would have
        taken. Returns the ``ds`` and ``recent`` arguments of :meth:`run`.
        """
        if len(branch) != state["points"] or len(branch) < 1:
            raise ValueError(f"restart: the state belongs to {state['points']} points, the branch has {len(branch)}")
        branch.status, branch.message = BranchStatus.RUNNING, ""
        self.builder.branch = self.branch = branch
        m = self.m
        self.sp = sp = _ScaledProblem(self.problem, m, np.array(state["su"], dtype=float), float(state["sl"]))
        for name in STATE_ARRAYS:
            setattr(self, name, np.array(state[name], dtype=np.intp if name == "groups" else float))
        for name in STATE_SCALARS:
            setattr(self, name, state[name])
        self.turns = [(a, d) for a, d in state["turns"]]
        self.rescalings = [tuple(r) for r in state["rescalings"]]
        self.g = [np.asarray(g, dtype=float) for g in state["tests"]]
        for mon, st in zip(self.monitors, state["monitors"]):
            if st is not None and hasattr(mon, "restore"):
                mon.restore(st)
        k = len(branch) - 1
        self.u, self.lam = branch.unknowns[k].copy(), float(branch.parameter[k])

        def info_at(i, tangent, row, s):
            u, lam = branch.unknowns[i], float(branch.parameter[i])
            R, Ju, Jlam = sp.evaluate(u, lam)
            A = np.empty((m + 1, m + 1))
            A[:m, :m] = Ju * sp.su
            A[:m, m] = Jlam * sp.sl
            A[m] = row
            data = {name: values[i] for name, values in branch.point_data.items()}
            return self._point_info(u, lam, tangent, factorize(A), Ju, Jlam, s, data)

        self.info = info_at(k, self.t, self.t_prev, self.s)
        self.prev_info = info_at(k - 1, self.t_prev, self.t_prev, float(branch.arclength[k - 1])) if k else None
        bar = state["barrier"]
        self.at_barrier = None if bar is None else _Barrier(**{**bar, "event": self.events[bar["event"]]})
        sp.calls = int(state["calls"])
        return float(state["ds"]), list(state["recent"])

    def _diagnosis(self) -> str:
        """What the last stored point says about a stop: condition and growth of the Jacobian."""
        parts = []
        try:
            norm = float(np.max(np.abs(self.info.Ju * self.sp.su)))
        except (AttributeError, ValueError):
            return ""
        if self.jac_norm_start > 0 and norm > JACOBIAN_GROWTH * self.jac_norm_start:
            parts.append(f"the scaled Jacobian grew {norm / self.jac_norm_start:.1e}-fold since the start "
                         "(the model blows up there?)")
        if math.isfinite(self.info.rcond):
            parts.append(f"condition estimate {_condition(self.info.rcond):.1e}")
        return "; " + "; ".join(parts) if parts else ""

    def _start_failed(self, message: str) -> bool:
        self.builder.finish(BranchStatus.START_FAILED, message)
        return False

    def _initial_tangent(self, Jh: np.ndarray) -> np.ndarray | None:
        m = self.m
        try:
            _, sv, vt = np.linalg.svd(Jh, full_matrices=True)
        except np.linalg.LinAlgError:
            return None
        tol = max(Jh.shape) * np.finfo(float).eps * (sv[0] if sv.size else 1.0)
        rank = int(np.count_nonzero(sv > tol))
        null = vt[rank:]  # at least one row: Jh has m+1 columns
        given = self.user_tangent
        if given is not None:
            if null.shape[0] > 1:
                t = null.T @ (null @ given)
                t = t if np.linalg.norm(t) > 0 else null[-1]
            else:
                t = null[-1]
            t = t / np.linalg.norm(t)
            if float(t @ given) < 0:
                t = -t
            return t
        t = vt[-1].copy()
        if abs(t[m]) > 1e-12 and np.sign(t[m]) != self.opt.direction:
            t = -t
        return t

    # -- bookkeeping -----------------------------------------------------
    def _store(self, info: PointInfo, iterations: int, step: float, res_norm: float) -> int:
        try:
            index = self.builder.append_point(
                u=info.u, lam=info.lam, tangent=info.tangent, s=info.s,
                newton_iterations=iterations, step_size=step, residual_norm=res_norm, data=info.data,
            )
        except PointRejected as exc:
            raise _Failure(BranchStatus.NEWTON_FAILED, f"point at {self.fmt(info.lam)} not stored: {exc}")
        if info.rcond < self.min_rcond:
            self.min_rcond = info.rcond
            self.min_rcond_index = index
        self.last_rcond = info.rcond
        return index

    def _after_store(self) -> bool:
        """Callback; False if it asks to stop."""
        if self.callback is None:
            return True
        index = len(self.branch) - 1
        self._update_info()
        if self.callback(self.branch, index) is False:
            self.builder.finish(BranchStatus.INTERRUPTED, f"stopped by the callback at {self.fmt(self.lam)}")
            return False
        return True

    def _update_info(self):
        b = self.branch
        b.info.update(
            unknown_scale=self.sp.su.copy(),
            parameter_scale=self.sp.sl,
            lam_range=(self.lo, self.hi),
            min_rcond=self.min_rcond,
            min_rcond_index=self.min_rcond_index,
            # 1-norm condition estimates (LAPACK gecon on the LU each corrector makes anyway) of
            # the scaled, row-equilibrated bordered Jacobian [[Ju su, Jlam sl], [t]]
            max_condition=_condition(self.min_rcond),
            max_condition_parameter=(float(b.parameter[self.min_rcond_index])
                                     if 0 <= self.min_rcond_index < len(b) else math.nan),
            last_condition=_condition(self.last_rcond),
            n_rejected_steps=self.n_rejected,
            n_newton_iterations=self.n_newton,
            n_backtracked=self.n_backtracked,
            rescalings=list(self.rescalings),
            n_linearizations=self.sp.calls,
            last_failure=self.last_failure,
            options=self._options_dict,
        )

    # -- steps -----------------------------------------------------------
    def _check_new(self, x_new, xp, ds, lu_or_none, rcond, iterations, landed=False) -> _Candidate:
        """Tangent, angle and distance checks of a converged corrector."""
        if lu_or_none is None:
            raise _StepFailed("singular bordered Jacobian at the new point", 0.0)
        lu = lu_or_none
        dist = float(np.linalg.norm(x_new - xp))
        if dist > max(ds, 10 * self.opt.ds_min):
            raise _StepFailed(f"corrector moved {dist / ds:.2g} step lengths from the prediction", rcond)
        t_new = self._tangent_from(lu)
        cosang = float(np.clip(self.t @ t_new, -1.0, 1.0))
        angle = math.degrees(math.acos(cosang))
        u, lam, R, Ju, Jlam = self.sp.last
        h = float(self.t @ (x_new - self.x))
        if landed or self.across:
            h = max(h, 0.0)  # the end may be within rounding of the current point
        elif not h > 0:
            raise _StepFailed("the new point is not ahead of the previous one", rcond)
        cand = _Candidate(
            x=x_new, u=np.array(u, dtype=float), lam=float(lam), tangent=t_new, lu=lu, R=R, Ju=Ju, Jlam=Jlam,
            iterations=iterations, h=h, ds=ds, landed=landed,
        )
        if angle > self.opt.max_angle_deg:
            raise _StepFailed(f"tangent turned by {angle:.1f} deg > {self.opt.max_angle_deg:g} deg", rcond,
                              turn=(angle, ds, cand))
        if not (landed or self.across):
            off = self._secant_offset(x_new, t_new, math.radians(angle))
            if off is not None:
                raise _StepFailed(off, rcond)
        return cand

    def _secant_offset(self, x_new, t_new, theta):
        """Why the chord to ``x_new`` is not an arc of the branch, or None.

        Along a smooth arc whose tangent turns by ``theta`` the chord lies
        between the end tangents (along their bisector for a circular arc).
        A corrector that landed on a neighbouring sheet (two branches closer
        than one step, as beside the backbone of a lightly damped resonance)
        has both end tangents nearly parallel yet a chord leaning sideways:
        the angle between the chord and the bisector exceeds
        ``2 theta`` plus a slack for the corrector's accuracy.
        """
        d = x_new - self.x
        L = float(np.linalg.norm(d))
        b = self.t + t_new
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
        against = (self.t * t_new > 0) & (np.minimum(np.abs(self.t), np.abs(t_new)) >= SECANT_MONOTONE) \
            & (d * self.t < 0) & (np.abs(d) >= SECANT_MONOTONE * L + SECANT_ACCURACY)
        if against.any():
            i = int(np.flatnonzero(against)[0])
            what = self.name if i == self.m else f"unknown {i}"
            return f"{what} moved against both end tangents over the step (a jump, or two turns in one step)"
        return None

    def _step(self, ds: float) -> _Candidate:
        xp = self.x + ds * self.t
        res = self._bordered_solve(xp.copy(), xp, self.t, 0.0)
        if not res.converged:
            raise _StepFailed(f"Newton did not converge ({res.message})", res.rcond)
        return self._check_new(res.x, xp, ds, res.lu, res.rcond, res.iterations)

    def _land(self, end: float, ds: float, guess_x: np.ndarray, landed: bool = True) -> _Candidate:
        """Newton at fixed ``lam = end`` from ``guess_x`` (scaled, lam = end)."""
        sp, m = self.sp, self.m
        res = self._fixed_solve(end, guess_x[:m] * sp.su)
        if not res.converged:
            where = "at the range end" if landed else "at"
            raise _StepFailed(f"Newton did not converge {where} {self.fmt(end)} ({res.message})", res.rcond)
        u, _, R, Ju, Jlam = sp.last  # evaluated at the converged u
        x_new = np.empty(m + 1)
        x_new[:m] = u / sp.su
        x_new[m] = end / sp.sl
        A = np.empty((m + 1, m + 1))
        A[:m, :m] = Ju * sp.su
        A[:m, m] = Jlam * sp.sl
        A[m] = self.t
        try:
            lu = factorize(A)
        except SingularMatrixError:
            lu = None
        return self._check_new(x_new, guess_x, ds, lu, res.rcond, res.iterations, landed=landed)

    def _attempt(self, ds: float) -> _Candidate | None:
        """One step from the current point; None if the current point is at
        the range end and the branch leaves the range."""
        lo, hi, sl = self.lo, self.hi, self.sp.sl
        t_lam = self.t[-1]
        lam_pred = (self.x[-1] + ds * t_lam) * sl
        if lam_pred > hi or lam_pred < lo:
            end = hi if lam_pred > hi else lo
            if self.lam == end:
                return None
            # shorten the prediction to reach the end exactly, then land on it
            ds_cut = (end / sl - self.x[-1]) / t_lam
            guess = self.x + ds_cut * self.t
            guess[-1] = end / sl
            try:
                return self._land(end, ds_cut, guess)
            except _StepFailed as failed_landing:
                # the branch may turn back before the end (a fold close to it)
                try:
                    cand = self._step(ds)
                except _StepFailed:
                    raise failed_landing from None
                if lo <= cand.lam <= hi:
                    return cand
                raise
        cand = self._step(ds)
        if cand.lam > hi or cand.lam < lo:
            end = hi if cand.lam > hi else lo
            theta = (end - self.lam) / (cand.lam - self.lam)
            guess = self.x + theta * (cand.x - self.x)
            guess[-1] = end / sl
            return self._land(end, ds, guess)
        return cand

    # -- main loop -------------------------------------------------------
    def run(self, ds: float | None = None, recent=()) -> Branch:
        opt = self.opt
        ds = opt.ds if ds is None else ds  # the step the step control wants; events may cap the one taken
        recent = collections.deque(recent, maxlen=opt.stall_points)  # steps of the last stored points
        while True:
            if len(self.branch) >= opt.max_points:
                self.builder.finish(BranchStatus.MAX_POINTS, f"stored max_points={opt.max_points} points; last at {self.fmt(self.lam)}")
                return self.branch
            ds_try = self.ds_free = ds
            if self.event_cap < ds:  # an event predicted within the step
                ds_try = max(self.event_cap, opt.ds_min, EVENT_FLOOR * ds)
            try:
                cand = self._attempt(ds_try)
            except _StepFailed as exc:
                cand = exc
            except NUMERICAL_ERRORS as exc:
                cand = _StepFailed(f"evaluation failed ({type(exc).__name__}: {exc})")
            if cand is None:
                self._finish_range_end(len(self.branch) - 1)
                return self.branch
            if isinstance(cand, _StepFailed):
                barrier = self._barrier(ds_try)
                if barrier is not None:
                    cand = barrier
            if isinstance(cand, _StepFailed) and opt.corners:
                corner = self._corner(cand, ds_try)
                if corner is not None:
                    cand = corner
            if isinstance(cand, _StepFailed):
                self.n_rejected += 1
                self.last_failure = cand.reason
                if self.at_barrier is not None:
                    self.at_barrier.failures += 1
                    if self.at_barrier.failures >= PASS_FAILURES:
                        self._finish_at_barrier(f"{PASS_FAILURES} steps beyond it failed (the last: {cand.reason})")
                        return self.branch
                if self.info.rcond < _ILL_RCOND:
                    raise _Failure(
                        BranchStatus.ILL_CONDITIONED,
                        f"the bordered Jacobian is ill-conditioned at {self.fmt(self.lam)} "
                        f"(rcond={self.info.rcond:.1e}) and the step failed: {cand.reason}",
                    )
                if ds_try <= opt.ds_min:
                    if cand.rcond < _ILL_RCOND:
                        raise _Failure(
                            BranchStatus.ILL_CONDITIONED,
                            f"step size fell below ds_min={opt.ds_min:g} near {self.fmt(self.lam)} with an "
                            f"ill-conditioned Jacobian (rcond={cand.rcond:.1e}): {cand.reason}",
                        )
                    raise _Failure(
                        BranchStatus.STEP_TOO_SMALL,
                        f"step size fell below ds_min={opt.ds_min:g} at {self.fmt(self.lam)}; "
                        f"last failure: {cand.reason}{self._diagnosis()}",
                    )
                ds = max(ds_try * opt.shrink, opt.ds_min)
                continue
            if not self.turns or cand.kink is not None or ds_try >= self.turns[0][1] / opt.corner_ratio:
                self.turns.clear()  # healthy again (or past the corner): forget the failures
            if not self._accept(cand):
                return self.branch
            bar = self.at_barrier
            if bar is not None and bar.index < len(self.branch) - 1:
                if bar.later:
                    self._finish_at_barrier(f"it changed again within {PASS_POINTS} points (a cascade)")
                    return self.branch
                bar.recovered = bar.recovered or max(ds_try, cand.h) >= PASS_FRACTION * bar.reach
                if len(self.branch) - 1 - bar.index >= PASS_POINTS:
                    if not bar.recovered:
                        self._finish_at_barrier(f"{PASS_POINTS} points beyond it the steps had not recovered "
                                                f"{PASS_FRACTION:.3g} of the step that reached it, {bar.reach:.2g}")
                        return self.branch
                    self.at_barrier = None  # passed
            recent.append(ds if ds_try < ds else ds_try)  # a step cut short by an event is no crawl
            if len(recent) == opt.stall_points and sum(recent) < opt.ds_max:
                self.builder.finish(
                    BranchStatus.STEP_TOO_SMALL,
                    f"the branch crawled: {opt.stall_points} points advanced {sum(recent):.2g} in all "
                    f"(ds_max={opt.ds_max:g}) up to {self.fmt(self.lam)}; last failure: {self.last_failure}"
                    f"{self._diagnosis()}")
                return self.branch
            if cand.kink is not None:
                self._record_kink(cand)
            if cand.landed:
                self._finish_range_end(len(self.branch) - 1)
                return self.branch
            self._maybe_rescale()
            if self._closed(cand):
                self.builder.finish(BranchStatus.CLOSED_LOOP, f"the branch returned to its start point {self.fmt(self.branch.parameter[0])}")
                return self.branch
            k = self._revisited(cand)
            if k is not None:
                self.builder.finish(
                    BranchStatus.CLOSED_LOOP,
                    f"the branch passed again through its point {k} at {self.fmt(self.branch.parameter[k])}, in the "
                    f"same direction, at {self.fmt(self.lam)}: it retraces itself (a loop not through the start; if "
                    "the problem has none there, a step jumped onto an earlier part of the branch: lower ds_max)")
                return self.branch
            if cand.iterations <= opt.newton_easy:
                ds = min(ds * opt.grow, opt.ds_max)
            if self.checkpoint is not None:
                self.checkpoint(self.branch, self.state(ds, recent))

    def _barrier_reached(self, ev: Event, lam: float, h: float, index: int, near_side: bool = False) -> None:
        bar = self.at_barrier
        if bar is None:
            # judged against the step the step control wanted there, not one an event cut short
            self.at_barrier = _Barrier(ev, lam, max(h, self.ds_free), index, near_side)
            return
        bar.index, bar.near_side = index, near_side
        last = bar.last_parameter if bar.later else bar.parameter
        if abs(lam - last) <= 1e3 * self.opt.locate_tol * max(1.0, abs(lam)):
            return  # the same point again (located from both sides)
        # a cascade (more contact arcs opening one after the other): judged against the step that
        # reached the first one
        bar.later += 1
        bar.last_parameter = lam

    def _finish_at_barrier(self, why: str) -> None:
        bar = self.at_barrier
        more = (f"; {bar.later} more located after it, the last at {self.fmt(bar.last_parameter)}"
                if bar.later else "")
        self.builder.finish(
            BranchStatus.BOUNDARY,
            f"the branch cannot pass the {bar.event.kind.value} point at {self.fmt(bar.parameter)} "
            f"({bar.event.name}{more}): {why}; last point at {self.fmt(self.lam)}")

    def _barrier(self, ds: float):
        """A barrier event's point located ahead of the current one, as a candidate, or None.

        Called when a step of length ``ds`` failed. A barrier event
        (:attr:`contin.engine.events.Event.barrier`) whose distance, extrapolated
        from the last two stored points, reaches zero within that step and
        within ``BARRIER_AHEAD`` last steps is located by
        :func:`contin.engine.events.narrow` on its distance, solving on the
        hyperplanes normal to the current tangent; a solve that fails counts
        as beyond the barrier, and the point is taken on the near side.
        Tried once per stored point.
        """
        if self.barrier_tried == len(self.branch) or self.prev_info is None or len(self.branch) < 2:
            return None
        self.barrier_tried = len(self.branch)
        h_last = float(self.s - self.prev_info.s)
        for ev in self.events:
            if not ev.barrier or (self.at_barrier is not None and ev is self.at_barrier.event):
                continue  # not a barrier, or the branch is at (or just past) its point already
            try:
                g_prev, g0 = float(ev.distance(self.prev_info)), float(ev.distance(self.info))
            except NUMERICAL_ERRORS:
                continue
            ahead = predicted_zero(g_prev, g0, h_last)
            if not (ahead <= BARRIER_REACH * ds and ahead <= BARRIER_AHEAD * h_last):
                continue  # not predicted there, or too far for the solves from here: shorter steps first
            cand = self._locate_barrier(ev, g0, (g0 - g_prev) / h_last, min(1.5 * ahead, ds))
            if cand is not None:
                return cand
        return None

    def _locate_barrier(self, ev: Event, g0: float, rate: float, s_end: float):
        """Locate ``ev``'s zero in ``(0, s_end]`` ahead of the current point (``g0``, ``rate``: its
        distance here and its rate of change per arclength); a candidate on the near side, or None."""
        solved = {}

        def point_at(sigma):
            xp = self.x + sigma * self.t
            try:
                res = self._bordered_solve(xp.copy(), self.x, self.t, sigma, quick=True)
            except NUMERICAL_ERRORS as exc:
                return None, f"{type(exc).__name__}: {exc}"
            if not res.converged or res.lu is None:
                return None, "no solution"
            try:
                cand = self._check_new(res.x, xp, sigma, res.lu, res.rcond, res.iterations)
            except _StepFailed as exc:
                return None, exc.reason
            info = self._point_info(cand.u, cand.lam, cand.tangent, cand.lu, cand.Ju, cand.Jlam, self.s + cand.h, {})
            solved[id(info)] = (info, cand)
            return info, ""

        # the far end is not solved: its distance is the one predicted there
        far = dataclasses.replace(self.info, lam=self.lam + s_end * float(self.t[-1]) * self.sp.sl)
        loc = narrow(point_at, 0.0, s_end, self.info, far, g0, g0 + rate * s_end, s_end,
                     side=lambda info, v: math.isfinite(v) and (v < 0) == (g0 < 0), value=ev.distance,
                     tol=self.opt.locate_tol, max_iter=BARRIER_SOLVES, vtol=BARRIER_GTOL, failed_beyond=True)
        if not loc.located or id(loc.point) not in solved:
            return None
        cand = solved[id(loc.point)][1]
        cand.barrier = ev
        return cand

    def _corner(self, failed: _StepFailed, ds: float):
        """A step across a corner of the branch, or None.

        Two signs of a corner once the step has shrunk ``corner_ratio``
        times since the first failure near the current point (failures are
        forgotten once a step of at least that scale succeeds again): the turn of a
        converged step does not shrink with it, or the bordered corrector,
        whose Newton iterates straddle the corner, fails; then a step at
        fixed parameter (``lam`` advanced by ``ds``, in scaled units, in the
        tangent's direction) is tried, as across a corner the branch is
        locally a graph over ``lam`` unless the corner is a fold; then one
        at a fixed value of the unknown dominating the tangent (a corner
        that is also a fold). A turned candidate at a step within
        ``corner_ratio`` of ``ds_min`` is a corner as well.
        """
        angle = failed.turn[0] if failed.turn is not None else None
        if not self.turns:
            self.turns.append((angle, ds))
            return None
        first_angle, first_ds = self.turns[0]
        self.turns.append((angle, ds))
        if first_ds < self.opt.corner_ratio * ds:
            return None
        if angle is not None and any(a is not None and angle >= 0.5 * a for a, d in self.turns[:-1]
                                     if d >= self.opt.corner_ratio * ds):
            cand = self._oriented(failed.turn[2])
            cand.kink = (angle, ds, first_angle or angle, first_ds)
            return cand
        cand = self._across_fixed_parameter(ds)
        if cand is None:
            cand = self._across_fixed_component(ds)
        if cand is None:
            if angle is not None and ds <= self.opt.corner_ratio * self.opt.ds_min:
                # a turn beyond max_angle_deg over a step this short would need a radius of
                # curvature below the smallest step: the step control cannot resolve it, so
                # it is a corner (the candidate lies within ds of the current point)
                cand = self._oriented(failed.turn[2])
                cand.kink = (angle, ds, first_angle or angle, first_ds)
            return cand
        cand = self._oriented(cand)
        turn = math.degrees(math.acos(float(np.clip(self.t @ cand.tangent, -1.0, 1.0))))
        if turn > self.opt.max_angle_deg:
            cand.kink = (turn, ds, first_angle or turn, first_ds)
        return cand

    def _across_fixed_parameter(self, ds: float):
        """A step at fixed ``lam`` advanced by ``ds`` (scaled), or None."""
        sl, t_lam = self.sp.sl, self.t[-1]
        if abs(t_lam) < 1e-3:
            return None  # a vertical tangent: not a graph over lam
        guess = self.x.copy()  # the unknowns as they are: the slope beyond the corner is unknown
        guess[-1] += math.copysign(ds, t_lam)
        self.across = True
        try:
            cand = self._land(float(guess[-1] * sl), ds / abs(t_lam), guess, landed=False)
        except _StepFailed as exc:
            if exc.turn is None:
                return None
            cand = exc.turn[2]
        finally:
            self.across = False
        if not (self.lo <= cand.lam <= self.hi):
            return None
        return cand

    def _across_fixed_component(self, ds: float):
        """A step with the unknown of the largest tangent component advanced by ``ds``, or None.

        At a corner that is also a fold of the discretised problem (near a
        fold the tangent is so sensitive to the Jacobian that one AFT sample
        entering the contact can turn the branch back), there is no
        solution beyond the corner at fixed ``lam``; the branch is still a
        graph over the unknown that dominates the tangent.
        """
        i = int(np.argmax(np.abs(self.t[:-1])))
        ti = float(self.t[i])
        if abs(ti) < 0.1:
            return None
        normal = np.zeros(self.m + 1)
        normal[i] = 1.0
        offset = math.copysign(ds, ti)
        guess = self.x.copy()
        guess[i] += offset
        self.across = True
        try:
            res = self._bordered_solve(guess, self.x, normal, offset)
            if not res.converged:
                return None
            cand = self._check_new(res.x, guess, ds / abs(ti), res.lu, res.rcond, res.iterations)
        except _StepFailed as exc:
            if exc.turn is None:
                return None
            cand = exc.turn[2]
        except NUMERICAL_ERRORS:
            return None
        finally:
            self.across = False
        if not (self.lo <= cand.lam <= self.hi):
            return None
        return cand

    def _maybe_rescale(self):
        """Grow the automatic unknown scale (of each group) with the unknowns.

        The automatic scale comes from the start point alone. A lightly
        damped resonance starting from a tiny response (1e-6 at the start,
        0.5 at the peak) would otherwise need millions of steps of at most
        ``ds_max``. So the scale follows ``||u||_inf`` whenever it has grown
        by ``RESCALE_FACTOR``, and the current point, tangent and references
        are converted (a positive diagonal change of variables keeps every
        orientation and sign the events use). It never shrinks: a scale
        following the response back down would magnify each small wiggle of
        the branch (a contact's corners) into steps that jump.
        """
        if not self.adaptive_scale:
            return
        su = self.sp.su
        mags = np.zeros(self.groups.max() + 1)
        np.maximum.at(mags, self.groups, np.abs(self.u))
        cur = np.zeros_like(mags)
        np.maximum.at(cur, self.groups, su)
        grow = mags > RESCALE_FACTOR * cur
        if not grow.any():
            return
        new = np.where(grow, mags, cur)
        f = (new / cur)[self.groups]
        m = self.m
        old_su = su.copy()
        self.sp.su[:] = new[self.groups]

        def convert_point(x):
            x = x.copy()
            x[:m] /= f
            return x

        def convert_direction(t):
            t = convert_point(t)
            return t / np.linalg.norm(t)

        self.x = convert_point(self.x)
        self.prev_x = convert_point(self.prev_x)
        self.x_start = convert_point(self.x_start)
        self.max_dist = float(np.linalg.norm(self.x - self.x_start))
        self.t = convert_direction(self.t)
        self.t_start = convert_direction(self.t_start)
        self.info.tangent = self.t
        self.turns.clear()
        self.rescalings.append((self.lam, float(old_su.max()), float(self.sp.su.max())))

    def _oriented(self, cand):
        """Orient the tangent beyond a corner along the secant (the bordered
        orientation, ``t_new . t_old > 0``, reverses it after a turn beyond 90 deg)."""
        if float(cand.tangent @ (cand.x - self.x)) < 0:
            cand.tangent = -cand.tangent
        return cand

    def _record_kink(self, cand):
        angle, ds, first_angle, first_ds = cand.kink
        i = len(self.branch) - 1
        lam_a, lam_b = float(self.branch.parameter[i - 1]), float(self.branch.parameter[i])
        self.builder.add_special(
            SpecialPoint(SpecialKind.KINK, lam_b, cand.u.copy(), (lam_a, lam_b), i - 1,
                         float(self.branch.arclength[i]), located=True, event="corner",
                         message=(f"the tangent jumps by {angle:.1f} deg over a step of {ds:.1e} "
                                  f"({first_angle:.1f} deg over {first_ds:.1e}): a corner of the branch, "
                                  "where the problem is not smooth (a contact opening or closing: grazing)"),
                         data={"angle_deg": angle, "ds": ds}, tangent=cand.tangent.copy())
        )

    def _finish_range_end(self, index: int):
        lam = float(self.branch.parameter[index])
        self.builder.add_special(
            SpecialPoint(SpecialKind.END, lam, self.branch.unknowns[index].copy(), (lam, lam), index,
                         float(self.branch.arclength[index]), located=True,
                         message="end of the parameter range", event="end",
                         tangent=self.branch.tangents[index].copy())
        )
        toward = self._toward()
        if lam == toward:
            self.builder.finish(BranchStatus.RANGE_END, f"reached the end of the parameter range at {self.fmt(lam)}")
            return
        furthest, gap = self._uncovered()
        self.builder.finish(
            BranchStatus.TURNED_BACK,
            f"turned back: it set out towards {self.fmt(toward)} but reached the other end of the range at "
            f"{self.fmt(lam)}; its furthest point is at {self.fmt(furthest)}, so [{gap[0]:.10g}, {gap[1]:.10g}] "
            "is not covered by this branch")

    def _toward(self) -> float:
        """The end of the range the branch set out towards (its start tangent's parameter direction)."""
        t = getattr(self, "t_start", None)
        up = self.opt.direction > 0 if t is None or t[-1] == 0 else t[-1] > 0
        return self.hi if up else self.lo

    def _uncovered(self) -> tuple[float, tuple[float, float]]:
        """The furthest parameter reached towards :meth:`_toward` and the interval beyond it, left uncovered."""
        b, toward = self.branch, self._toward()
        lams = [float(v) for v in b.parameter] + [sp.parameter for sp in b.special_points if sp.kind is SpecialKind.FOLD]
        lams = lams or [self.lam0]
        furthest = max(lams) if toward == self.hi else min(lams)
        gap = (furthest, toward) if toward == self.hi else (toward, furthest)
        b.info["uncovered"] = gap
        return furthest, gap

    def _accept(self, cand: _Candidate) -> bool:
        prev_x, prev_info, prev_g = self.x, self.info, self.g
        self.prev_x = prev_x
        s_new = self.s + cand.h
        lam_new = cand.lam
        try:
            data = self._monitor(cand.u, lam_new, cand.Ju, cand.Jlam)
        except NUMERICAL_ERRORS as exc:
            raise _Failure(BranchStatus.NEWTON_FAILED, f"a monitor failed at {self.fmt(lam_new)} ({type(exc).__name__}: {exc})")
        info = self._point_info(cand.u, lam_new, cand.tangent, cand.lu, cand.Ju, cand.Jlam, s_new, data)
        res_norm = float(np.max(np.abs(cand.R), initial=0.0))
        index = self._store(info, cand.iterations, cand.h, res_norm)
        g_new = self._tests(info)
        # events on the arc between the previous and the new point
        t_prev = self.t
        changed = set()
        for ev, ga, gb in zip(self.events, prev_g, g_new):
            if cand.kink is not None and isinstance(ev, (FoldEvent, BranchPointEvent)):
                continue  # the tangent's jump at a corner is neither a fold nor a branch point
            bar = self.at_barrier
            if bar is not None and bar.near_side and ev is bar.event and bar.index == index - 1:
                continue  # the step from the barrier's point passes the barrier recorded there
            for comp in changed_components(ev, ga, gb, prev_info, info):
                changed.add(ev)
                self._locate(ev, comp, prev_x, t_prev, prev_info, cand, info, ga, gb, index - 1)
        if cand.barrier is not None:
            self._record_barrier(cand.barrier, info, prev_info.lam, index)
            self._barrier_reached(cand.barrier, info.lam, cand.h, index, near_side=True)
        cap = math.inf
        for ev in self.events:
            if ev in changed or ev is cand.barrier:
                continue  # located at or just behind the new point: nothing ahead to predict yet
            try:
                limit = float(ev.step_limit(prev_info, info, cand.h))
            except NUMERICAL_ERRORS:
                continue
            if limit > 0:
                cap = min(cap, limit)
        self.event_cap = cap
        self.prev_info = prev_info
        self.t_prev = t_prev  # the bordering row of the new point's Jacobian (for a restart)
        self.x, self.u, self.lam, self.t, self.s = cand.x, cand.u, lam_new, cand.tangent, s_new
        self.info, self.g = info, g_new
        return self._after_store()

    def _record_barrier(self, ev: Event, info: PointInfo, lam_prev: float, index: int) -> None:
        try:
            data = dict(ev.describe(info))
        except NUMERICAL_ERRORS as exc:
            data = {"describe_error": f"{type(exc).__name__}: {exc}"}
        self.builder.add_special(
            SpecialPoint(
                kind=ev.kind, parameter=float(info.lam), unknowns=info.u.copy(), interval=(lam_prev, info.lam),
                index=index, s=float(info.s), located=True, data=data, event=ev.name,
                message=f"{ev.name}: located from the near side, where the steps failed", tangent=info.tangent.copy(),
                point_data={k: np.array(v) for k, v in info.data.items()},
            )
        )

    def _locate(self, ev: Event, comp: int, xa, ta, info_a: PointInfo, cand: _Candidate, info_b: PointInfo, ga, gb, index: int):
        sp = self.sp
        h = cand.h
        arc = HermiteArc(xa, ta, cand.x, cand.tangent, h)

        def solve_on_arc(sigma: float):
            # the cubic Hermite guess on the arc first (O(h^4) off the curve, where the chord is
            # O(h^2) off); where Newton's basin is smaller still (stiff contact), march from the
            # earlier point in substeps along the family of hyperplanes normal to its tangent
            try:
                res = self._bordered_solve(arc.at(sigma), xa, ta, sigma)
                if res.converged and res.lu is not None:
                    return res, ""
                x, t, ok = xa, ta, True
                n_sub = 4
                for k in range(1, n_sub + 1):
                    sk = sigma * k / n_sub
                    res = self._bordered_solve(x + (sigma / n_sub) * t / max(float(t @ ta), 0.1), xa, ta, sk)
                    if not res.converged or res.lu is None:
                        ok = False
                        break
                    x = res.x
                    z = res.lu.solve(self._e_last)
                    t = z / np.linalg.norm(z)
                    if float(t @ ta) < 0:
                        t = -t
                if ok:
                    return res, ""
            except NUMERICAL_ERRORS as exc:
                return None, f"evaluation failed ({type(exc).__name__}: {exc})"
            if res.converged:
                return None, "singular bordered Jacobian"
            return None, f"Newton did not converge ({res.message})"

        def point_at(sigma: float):
            res, why = solve_on_arc(sigma)
            if res is None:
                return None, why
            z = res.lu.solve(self._e_last)
            nz = float(np.linalg.norm(z))
            if not (math.isfinite(nz) and nz > 0):
                return None, "non-finite tangent"
            u, lam, R, Ju, Jlam = sp.last
            # the monitors run when an event's test first reads the point's data: a fold's test
            # (the tangent) needs none, a stability event's the multipliers
            data = _LazyData(lambda u=u, lam=lam, Ju=Ju, Jlam=Jlam: self._monitor(u, lam, Ju, Jlam))
            return self._point_info(u, lam, z / nz, res.lu, Ju, Jlam, info_a.s + sigma, data), ""

        locations = ev.locate(comp, point_at, h, info_a, info_b, float(ga[comp]), float(gb[comp]),
                              tol=self.opt.locate_tol, max_iter=self.opt.locate_max_iter)
        for loc in locations:
            p = loc.point
            if isinstance(p.data, _LazyData):
                try:
                    p.data = dict(p.data)
                except NUMERICAL_ERRORS as exc:
                    p.data = {}
                    loc.message += f"; a monitor failed there ({type(exc).__name__}: {exc})"
            self._record_location(ev, loc, ga[comp], gb[comp], comp, ga.size > 1, info_a.lam, info_b.lam, index)
            if ev.barrier and loc.located:
                # the steps after it must show that the branch passes it (see _finish_at_barrier)
                self._barrier_reached(ev, float(loc.point.lam), h, index + 1)

    def _record_location(self, ev: Event, loc, ga: float, gb: float, comp: int, vector: bool, lam_a: float,
                         lam_b: float, index: int) -> None:
        p = loc.point
        try:
            data = dict(ev.describe(p))
        except NUMERICAL_ERRORS as exc:
            data = {"describe_error": f"{type(exc).__name__}: {exc}"}
        if vector:
            data.setdefault("component", comp)
        self.builder.add_special(
            SpecialPoint(
                kind=ev.kind, parameter=float(p.lam), unknowns=p.u.copy(), interval=(lam_a, lam_b),
                index=index, s=float(p.s), test_values=(float(ga), float(gb)), located=loc.located,
                data=data, message=f"{ev.name}: {loc.message}", event=ev.name, tangent=p.tangent.copy(),
                point_data={k: np.array(v) for k, v in p.data.items()},
            )
        )

    def _revisited(self, cand: _Candidate) -> int | None:
        """Index of an earlier stored point (not the start, not the last few) that the
        last chord passes through in the same direction, or None.

        Without it, a branch that jumped back onto an earlier part of itself
        would go round the same loop until ``max_points``.
        """
        b = self.branch
        n = len(b) - 1  # the new point is stored
        if n < 6:
            return None
        a, x1 = self.prev_x, cand.x
        seg = x1 - a
        L = float(np.linalg.norm(seg))
        if L == 0.0:
            return None
        m = self.m
        X = np.empty((n - 3, m + 1))  # points 1 .. n-3 in the current scales
        X[:, :m] = b.unknowns[1:n - 2] / self.sp.su
        X[:, m] = b.parameter[1:n - 2] / self.sp.sl
        p = (X - a) @ seg / (L * L)
        near = (p >= 0.0) & (p <= 1.0)
        if not near.any():
            return None
        dist = np.linalg.norm(a + np.outer(p, seg) - X, axis=1)
        cand_idx = np.flatnonzero(near & (dist <= 0.1 * L))
        cos_min = math.cos(math.radians(min(2 * self.opt.max_angle_deg, 89.0)))
        for j in cand_idx:
            k = int(j) + 1
            d = np.empty(m + 1)
            d[:m] = (b.unknowns[k + 1] - b.unknowns[k]) / self.sp.su
            d[m] = (b.parameter[k + 1] - b.parameter[k]) / self.sp.sl
            nd = float(np.linalg.norm(d))
            if nd > 0 and float(d @ seg) >= cos_min * nd * L:
                return k
        return None

    def _closed(self, cand: _Candidate) -> bool:
        """Did the last step pass the start point (after having gone away)?"""
        x0, a = self.x_start, self.prev_x
        seg = cand.x - a
        L = float(np.linalg.norm(seg))
        went_away = self.max_dist > 2.0 * L
        self.max_dist = max(self.max_dist, float(np.linalg.norm(cand.x - x0)))
        if len(self.branch) < 4 or not went_away or L == 0:
            return False
        p = float((x0 - a) @ seg) / (L * L)
        if not (0.0 <= p <= 1.0):
            return False
        dist = float(np.linalg.norm(a + p * seg - x0))
        # same direction as the start tangent (not a crossing of a figure eight)
        cos_min = math.cos(math.radians(min(2 * self.opt.max_angle_deg, 89.0)))
        return dist <= 0.25 * L and float(self.t_start @ seg) >= cos_min * L


def continuation(
    problem: Problem,
    u0,
    lam0: float,
    lam_range: tuple[float, float] = (-math.inf, math.inf),
    options: ContinuationOptions | Mapping[str, Any] | None = None,
    *,
    parameter_name: str = "lambda",
    events: Iterable[Event] = (),
    monitors: Iterable[Monitor] = (),
    tangent=None,
    callback: Callable[[Branch, int], Any] | None = None,
    solve_start: bool = True,
    checkpoint: Callable[[Branch, dict], Any] | None = None,
    restart: tuple[Branch, Mapping[str, Any]] | None = None,
) -> Branch:
    """Trace the solution branch of ``R(u, lam) = 0`` through ``(u0, lam0)``.

    Parameters
    ----------
    problem : Problem
        Object with ``linearize(u, lam) -> (R, Ju, Jlam)`` (and optionally
        ``unknown_scale()``).
    u0 : array_like, shape (m,)
        Start guess (or exact start point).
    lam0 : float
        Start parameter, inside ``lam_range``.
    lam_range : (float, float)
        ``(lo, hi)``, ``lo < hi``; infinite bounds allowed. The branch stops
        exactly on a bound (status ``RANGE_END``).
    options : ContinuationOptions or mapping, optional
    parameter_name : str
        Used in messages and stored in the branch.
    events : iterable of Event
        Extra events (the fold and branch-point events are added according
        to the options).
    monitors : iterable of callables
        ``monitor(u, lam, Ju, Jlam) -> {name: value}`` evaluated at every
        stored and located point; stored in ``Branch.point_data`` and passed
        to events in ``PointInfo.data``.
    tangent : array_like, shape (m+1,), optional
        Start orientation (e.g. ``Branch.tangents[i]`` when resuming; only its
        orientation is used, it takes precedence over ``options.direction``).
    callback : callable, optional
        ``callback(branch, index)`` after each stored point; returning
        ``False`` (or raising ``KeyboardInterrupt``) stops with
        ``INTERRUPTED``.
    solve_start : bool
        If True, Newton at fixed ``lam0`` from ``u0`` first. If False,
        ``(u0, lam0)`` is taken as the start when it meets ``newton_tol``,
        otherwise it is corrected on the hyperplane through it normal to the
        tangent (usable at a fold).
    checkpoint : callable, optional
        ``checkpoint(branch, state)`` after each step that stored a point and
        did not end the branch, with the state the next step starts from
        (``_Engine.state``: arrays and plain values; with the branch's points
        it is everything a ``restart`` needs), and once more when the branch
        ends, with ``state = {"monitors": [...]}`` (the monitors' final states).
    restart : (Branch, dict), optional
        Continue ``branch`` (its points, point data and special points, as an
        interrupted run stored them) from a ``state`` given to ``checkpoint``
        at its last point: the run goes on exactly as the interrupted one
        would have (``u0``, ``lam0`` and ``tangent`` are then ignored; the
        same problem, options, events and monitors must be given).

    Returns
    -------
    Branch
        Never raises for numerical reasons: failures end the branch with a
        status and message (``START_FAILED`` gives an empty branch). Invalid
        arguments raise ``ValueError``. Other exceptions from the problem,
        monitors, events or callback propagate; the partial branch is then
        attached to the exception as ``exc.partial_branch``.
    """
    if options is None:
        options = ContinuationOptions()
    elif isinstance(options, Mapping):
        options = ContinuationOptions.from_dict(options)
    elif not isinstance(options, ContinuationOptions):
        raise TypeError(f"options must be ContinuationOptions or a mapping, got {type(options).__name__}")
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

    eng = _Engine(problem, u0, lam0, (lo, hi), options, parameter_name, events, monitors, tangent, callback, solve_start,
                  checkpoint)
    if restart is not None:
        ds, recent = eng.restart(*restart)
    branch = eng.branch
    try:
        try:
            if restart is not None:
                eng.run(ds, recent)
            elif eng.start():
                eng.run()
        except _Failure as exc:
            eng.builder.finish(exc.status, exc.message)
        except KeyboardInterrupt:
            where = f" at {eng.fmt(eng.lam)}" if len(branch) else ""
            eng.builder.finish(BranchStatus.INTERRUPTED, f"interrupted (KeyboardInterrupt){where}")
    except BaseException as exc:
        if branch.status is BranchStatus.RUNNING:
            branch.message = f"aborted by {type(exc).__name__}: {exc}"
        try:
            exc.partial_branch = branch
        except Exception:
            pass
        raise
    finally:
        if branch.status is BranchStatus.MAX_POINTS or (
                branch.status not in (BranchStatus.RUNNING, BranchStatus.INTERRUPTED) and not branch.status.as_asked):
            eng._uncovered()
        if len(branch):
            eng._update_info()
        elif hasattr(eng, "sp"):
            branch.info.update(lam_range=(lo, hi), n_linearizations=eng.sp.calls, n_newton_iterations=eng.n_newton)
    if checkpoint is not None and branch.status is not BranchStatus.INTERRUPTED:
        checkpoint(branch, {"monitors": [mon.state() if hasattr(mon, "state") else None for mon in eng.monitors]})
    return branch


CONNECTION_SUBSTEPS = 4  # hyperplanes from a stored point to the chord's midpoint when the direct solve fails


def connection_report(problem: Problem, branch: Branch, *, max_angle_deg: float = 45.0, midpoint: bool = True,
                      max_offset: float = 0.5, newton_tol: float | None = None, skip_kinks: bool = True) -> dict:
    """Check that consecutive stored points of a branch lie on one connected curve.

    An invariant against silent branch jumping, computed from the problem
    alone (not from the engine's own tangents):

    - at each stored point the tangent is the null vector of the scaled
      ``[Ju su, Jlam sl]`` (oriented along the secant); the angle between
      the secant to the next point and the tangents at both ends must stay
      below ``max_angle_deg`` (a smooth arc of curvature ``k`` and length
      ``L`` gives about ``k L / 2``);
    - with ``midpoint``, the problem is solved again on the hyperplane
      through the chord's midpoint normal to the chord; the solution must
      lie within ``max_offset * L`` of the midpoint, i.e. between the two
      points, not on another sheet. Newton starts from the cubic Hermite
      midpoint; where that lies outside the basin (contact orbits with many
      harmonics), the midpoint hyperplane is reached from point ``index``
      over ``CONNECTION_SUBSTEPS`` hyperplanes parallel to it, each solve
      started on the previous solution's tangent.

    Steps across a recorded corner (``kink`` special point) are skipped with
    ``skip_kinks``: the tangent jumps there by construction.

    Parameters
    ----------
    problem : Problem
    branch : Branch
        Traced with ``problem``; its ``info`` holds the scales.
    max_angle_deg, max_offset : float
    midpoint : bool
    newton_tol : float, optional
        Tolerance of the midpoint solves (default: the branch's
        ``newton_tol`` times 10, or 1e-9).
    skip_kinks : bool

    Returns
    -------
    dict
        ``ok`` (bool), ``max_angle_deg``, ``max_offset`` (midpoint distance
        over chord length), ``checked`` (number of steps checked) and
        ``failures``: list of ``(index, reason)`` for the step from point
        ``index`` to ``index + 1``.
    """
    n = len(branch)
    m = branch.unknowns.shape[1] if n else 0
    su = np.broadcast_to(np.asarray(branch.info.get("unknown_scale", 1.0), dtype=float), (m,))
    sl = float(branch.info.get("parameter_scale", 1.0))
    opts = branch.info.get("options") or {}
    tol = newton_tol if newton_tol is not None else 10.0 * float(opts.get("newton_tol", 1e-10))
    kinks = {sp.index for sp in branch.special_points if sp.kind == SpecialKind.KINK} if skip_kinks else set()
    X = np.column_stack([branch.unknowns / su, branch.parameter / sl]) if n else np.zeros((0, m + 1))
    failures: list = []
    worst_angle, worst_offset, checked = 0.0, 0.0, 0

    def jac(x):
        R, Ju, Jlam = problem.linearize(x[:m] * su, float(x[m] * sl))
        return np.asarray(R, dtype=float), np.column_stack([np.asarray(Ju, float) * su, np.asarray(Jlam, float) * sl])

    def tangent(x, d):
        _, Jh = jac(x)
        A = np.vstack([Jh, d])
        rhs = np.zeros(m + 1)
        rhs[-1] = 1.0
        try:
            z = np.linalg.solve(A, rhs)
        except np.linalg.LinAlgError:
            return None
        return z / np.linalg.norm(z)

    def angle(a, b):
        return math.degrees(math.acos(float(np.clip(abs(a @ b), -1.0, 1.0))))

    def on_plane(xm, d):
        def fun(x):  # the residual bordered by the hyperplane through xm normal to d
            R, Jh = jac(x)
            return np.concatenate([R, [d @ (x - xm)]]), np.vstack([Jh, d])
        return fun

    def march(x, d, L, tol, substeps=CONNECTION_SUBSTEPS):
        # a contact orbit's basin can be narrower than the Hermite midpoint's distance to the curve: reach the
        # midpoint hyperplane from point i over hyperplanes normal to the chord, with the tangent's predictor
        x0, s_prev, res = x, 0.0, None
        for k in range(1, substeps + 1):
            s = 0.5 * L * k / substeps
            t = tangent(x, d)
            if t is None:
                break
            res = newton(on_plane(x0 + s * d, d), x + (s - s_prev) * t / (t @ d), tol, 30)
            if not res.converged:
                break
            x, s_prev = res.x, s
        return res

    for i in range(n - 1):
        if i in kinks or (i + 1) in kinks:
            continue
        d = X[i + 1] - X[i]
        L = float(np.linalg.norm(d))
        if L == 0.0:
            continue
        d = d / L
        checked += 1
        ends = [tangent(X[i], d), tangent(X[i + 1], d)]
        if any(t is None for t in ends):
            failures.append((i, "singular Jacobian at a stored point"))
            continue
        a = max(angle(d, t) for t in ends)
        worst_angle = max(worst_angle, a)
        if a > max_angle_deg:
            failures.append((i, f"secant and tangent differ by {a:.1f} deg"))
            continue
        if not midpoint:
            continue
        xm = 0.5 * (X[i] + X[i + 1])
        # Newton starts from the cubic Hermite midpoint of the two ends and their tangents (O(L^3) off the
        # curve, where the chord midpoint is O(L^2) off: small basins, a stiff contact, need the former)
        res = newton(on_plane(xm, d), xm + 0.125 * L * (ends[0] - ends[1]), tol, 30)
        if not res.converged:
            res = march(X[i], d, L, tol)
        if not res.converged:
            failures.append((i, f"no solution on the midpoint hyperplane ({res.message})"))
            continue
        off = float(np.linalg.norm(res.x - xm)) / L
        worst_offset = max(worst_offset, off)
        if off > max_offset:
            failures.append((i, f"the midpoint solution lies {off:.2g} chord lengths away from the chord"))
    return {"ok": not failures, "max_angle_deg": worst_angle, "max_offset": worst_offset, "checked": checked,
            "failures": failures}
