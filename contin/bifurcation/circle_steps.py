"""A torus of a system with contact by plain steps in the parameter: Newton at fixed ``lam``, circle by circle.

The invariant circle of a system with contact (:mod:`contin.timedomain.invariant_circle`)
has corners where its points cross the switching surfaces of the flow map, and
every crossing of a grid point puts a corner into the discretised branch: the
branch turns by tens of degrees at corners close together in ``lam``, however
short the step (the rotor's large torus: docs/theory/quasi-periodic.md). A
pseudo-arclength branch, whose corrector and step control read the tangent,
crawls there; a step at fixed ``lam`` does not see the corners, as the circle
at each ``lam`` is still the solution of a Newton problem in ``U`` and ``rho``
with one solution nearby. Plain steps also step
over the thin resonance tongues of large ``q`` that a discretised circle
cannot cross smoothly (docs/theory/quasi-periodic.md). Where Newton fails at
every step down to ``min_step`` (a fold, a corner too tight, a tongue), a
pass of steps at a fixed size of the circle with ``lam`` free
(:mod:`contin.bifurcation.circle_fold`) tries to go on, given the range's
other end (``turn_to``): where ``lam`` turns back in it, the fold is located
between its circles and the steps in ``lam`` go on the other way; where
``lam`` goes on the same way past the failure, they go on that way; the
pass's circles are kept from then on. Where that pass finds neither, it
takes its circles back and the steps end and say where, with the rational
of small denominator nearest ``rho`` (a locking tongue, or the breakdown of
the torus: which one, the rows before it tell). Past a Neimark-Sacker point Newton converges onto the periodic orbit
itself (all points on it solve the equations at any ``rho``): a circle whose
size falls below :data:`COLLAPSED` of the largest so far is not kept but
taken as a failed step, and steps that end so end as a collapse, located to
``min_step``.

:func:`step_circle` takes the circle from ``lam0`` towards ``end``; the
predictor is the line through the last two circles, the step halved where
Newton fails and grown by half again after a success, up to the first step.
Newton's Jacobian is lazy (:func:`contin.engine.newton.newton`): the iterates
are evaluated by plain flows, and chord steps with the factorisation of the
last circle's updates go on while they contract; a variational flow per point
only where an update factorises; a solve whose residual grows to :data:`DIVERGED`
times its first is given up. (Giving up a Newton solve after a few updates
without progress saves time at the ends but stops steps that a few more
updates would finish: the residual has corners too.)
"""

from __future__ import annotations

import dataclasses
from fractions import Fraction

import numpy as np

from contin.bifurcation.circle_branch import LOCKING_FIT, LOCKING_TOL, MAX_DENOMINATOR, circle_spread, locking_ahead
from contin.bifurcation.circle_fold import circle_size, refine_fold, scaled, size_step
from contin.engine.linalg import factorize
from contin.engine.newton import solve_at_parameter
from contin.engine.options import ContinuationOptions

__all__ = ["COLLAPSED", "DIVERGED", "FOLD_PASSES", "FOLD_PASS_STEPS", "CircleStepper", "CircleSteps", "step_circle"]

#: a circle this small against the largest of the steps (peak-to-peak range of a state component) has collapsed
COLLAPSED = 1e-3
#: the denominators considered for the rational nearest ``rho`` where the steps end, unless ``rho`` lies within
#: ``1 / (10 q^2)`` of a ``p/q`` with ``q`` up to :data:`CLOSE_DENOMINATOR` (the smallest such ``q`` is named: a
#: rotation number at the edge of a tongue of larger ``q``, where it sits)
NEAREST_DENOMINATOR = 12
CLOSE_DENOMINATOR = 30
#: a step's Newton is given up once its residual exceeds this factor times the first one: the steps that fail
#: diverge far beyond it, those that converge stay well within it (docs/theory/quasi-periodic.md)
DIVERGED = 100.0
#: a pass of steps at a fixed size (where the steps in ``lam`` failed) takes at most this many circles ...
FOLD_PASS_STEPS = 16
#: ... a branch turns at most this many folds (a closed family of tori would turn for ever) ...
FOLD_PASSES = 4
#: ... and at most this many passes that went on the same way since the last turn, or since a step in ``lam`` as long
#: as ``max_step`` (at the edge of a tongue of large ``q`` the passes would creep along it, a pass each time, the
#: steps between them never long)
FORWARD_PASSES = 2
#: the size steps, relative: the first, the largest, and the smallest before a pass gives up
SIZE_STEP, SIZE_STEP_MAX, SIZE_STEP_MIN = 1e-2, 5e-2, 1e-3
#: after a turn the steps in ``lam`` take over once ``lam`` is this many ``min_step`` back from the fold, and ...
TURN_CLEAR = 1
#: ... going on the same way, this many past the place where they failed (towards a fold the size steps first go
#: on the same way a while)
PASS_CLEAR = 4
#: a circle born at a Neimark-Sacker point grows by size steps from the small first guess, the first and the
#: largest relative (its ``lam`` moves as the square of its size there: doublings are small steps), until
#: ``lam`` has moved :data:`TURN_CLEAR` ``min_step`` away, in at most :data:`GROW_STEPS` circles
GROW_STEP, GROW_STEP_MAX, GROW_STEPS = 0.5, 1.0, 60


@dataclasses.dataclass
class CircleSteps:
    """The circles of :func:`step_circle`.

    Attributes
    ----------
    parameter : ndarray, shape (K,)
        ``lam`` of each circle, the start first.
    unknowns : ndarray, shape (K, problem.size)
    iterations : ndarray of int, shape (K,)
        Newton's iterations (0 at the start).
    reached : bool
        Whether the steps got to ``end``.
    message : str
        Where and why they stopped.
    rows : list of dict
        ``measure(u, lam)`` at each circle (empty without ``measure``).
    folds : list of dict
        The folds turned (:attr:`CircleStepper.turned`): ``lam``, ``u``, ``located``, ``interval``, ``index``
        (the circle nearest the turn).
    """

    parameter: np.ndarray
    unknowns: np.ndarray
    iterations: np.ndarray
    reached: bool
    message: str
    rows: list
    folds: list = dataclasses.field(default_factory=list)


class CircleStepper:
    """The loop of :func:`step_circle`, one step at a time, with the state that resumes it exactly.

    ``lams`` and ``us`` hold the circles so far (the predictor reads the last
    two); ``step`` is the next step, ``largest`` the largest circle so far.
    The chord factorisation passed from circle to circle is kept with the point
    its Jacobian was evaluated at (``lu_at``), so :meth:`restore` rebuilds it
    and a resumed run takes the steps the uninterrupted one would have.

    With ``grow``, ``u0`` is the first guess of a circle born at a
    Neimark-Sacker point at ``lam0`` (:func:`~contin.bifurcation.circle_branch.circle_child_start`):
    size steps grow it (``mode`` ``"grow"``) until ``lam`` has moved away from
    the point, and the steps in ``lam`` go on the way it moved, towards
    ``end`` or ``turn_to`` (the side of the point the torus lies on is
    not known before). With ``turn_to`` (the range's other end), where the steps in ``lam`` fail
    down to ``min_step`` a pass of size steps begins (module docstring):
    ``mode`` is then ``"size"``, ``pass_lams`` the ``lam`` of the pass's
    circles (the one it began from first). An attempt that turns a fold sets
    ``turned`` (``lam``, ``u``, ``located``, ``interval``, ``back``: how many
    circles before the last the one nearest the turn is), for the caller to
    take and clear.
    """

    def __init__(self, problem, u0, lam0: float, step: float, end: float, *, min_step: float = 1e-5,
                 max_step: float | None = None, options: ContinuationOptions | None = None,
                 turn_to: float | None = None, grow: bool = False):
        step, lam0, end = float(step), float(lam0), float(end)
        if step == 0.0 or (end - lam0) * step < 0.0:
            raise ValueError(f"step_circle: step {step:g} must point from {lam0:g} towards {end:g}")
        if not min_step > 0.0:
            raise ValueError(f"step_circle: min_step must be positive, got {min_step!r}")
        self.problem, self.end, self.min_step = problem, end, float(min_step)
        self.turn_to = None if turn_to is None else float(turn_to)
        self.max_step = abs(step) if max_step is None else float(max_step)
        self.sign = float(np.sign(step))
        self.opts = options or ContinuationOptions(newton_tol=1e-8, newton_max_iter=20)
        self.lams, self.us = [lam0], [np.asarray(u0, dtype=float)]
        self.step = step
        self.largest = circle_spread(problem, self.us[0])
        self.collapsed = None  # (lam, spread) of the last circle refused as collapsed
        self.lu = self.lu_at = None  # the chord factorisation and (u, lam) where its Jacobian was evaluated
        self.failures = 0
        self.mode = "lam"
        self.size_step = 0.0
        self.last_delta = None  # the size step of the last circle, where it was one (the predictor's secant)
        self.pass_lams: list[float] = []
        self.lam_fail = None  # where the steps in lam failed, for the pass under way
        self.passes = 0  # folds turned
        self.forward = 0  # passes that went on the same way since the last turn
        self.gave_up = False  # a pass that found nothing: the steps end
        self.turned = None
        self.held: list = []  # the circles of a pass under way, (lam, result)
        self._pass_largest = 0.0
        self.last_kind = None  # how the last circle was found: "lam", or "size" (a size step, growing or turning)
        self._before = None  # what a step in lam changed, for undo
        #: the last step in lam's circle, its distance from the predictor over the predictor's distance from the
        #: circle before (None without a secant): a leap onto another branch lands far off the line
        self.leap = None
        if grow:
            if self.turn_to is None:
                raise ValueError("step_circle: a circle grown from a Neimark-Sacker point needs turn_to, the other "
                                 "end of the range")
            # ``u0`` is a first guess at the point itself: it is no circle yet and is not kept
            self.mode, self.size_step, self.lam_fail = "grow", GROW_STEP, lam0
            self.pass_lams = [lam0]

    @property
    def lam(self) -> float:
        return self.lams[-1]

    def going(self) -> bool:
        """Whether another step is to be tried."""
        if self.gave_up:
            return False
        if self.mode in ("size", "grow"):
            return True
        return (self.end - self.lam) * self.sign > 1e-12 * max(1.0, abs(self.end)) and abs(self.step) >= self.min_step

    def attempt(self) -> list:
        """One step: ``[(lam, result)]`` for the circle it appended (the converged Newton result, ``x`` the
        circle's unknowns), ``[]`` where it failed (the step halved), or, where a pass of size steps ends by
        turning a fold or going on, all the circles of the pass at once (held back until then: a pass that
        finds nothing takes its circles back)."""
        if self.mode in ("size", "grow"):
            return self._size_attempt()
        problem, lam = self.problem, self.lam
        h = self.step
        target = self.end if (self.end - lam - h) * self.sign <= 0.0 else lam + h
        guess = self.us[-1]
        if len(self.lams) > 1:
            guess = self.us[-1] + (self.us[-1] - self.us[-2]) * (target - lam) / (lam - self.lams[-2])
        seen = _Linearizations(problem)
        # a lazy Jacobian: iterates by plain flows, the factorisation of the last circle's updates first
        r = solve_at_parameter(seen, guess, target, self.opts, lu0=self.lu,
                               residual=lambda x: problem.residual(x, target), jacobian_at_solution=False,
                               divergence_factor=DIVERGED)
        spread = circle_spread(problem, r.x) if r.converged else 0.0
        if r.converged and spread < COLLAPSED * self.largest:  # as a failure: the step shrinks towards the point
            self.collapsed = (target, spread)
        if not r.converged or spread < COLLAPSED * self.largest:
            self.failed()
            return []
        self._before = (h, self.lu, self.lu_at, self.largest, self.last_delta)
        # how far Newton moved from the predictor, in the predictor's own steps from the last circle
        reach = float(np.linalg.norm(guess - self.us[-1]))
        self.leap = float(np.linalg.norm(r.x - guess)) / reach if len(self.lams) > 1 and reach > 0.0 else None
        if r.lu is not self.lu:
            self.lu, self.lu_at = r.lu, (None if r.lu is None else seen.last)
        self.largest, self.collapsed = max(self.largest, spread), None
        self.lams.append(target)
        self.us.append(r.x)
        self.last_delta = None
        self.step = self.sign * min(abs(h) * 1.5, self.max_step)
        if abs(h) >= self.max_step:  # clear of the place the last pass went past: passes allowed again
            self.forward = 0
        self.last_kind = "lam"
        return [(target, r)]

    def undo(self) -> None:
        """Take back the circle the last step in ``lam`` appended, as a failed step (the caller refuses it: a step
        across a fold onto the torus's other half, :func:`~contin.bifurcation.circle_natural.follow_circle_steps`)."""
        self.lams.pop()
        self.us.pop()
        self.step, self.lu, self.lu_at, self.largest, self.last_delta = self._before
        self.failed()

    def failed(self) -> None:
        """A step that failed (or whose evaluation raised): the next one shorter; where the steps in ``lam`` are
        spent, a pass of size steps begins (given ``turn_to``), and where the size steps are, the pass ends."""
        self.failures += 1
        if self.mode in ("size", "grow"):
            self.size_step /= 2.0
            if abs(self.size_step) < SIZE_STEP_MIN:
                self._give_up()
            return
        self.step /= 2.0
        if (abs(self.step) < self.min_step and self.collapsed is None and self.turn_to is not None
                and self.passes < FOLD_PASSES and self.forward < FORWARD_PASSES and len(self.lams) > 1
                and not self.reached() and not self.locking()):
            sizes = [circle_size(self.problem, u) for u in self.us[-2:]]
            self.mode, self.lam_fail, self.held, self._pass_largest = "size", self.lam, [], self.largest
            # the size goes on as it went: across a fold the branch is a graph over it
            self.size_step = SIZE_STEP if sizes[1] >= sizes[0] else -SIZE_STEP
            self.pass_lams = [self.lam]

    def locking(self) -> bool:
        """Whether the circles end at a locking (the rotation number at ``p/q`` of small ``q``, or heading for it
        as the square root of the distance to a tongue's edge just ahead:
        :func:`~contin.bifurcation.circle_branch.classify_circle_end`): the end as asked, no pass for it."""
        rho = float(self.problem.blocks(self.us[-1])[1]) % 1.0
        if abs(rho - float(Fraction(rho).limit_denominator(MAX_DENOMINATOR))) < LOCKING_TOL:
            return True
        circles = _Circles(self.lams, self.us)
        return locking_ahead(circles, self.problem) is not None

    def _size_attempt(self):
        problem, m = self.problem, self.problem.size
        x = np.r_[self.us[-1], self.lam]
        delta = self.size_step
        if self.last_delta is not None and len(self.lams) > 1:
            guess = x + (x - np.r_[self.us[-2], self.lams[-2]]) * (delta / self.last_delta)
        else:
            guess = scaled(problem, x, delta)
        r = size_step(problem, x, delta, guess, self.opts, divergence_factor=DIVERGED)
        u, lam = r.x[:m], float(r.x[m])
        if not r.converged or circle_spread(problem, u) < COLLAPSED * self.largest:
            self.failed()
            return []
        if self.mode == "grow" and len(self.pass_lams) == 1:  # the first circle: the guess it grew from is dropped
            self.lams, self.us, self.largest = [], [], 0.0
        self.largest = max(self.largest, circle_spread(problem, u))
        self.lams.append(lam)
        self.us.append(u)
        self.pass_lams.append(lam)
        self.last_delta = delta
        self.last_kind = "size"
        top = GROW_STEP_MAX if self.mode == "grow" else SIZE_STEP_MAX
        # a pass lengthens its steps slowly until lam turns back (towards a fold the discrete branch may be tight
        # and cornered), then as a growth does
        L = self.pass_lams
        back = self.mode == "grow" or (len(L) > 1 and (L[-1] - L[-2]) * self.sign < 0.0)
        self.size_step = float(np.sign(delta)) * min(abs(delta) * (1.5 if back else 1.2), top)
        found = (lam, dataclasses.replace(r, x=u))
        if self.mode == "grow":
            self._grown()
            return [found]
        self.held.append(found)
        self._decide()
        if self.mode == "size":
            return []
        done, self.held = self.held, []
        return done

    def _decide(self) -> None:
        """After a size step: a turn of ``lam`` (the fold located, the steps in ``lam`` the other way), a pass
        beyond the failure the same way (the steps in ``lam`` again), or on with the pass."""
        L, way = self.pass_lams, self.sign
        if len(L) >= 3 and all((L[i] - L[i - 1]) * way < 0.0 for i in (-1, -2)):
            k = int(np.argmax(way * np.asarray(L)))
            # the circle the pass began from may be the extreme one: its neighbour is the step in lam before it
            if k < len(L) - 1 and len(self.lams) - len(L) + k >= 1 and abs(L[-1] - L[k]) >= TURN_CLEAR * self.min_step:
                self.passes += 1
                self._turn(k)
                return
        if (len(L) >= 3 and all((L[i] - L[i - 1]) * way > 0.0 for i in (-1, -2))
                and (L[-1] - self.lam_fail) * way >= PASS_CLEAR * self.min_step):
            self.forward += 1
            self._leave_pass(way)
            return
        if len(L) - 1 >= FOLD_PASS_STEPS:
            self._give_up()

    def _grown(self) -> None:
        """After a size step of a circle born at a Neimark-Sacker point: the steps in ``lam`` once it has moved
        away from the point, the way it moved over the last two circles."""
        L = self.pass_lams
        way = float(np.sign(L[-1] - L[0]))
        if (len(L) >= 3 and abs(L[-1] - L[0]) >= TURN_CLEAR * self.min_step
                and all((L[i] - L[i - 1]) * way > 0.0 for i in (-1, -2))):
            if (self.end - L[0]) * way < 0.0:  # the torus lies towards turn_to
                self.end, self.turn_to = self.turn_to, self.end
            self._leave_pass(way, abs(L[-1] - L[-2]))
        elif len(L) - 1 >= GROW_STEPS:
            self.gave_up = True

    def _give_up(self) -> None:
        """The steps end; a pass of size steps under way takes its circles back (it found neither a fold nor a
        way past: the branch ends where the steps in lam failed)."""
        self.gave_up = True
        if self.mode == "size" and self.held:
            del self.lams[-len(self.held):], self.us[-len(self.held):]
            self.largest, self.held = self._pass_largest, []

    def _turn(self, k: int) -> None:
        """The fold at the pass's circle ``k``: located between it and its neighbours; the steps in ``lam`` go on
        the other way, towards the range's other end."""
        n = len(self.pass_lams)
        at = len(self.lams) - n + k
        xs = [np.r_[self.us[i], self.lams[i]] for i in (at - 1, at, at + 1)]
        tol = self.opts.locate_tol * max(1.0, abs(self.lams[at]))
        x, located, interval = refine_fold(self.problem, xs, tol, self.opts, divergence_factor=DIVERGED)
        m = self.problem.size
        self.turned = {"lam": float(x[m]), "u": x[:m], "located": located, "interval": interval, "back": n - 1 - k}
        self.end, self.turn_to = self.turn_to, self.end
        self.forward = 0
        self._leave_pass(-self.sign, abs(self.lam - self.turned["lam"]))

    def _leave_pass(self, way: float, reach: float | None = None) -> None:
        """Steps in ``lam`` again, the way ``way``, the first as long as ``reach`` (default: the last step's)."""
        if reach is None:
            reach = abs(self.lams[-1] - self.lams[-2])
        self.mode, self.sign = "lam", float(way)
        self.step = self.sign * min(max(reach, 2.0 * self.min_step), self.max_step)
        self.pass_lams, self.lam_fail = [], None
        self.lu = self.lu_at = None  # the factorisation of before the pass is far from here

    def reached(self) -> bool:
        return self.collapsed is None and not (self.end - self.lam) * self.sign > 1e-12 * max(1.0, abs(self.end))

    def message(self) -> str:
        """Where and why the steps stopped (module docstring)."""
        name, lam = self.problem.parameter, self.lam
        if self.collapsed is not None:
            return (f"the circle collapses onto a periodic orbit between {name}={lam:.10g} and "
                    f"{self.collapsed[0]:.10g} (size {self.collapsed[1]:.3g} there against {self.largest:.3g}): "
                    "a Neimark-Sacker point")
        if self.reached():
            return f"reached {name}={self.end:.10g}"
        rho = float(self.problem.blocks(self.us[-1])[1]) % 1.0
        near = rational_near(rho)
        where = lam if self.lam_fail is None else self.lam_fail
        tail = ("" if not self.gave_up else
                ", and steps at a fixed size of the circle from there found neither a fold nor a way past")
        return (f"Newton at fixed {name} failed at every step down to {self.min_step:g} beyond {name}={where:.10g}"
                f"{tail}: rho = {rho:.6f}, {rho - float(near):+.1e} from {near}")

    def state(self) -> dict:
        """What :meth:`restore` needs besides the circles (JSON-able but for arrays)."""
        at = self.lu_at
        return {"step": self.step, "largest": self.largest, "failures": self.failures,
                "lu_u": None if at is None else at[0], "lu_lam": None if at is None else at[1],
                "sign": self.sign, "end": self.end, "turn_to": self.turn_to, "mode": self.mode,
                "size_step": self.size_step, "last_delta": self.last_delta, "pass_lams": list(self.pass_lams),
                "lam_fail": self.lam_fail, "passes": self.passes,
                "forward": self.forward, "gave_up": self.gave_up}

    def restore(self, lams, us, state: dict) -> None:
        """Go on from the circles ``lams``, ``us`` (the last :meth:`circles_needed`, where there are so many: those
        :meth:`locking` reads, or those of the pass under way and the one before it) and ``state``."""
        self.lams, self.us = [float(v) for v in lams], [np.asarray(u, dtype=float) for u in us]
        self.step, self.largest = float(state["step"]), float(state["largest"])
        self.failures = int(state["failures"])
        self.lu = self.lu_at = None
        if state["lu_u"] is not None:  # the same factorisation again: the same Jacobian, the same LAPACK call
            u, lam = np.asarray(state["lu_u"], dtype=float), float(state["lu_lam"])
            self.lu, self.lu_at = factorize(self.problem.linearize(u, lam)[1]), (u, lam)
        if "mode" in state:  # a state written before the size steps has none of these
            self.sign, self.end = float(state["sign"]), float(state["end"])
            self.turn_to = None if state["turn_to"] is None else float(state["turn_to"])
            self.mode, self.size_step = str(state["mode"]), float(state["size_step"])
            self.last_delta = None if state["last_delta"] is None else float(state["last_delta"])
            self.pass_lams = [float(v) for v in state["pass_lams"]]
            self.lam_fail = None if state["lam_fail"] is None else float(state["lam_fail"])
            self.passes, self.gave_up = int(state["passes"]), bool(state["gave_up"])
            self.forward = int(state["forward"])

    @staticmethod
    def circles_needed(state: dict) -> int:
        """How many of the last circles :meth:`restore` needs with ``state``."""
        return max(LOCKING_FIT, len(state.get("pass_lams", ())) + 1)


def rational_near(rho: float) -> Fraction:
    """The ``p/q`` of smallest ``q <= CLOSE_DENOMINATOR`` within ``1 / (10 q^2)`` of ``rho``, else the one nearest
    ``rho`` with ``q <= NEAREST_DENOMINATOR``."""
    for q in range(1, CLOSE_DENOMINATOR + 1):
        p = round(rho * q)
        if abs(rho - p / q) <= 0.1 / q ** 2:
            return Fraction(p, q)
    return Fraction(rho).limit_denominator(NEAREST_DENOMINATOR)


class _Circles:
    """The stepper's circles as the branch :func:`~contin.bifurcation.circle_branch.locking_ahead` reads."""

    def __init__(self, lams, us):
        self.parameter, self.unknowns = lams, us

    def __len__(self) -> int:
        return len(self.parameter)


class _Linearizations:
    """``problem`` with the point of its last ``linearize`` call kept (where the chord's Jacobian was taken)."""

    def __init__(self, problem):
        self.problem, self.last = problem, None

    def linearize(self, u, lam):
        self.last = (np.array(u, dtype=float), float(lam))
        return self.problem.linearize(u, lam)


def step_circle(problem, u0, lam0: float, step: float, end: float, *, min_step: float = 1e-5,
                options: ContinuationOptions | None = None, measure=None, callback=None,
                turn_to: float | None = None) -> CircleSteps:
    """Circles at ``lam0 + step``, ``+ 2 step``, ... up to ``end`` (module docstring).

    Parameters
    ----------
    problem : InvariantCircleProblem
    u0 : array_like, shape (problem.size,)
        The circle at ``lam0`` (solved).
    lam0, end : float
    step : float
        The first and largest step; its sign must point from ``lam0`` to ``end``.
    min_step : float
        The steps end where Newton fails at every step down to this.
    options : ContinuationOptions, optional
        ``newton_tol`` and ``newton_max_iter`` (default 1e-8 and 20: the lazy Jacobian takes more, cheaper, updates).
    measure : callable, optional
        ``measure(u, lam) -> dict``, kept for every circle (the start included).
    callback : callable, optional
        ``callback(lam, u, iterations, row)`` after each circle.
    turn_to : float, optional
        The other end of the range: where the steps in ``lam`` fail, size steps try to turn a fold (or pass
        the place) and the steps go on (:class:`CircleStepper`); without it the steps end there.

    Raises
    ------
    ValueError
        If ``step`` is zero or points away from ``end``, or ``min_step`` is not positive.
    """
    stepper = CircleStepper(problem, u0, lam0, step, end, min_step=min_step, options=options, turn_to=turn_to)
    its = [0]
    rows = [measure(stepper.us[0], stepper.lam)] if measure is not None else []
    folds = []
    while stepper.going():
        found = stepper.attempt()
        if stepper.turned is not None:
            folds.append({**stepper.turned, "index": len(stepper.lams) - 1 - stepper.turned["back"]})
            stepper.turned = None
        for lam, r in found:
            its.append(r.iterations)
            if measure is not None:
                rows.append(measure(r.x, lam))
            if callback is not None:
                callback(lam, r.x, r.iterations, rows[-1] if rows else None)
    return CircleSteps(np.asarray(stepper.lams), np.asarray(stepper.us), np.asarray(its, dtype=int),
                       stepper.reached(), stepper.message(), rows, folds)
