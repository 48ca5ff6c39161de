"""Following a torus branch of invariant circles (:mod:`contin.timedomain.invariant_circle`), with its ends told.

The branch is traced by the continuation engine; every stored point
carries ``circle_spread``, the largest peak-to-peak range of a state
component over the circle's points (its size). A circle branch ends, beside
the engine's own ends, where the torus stops existing as a circle of the
map:

- **collapse**: the circle shrinks onto the periodic orbit it was born from,
  at a Neimark-Sacker point, where the parameter turns. Past it the circles
  grow again with their angle turned by half a turn (the same tori,
  retraced), so the branch is stopped at the first stored circle whose
  points, centred, correlate negatively with those of the circle before
  (the flip) while one of the two is smaller than ``FLIP_SPREAD`` of the
  largest so far; status ``boundary`` and an ``ns`` special point at the
  furthest parameter value reached.
- **locking**: the steps fail with the rotation number at a rational ``p/q``
  of small ``q``: the torus carries periodic orbits of ``q`` forcing periods
  (an Arnold tongue), and a circle discretised by points of a grid no longer
  determines the rotation number; status ``boundary`` and a ``locking``
  special point naming ``p/q``. Steps that fail short of the tongue, where
  the rotation number still heads for ``p/q`` as the square root of the
  distance to its edge, lock at that edge extrapolated
  (:func:`locking_ahead`). :func:`locked_orbits` finds the periodic
  orbits of ``q`` forcing periods there, by multiple shooting (one segment a
  forcing period) started from the circle's points, and tells the rotation
  ``p/q`` each one makes around the circle; :func:`locked_starts` makes them
  the first points of their branches (a diagram follows them, children of
  the circle branch), each parametrised at the section of its orbit
  farthest from the contact switches (:mod:`contin.timedomain.shooting_section`)
  and shot in one segment where its multipliers allow (:data:`SINGLE_SHOOTING`).

Any other end keeps the engine's status and message.
"""

from __future__ import annotations

import dataclasses
from fractions import Fraction

import numpy as np

from contin.bifurcation.switching import BranchStart
from contin.bifurcation.torus_branch import end_as_boundary
from contin.engine.branch import Branch, BranchStatus, SpecialKind
from contin.engine.continuation import ContinuationOptions, continuation
from contin.engine.problem import solve_at
from contin.timedomain.invariant_circle import (CircleOptions, InvariantCircleProblem, circle_lyapunov, circle_start,
                                               point_jacobians)
from contin.timedomain.multiple_shooting import ShootingProblem
from contin.timedomain.shooting_options import ShootingOptions
from contin.timedomain.shooting_section import at_quiet_section, state_at_zero
from contin.timedomain.torus_check import check_circle

__all__ = ["CHECK_PERIODS", "FLIP_SPREAD", "LOCKING_FIT", "LOCKING_REACH", "LOCKING_SHAPE", "LOCKING_TOL",
           "LYAPUNOV_PERIODS", "MAX_DENOMINATOR", "PAIR_MULTIPLIER", "SINGLE_SHOOTING", "CircleStabilityMonitor",
           "CircleStart", "LOCKED_OFFSETS", "LockedOrbit", "circle_child_start", "circle_spread", "classify_circle_end",
           "follow_circle", "locked_orbits", "locked_starts", "locking_ahead"]

#: a flip counts as the collapse where the circle is this small against its largest (elsewhere it would be the
#: parametrisation turning, not the circle shrinking)
FLIP_SPREAD = 0.25
#: a failing branch whose rotation number lies this close to ``p/q`` (``q <= MAX_DENOMINATOR``) has locked
LOCKING_TOL = 2e-3
MAX_DENOMINATOR = 6

#: the engine's ends with nothing to tell: as asked, or a jump the engine's message says (no locking or collapse)
_TOLD = (BranchStatus.RANGE_END, BranchStatus.MAX_POINTS, BranchStatus.CLOSED_LOOP, BranchStatus.RETRACED)


def circle_spread(problem, u) -> float:
    """A circle's size: the largest peak-to-peak range of a state component over its points."""
    U, _ = problem.blocks(u)
    return float(np.max(np.ptp(U, axis=0)))


def follow_circle(problem, u0, lam0: float, lam_range, options: ContinuationOptions | None = None, *,
                  tangent=None, solve_start: bool = False, parameter_name: str | None = None,
                  max_denominator: int = MAX_DENOMINATOR, locking_tol: float = LOCKING_TOL, monitors=(),
                  callback=None, checkpoint=None, resume=None) -> Branch:
    """Trace the circle branch from ``u0`` (for example :func:`~contin.timedomain.invariant_circle.circle_start`)
    and tell its end (module docstring).

    Parameters
    ----------
    problem : InvariantCircleProblem
    u0 : array_like, shape (problem.size,)
    lam0 : float
    lam_range : (float, float)
    options : ContinuationOptions, optional
    tangent : array_like, optional
        The start's tangent (``circle_start`` gives it).
    solve_start : bool
        Correct the start at ``lam0`` first (False: on the hyperplane normal to ``tangent``).
    parameter_name : str, optional
    max_denominator, locking_tol
        Rationals taken as locking, and how close.
    monitors, callback, checkpoint
        The engine's (:func:`contin.engine.continuation.continuation`); ``callback`` is called at every stored
        point, the flip included.
    resume : callable, optional
        ``resume(problem, options, monitors, callback) -> Branch`` takes up the same branch of an interrupted
        run instead of tracing it from ``u0``.

    Returns
    -------
    Branch
        ``point_data["circle_spread"]`` at every point.
    """
    flipped = []

    def monitor(u, lam, Ju=None, Jlam=None):
        return {"circle_spread": circle_spread(problem, u)}

    def watch(branch: Branch, index: int):
        going = True if callback is None else callback(branch, index) is not False
        if index > 0:
            spread = branch.point_data["circle_spread"]
            small = min(spread[index], spread[index - 1]) < FLIP_SPREAD * max(spread[:index + 1])
            now, before = (_centred(problem, branch.unknowns[i]) for i in (index, index - 1))
            if small and float(np.sum(now * before)) < 0.0:
                flipped.append(index)
                return False
        return going

    mons = [monitor, *monitors]
    if resume is not None:
        br = resume(problem, options, mons, watch)
    else:
        br = continuation(problem, u0, lam0, lam_range, options, parameter_name=parameter_name or problem.parameter,
                          monitors=mons, tangent=tangent, solve_start=solve_start, callback=watch,
                          checkpoint=checkpoint)
    classify_circle_end(br, problem, max_denominator, locking_tol, collapsed=bool(flipped))
    return br


def _centred(problem, u) -> np.ndarray:
    U, _ = problem.blocks(u)
    return U - U.mean(axis=0)


def classify_circle_end(branch: Branch, problem, max_denominator: int = MAX_DENOMINATOR,
                        locking_tol: float = LOCKING_TOL, collapsed: bool = False) -> None:
    """Tell a circle branch's end: collapse (``collapsed``: stopped at a flip) or locking (module docstring);
    changes ``branch`` in place."""
    if not len(branch) or branch.status in _TOLD:
        return
    u, lam = branch.unknowns[-1], float(branch.parameter[-1])
    name = branch.parameter_name
    spread = np.asarray(branch.point_data["circle_spread"], dtype=float)
    rho = float(problem.blocks(u)[1]) % 1.0
    f = Fraction(rho).limit_denominator(max_denominator)
    i = len(branch) - 1
    if collapsed and branch.status is BranchStatus.INTERRUPTED:
        far = branch.parameter[np.argmax(np.abs(branch.parameter - branch.parameter[0]))]
        i = int(np.argmin(spread[-2:])) + len(branch) - 2
        u, lam = branch.unknowns[i], float(far)
        kind = SpecialKind.NS
        why = (f"the torus shrinks onto the periodic orbit at a Neimark-Sacker point near {name}={lam:.10g}, "
               f"where the parameter turns (circle spread {spread[i]:.3g} there, {spread.max():.3g} at most; "
               f"the circles beyond retrace the branch turned by half a turn)")
    elif branch.status is BranchStatus.INTERRUPTED:
        return
    elif abs(rho - float(f)) < locking_tol:
        kind = SpecialKind.LOCKING
        why = (f"the torus locks: its rotation number {rho:.6g} sits at {f} at {name}={lam:.10g} (periodic "
               f"orbits of {f.denominator} forcing periods on it)")
    else:
        ahead = locking_ahead(branch, problem, max_denominator)
        if ahead is None:
            return
        f, edge = ahead
        end_as_boundary(branch, SpecialKind.LOCKING, edge, u, i,
                        {"rotation_number": rho, "rational": str(f), "predicted": edge},
                        f"the torus locks: its rotation number {rho:.6g} approaches {f} as the square root of the "
                        f"distance to {name}={edge:.10g} (extrapolated from its last {LOCKING_FIT} circles), where "
                        f"periodic orbits of {f.denominator} forcing periods appear on it", "circle end")
        return
    end_as_boundary(branch, kind, lam, u, i, {"rotation_number": rho, "rational": str(f)}, why, "circle end")


#: circles of a branch's end that :func:`locking_ahead` extrapolates
LOCKING_FIT = 3
#: how far beyond the last circle (relative to ``max(1, |lam|)``) an extrapolated locking is taken: as far as
#: :func:`locked_starts` looks for the locked orbits
LOCKING_REACH = 2e-3
#: the earlier circles' squared distances must lie within this factor of the extrapolated line
#: (docs/theory/quasi-periodic.md: the rotor's torus that locks onto its subharmonic)
LOCKING_SHAPE = 1.5


def locking_ahead(branch: Branch, problem, max_denominator: int = MAX_DENOMINATOR):
    """``(p/q, lam_c)`` where a circle branch's end heads for a locking just beyond its last circle, else None.

    At the edge of an Arnold tongue two periodic orbits of ``q`` forcing periods appear on the torus in a
    saddle-node, and the rotation number approaches ``p/q`` as the square root of the distance to it,
    ``(rho - p/q)^2 ~ c (lam_c - lam)`` (the passage through the saddle-node's bottleneck, whose time grows as
    ``1 / sqrt(lam_c - lam)``: Pikovsky, Rosenblum & Kurths, *Synchronization*, Cambridge 2001, sec. 7.1;
    Strogatz, *Nonlinear Dynamics and Chaos*, sec. 4.3). Steps of the parameter fail before it, where the
    circle's points bunch in the bottleneck. From the last :data:`LOCKING_FIT` circles: ``p/q`` the rational
    of ``q <= max_denominator`` nearest the last rotation number, approached monotonically; ``lam_c`` the zero
    of the line through the last two values of ``(rho - p/q)^2``, taken where it lies ahead within
    :data:`LOCKING_REACH` and the earlier circle lies on the line within :data:`LOCKING_SHAPE` (the law holds as
    the tongue is approached, not far from it; a rotation number that jumps at the last circle does not).
    """
    if len(branch) < LOCKING_FIT:
        return None
    lam = np.asarray(branch.parameter[-LOCKING_FIT:], dtype=float)
    rho = np.array([float(problem.blocks(u)[1]) % 1.0 for u in branch.unknowns[-LOCKING_FIT:]])
    f = Fraction(float(rho[-1])).limit_denominator(max_denominator)
    d2 = (rho - float(f)) ** 2
    way = np.sign(lam[-1] - lam[-2])
    if way == 0 or not (np.all(np.diff(lam) * way > 0) and np.all(np.diff(d2) < 0)):
        return None
    slope = (d2[-1] - d2[-2]) / (lam[-1] - lam[-2])
    lam_c = float(lam[-1] - d2[-1] / slope)
    if not 0.0 < (lam_c - lam[-1]) * way <= LOCKING_REACH * max(1.0, abs(float(lam[-1]))):
        return None
    line = slope * (lam[:-2] - lam_c)
    if not np.all((line > d2[:-2] / LOCKING_SHAPE) & (line < LOCKING_SHAPE * d2[:-2])):
        return None
    return f, lam_c


@dataclasses.dataclass(frozen=True)
class LockedOrbit:
    """A periodic orbit of ``q`` forcing periods on a locked torus (:func:`locked_orbits`).

    Attributes
    ----------
    problem : ShootingProblem
        Its multiple shooting (``q`` segments, one a forcing period), to follow it with the engine.
    unknowns : ndarray, shape (2 n q,)
        The states at ``t = k T``, ``k = 0 .. q - 1``.
    rotation : Fraction
        ``p/q``: each forcing period advances the orbit by ``p/q`` of a turn around the circle.
    distance : float
        The largest distance of its states from the circle's points (the circle's resolution).
    multipliers : ndarray, shape (2 n,)
        Floquet multipliers over ``q`` periods, by decreasing modulus.
    """

    problem: ShootingProblem
    unknowns: np.ndarray
    rotation: Fraction
    distance: float
    multipliers: np.ndarray


def _angles(U, Z) -> np.ndarray:
    # the circle's angle nearest each state of Z (K, 2n): from the circle's points U (N, 2n), refined by the
    # parabola through the nearest one and its neighbours
    N = len(U)
    out = np.empty(len(Z))
    for k, z in enumerate(Z):
        d = np.sum((U - z) ** 2, axis=1)
        j = int(np.argmin(d))
        a, b, c = d[j - 1], d[j], d[(j + 1) % N]
        curv = a - 2.0 * b + c
        out[k] = (j + (0.5 * (a - c) / curv if curv > 0 else 0.0)) / N
    return out % 1.0


def locked_orbits(problem, u, lam: float, q: int, *, tol: float = 1e-10, max_iter: int = 12,
                  starts: int | None = None) -> list[LockedOrbit]:
    """The periodic orbits of ``q`` forcing periods near a circle that locks (module docstring).

    Parameters
    ----------
    problem : InvariantCircleProblem
    u : ndarray, shape (problem.size,)
        The circle, at or near its locking end.
    lam : float
    q : int
        The denominator of the locking ratio.
    tol, max_iter
        Newton's tolerance (``max |R| <= tol max(1, max |u|)``) and updates.
    starts : int, optional
        How many of the circle's points start Newton (evenly spaced; default all).

    Returns
    -------
    list of LockedOrbit
        The distinct orbits found (a cyclic shift of the segment starts is the same orbit), those of fewer
        periods left out.
    """
    if isinstance(q, bool) or not isinstance(q, (int, np.integer)) or q < 1:
        raise ValueError(f"locked_orbits: q must be a positive integer, got {q!r}")
    U, _ = problem.blocks(u)
    shoot = ShootingProblem(problem.model, problem.parameter, problem.map.base,
                            ShootingOptions(steps_per_period=problem.options.steps_per_period, subharmonic=int(q),
                                            segments=int(q)))
    n2 = 2 * problem.n
    pick = np.unique(np.linspace(0, len(U), starts or len(U), endpoint=False).astype(int))
    found: list[LockedOrbit] = []
    for j in pick:
        try:
            x = solve_at(shoot, shoot.start_unknowns(U[j], lam), lam, tol=tol, max_iter=max_iter,
                         what=f"orbit of {q} periods")
        except ArithmeticError:
            continue
        Z = x.reshape(q, n2)
        scale = max(1.0, float(np.max(np.abs(Z))))
        if any(np.max(np.abs(np.roll(Z, d, axis=0) - Z)) < 1e-6 * scale for d in range(1, q) if q % d == 0):
            continue  # an orbit of fewer periods (the torus' own periodic orbit, run q times): not on the tongue
        if any(min(np.max(np.abs(np.roll(Z, k, axis=0) - o.unknowns.reshape(q, n2))) for k in range(q)) < 1e-6 * scale
               for o in found):
            continue
        theta = _angles(U, Z)
        steps = (np.diff(np.r_[theta, theta[0]]) % 1.0)
        rot = Fraction(float(np.mean(steps)) if q > 1 else 0.0).limit_denominator(q)
        dist = float(max(np.min(np.max(np.abs(U - z), axis=1)) for z in Z))
        found.append(LockedOrbit(shoot, x, rot, dist, shoot.multipliers(x, lam)))
    return found


#: periods of the circle map averaged for a point's Lyapunov exponents (products of interpolated Jacobians,
#: no flow: a few microseconds each)
LYAPUNOV_PERIODS = 4000
#: forcing periods simulated off a circle whose exponents give no verdict
CHECK_PERIODS = 400


class CircleStabilityMonitor:
    """Engine monitor: a circle's stability from the Lyapunov exponents of the map along it.

    The map's Jacobians at the circle's points are read off the circle's own
    Jacobian at the solution, those halfway between integrated (one
    variational flow each; :func:`~contin.timedomain.invariant_circle.point_jacobians`);
    interpolated along the circle and multiplied over :data:`LYAPUNOV_PERIODS`
    periods (:func:`~contin.timedomain.invariant_circle.circle_lyapunov`), the
    ``2N`` of them give the exponents and the ``N`` points alone the same
    again: their difference is the error of the interpolation (the flow map's
    Jacobian has corners along a circle where a contact arc opens), which a
    verdict must exceed. Reported in the columns of a periodic branch:
    ``stable``; ``n_unstable`` the normal exponents above zero;
    ``max_multiplier`` ``exp`` of the largest normal exponent (the growth of
    the fastest normal perturbation over a forcing period); and
    ``normal_exponent`` with its ``normal_exponent_error``. Where the
    exponents give no verdict (the largest normal one within its error or
    within the tangential one's modulus of zero: on a circle with corners
    the tangential exponent, exactly zero for exact data, is often the
    larger), a simulation started off the circle decides
    (:func:`contin.timedomain.torus_check.check_circle`, ``simulation``
    periods; 0: never), and ``max_multiplier`` is ``exp`` of its fitted rate,
    taken at most 0 (at least 0) for a stable (unstable) verdict; still
    undecided is no verdict, and so is a simulation's verdict against the
    exponent's sign where that stands clear of the interpolation's error
    (below the verdict's floor: a weakly unstable torus near its
    Neimark-Sacker point, whose slow departure the simulation does not see).
    """

    def __init__(self, problem, periods: int = LYAPUNOV_PERIODS, simulation: int = CHECK_PERIODS):
        self.problem = problem
        self.periods = periods
        self.simulation = int(simulation)
        self.undecided: list[float] = []  # parameter values without a verdict
        self.simulated: list[float] = []  # those the simulation decided

    def __call__(self, u, lam, Ju=None, Jlam=None) -> dict:
        jac = point_jacobians(self.problem, u, lam, Ju, midpoints=True)
        fine = circle_lyapunov(self.problem, u, lam, iterations=self.periods, jacobians=jac)
        coarse = circle_lyapunov(self.problem, u, lam, iterations=self.periods, jacobians=jac[0::2])
        error = abs(fine.largest_normal - coarse.largest_normal)
        stable = fine.stable if abs(fine.largest_normal) > error else None
        normal = np.delete(fine.exponents, fine.tangent)
        unstable, largest = int(np.sum(normal > 0.0)), float(fine.largest_normal)
        # the exponent's sign, where it stands clear of the interpolation's error, though not of the
        # verdict's floor (the simulation is asked for the circles whose Jacobians the interpolation misses)
        sign = np.sign(largest) if abs(largest) > error else 0.0
        if stable is None and self.simulation:
            check = check_circle(self.problem, u, lam, periods=self.simulation)
            # a simulation's verdict against that sign is none: over its periods a weak instability
            # is hidden by the faster normal directions dying out (a torus near its Neimark-Sacker point)
            stable = None if check.stable is not None and sign == (1.0 if check.stable else -1.0) \
                else check.stable
            if stable is not None:  # its rate, on the side of its verdict
                self.simulated.append(float(lam))
                unstable = 0 if stable else max(unstable, 1)
                largest = min(check.rate, 0.0) if stable else max(check.rate, 0.0)
        if stable is None:
            self.undecided.append(float(lam))
        return {"evaluated": stable is not None, "stable": bool(stable), "n_unstable": unstable,
                "max_multiplier": float(np.exp(min(largest, 700.0))), "normal_exponent": float(fine.largest_normal),
                "normal_exponent_error": float(error)}

    def state(self) -> dict:
        """The parameter values without a verdict and those a simulation decided (a checkpoint's)."""
        return {"undecided": list(self.undecided), "simulated": list(self.simulated)}

    def restore(self, state: dict) -> None:
        self.undecided = [float(v) for v in state["undecided"]]
        self.simulated = [float(v) for v in state["simulated"]]


@dataclasses.dataclass(frozen=True)
class CircleStart:
    """The first point of a circle branch (:func:`circle_child_start`): its problem, unknowns, parameter and
    tangent; ``kind``, ``side`` and ``eps`` (the ellipse's size relative to the state) as a switch's start says
    them."""

    problem: InvariantCircleProblem
    u: np.ndarray
    lam: float
    tangent: np.ndarray | None
    kind: str = "ns"
    side: int = 1
    eps: float = 1e-3
    #: correct ``u`` at ``lam`` first (a start from a fitted guess; a switch's start is corrected by the engine)
    solve_start: bool = False


def circle_child_start(shooting, lam: float, unknowns, points: int) -> CircleStart:
    """The first circle of the torus born at a Neimark-Sacker point of a shooting branch.

    Parameters
    ----------
    shooting : ShootingProblem
        The branch's problem (one forcing period: ``nu = 1``).
    lam : float
        The Neimark-Sacker point.
    unknowns : array_like, shape (shooting.size,)
        The orbit there (its unknowns at any section: the circle starts from its state at forcing phase zero).
    points : int
        ``N``, points of the circle.

    Raises
    ------
    ValueError
        For a subharmonic branch, or where no multiplier pair lies on the unit circle.
    """
    if shooting.nu != 1:
        raise ValueError(f"the torus of a Neimark-Sacker point of a branch of {shooting.nu} forcing periods is "
                         f"not built (its circle would be of the map over {shooting.nu} periods)")
    z = state_at_zero(shooting, np.asarray(unknowns, dtype=float), float(lam))  # the circle's map starts there
    opts = CircleOptions(points=int(points), steps_per_period=shooting.options.steps_per_period)
    problem, u0, tangent = circle_start(shooting.model, shooting.parameter, z, float(lam), shooting.base, opts,
                                        eps=CircleStart.eps)
    return CircleStart(problem, u0, float(lam), tangent)


#: a locked orbit whose largest multiplier is below this is followed by single shooting (one segment of ``q``
#: forcing periods), at its quiet section: with one section, only one state of the orbit shapes the branch's steps
SINGLE_SHOOTING = 1e3
#: how far into the tongue the orbits of a locked circle are sought, in turn (relative to ``max(1, |lam|)``)
LOCKED_OFFSETS = (1e-4, 3e-4, 5.6e-4, 1e-3, 2e-3)


def locked_starts(problem, branch: Branch, starts: int = 11) -> list:
    """First points of the branches of periodic orbits at a circle branch's locking end.

    At an extrapolated edge of the tongue (:func:`locking_ahead`) and a little
    past it, then a little past the last circle, into the tongue
    (:data:`LOCKED_OFFSETS` in turn, until some are found), :func:`locked_orbits` finds the orbits of
    ``q`` forcing periods from ``starts`` of its points; each one starts a
    branch of shooting at its quiet section (one segment, or ``q`` where a
    multiplier reaches :data:`SINGLE_SHOOTING`), its tangent
    the null vector of ``[dR/du dR/dlam]`` pointing on into the tongue. Where
    they are the node and the saddle born together at the tongue's edge, the
    node starts two branches instead, one on into the tongue and one back to
    the edge, where it folds (the edge, located) onto the saddle's branch.

    Returns
    -------
    list of BranchStart
        Empty where the branch did not lock, or no orbit was found.
    """
    locks = [sp for sp in branch.special_points if sp.kind is SpecialKind.LOCKING]
    if not locks or len(branch) < 2:
        return []
    q = Fraction(str(locks[-1].data["rational"])).denominator
    last = float(branch.parameter[-1])
    ahead = float(np.sign(last - float(branch.parameter[0]))) or 1.0  # the branch's way (its last steps zigzag)
    # a locking extrapolated ahead of the last circle (locking_ahead) is sought there first
    edge = locks[-1].data.get("predicted")
    lams = [] if edge is None else [edge + ahead * offset * max(1.0, abs(edge))
                                    for offset in (0.0,) + LOCKED_OFFSETS[:3]]
    lams += [last + ahead * offset * max(1.0, abs(last)) for offset in LOCKED_OFFSETS]
    orbits = []
    for lam in lams:
        orbits = locked_orbits(problem, branch.unknowns[-1], lam, q, starts=starts, max_iter=20)
        if orbits:
            break
    # the two orbits born together at the tongue's edge: the node's branch goes on into the tongue and back
    # out to the edge, where it folds onto the saddle's (the edge located as that fold)
    pair = _saddle_node_pair(orbits)
    plan = [(pair[0], ahead), (pair[0], -ahead)] if pair else [(o, ahead) for o in orbits]
    out = []
    charts = {}  # each orbit's unknowns at its quiet section (the node starts two branches)
    for o, way in plan:
        if id(o) not in charts:
            single = float(np.max(np.abs(o.multipliers))) < SINGLE_SHOOTING
            charts[id(o)] = at_quiet_section(o.problem, o.unknowns, lam, 1 if single else None)
        shoot, u = charts[id(o)]
        _, Ju, Jlam = shoot.linearize(u, lam)
        tangent = np.linalg.svd(np.c_[Ju, Jlam])[2][-1]
        tangent *= np.sign(tangent[-1] * way) or 1.0
        out.append(BranchStart(shoot, u, lam, tangent, SpecialKind.LOCKING, tangent[:-1], abs(lam - last),
                               int(way * ahead), (u, lam)))
    return out


#: a locked orbit's multiplier this close to +1 is the one of the saddle-node it was born in
PAIR_MULTIPLIER = 0.1


def _saddle_node_pair(orbits) -> tuple | None:
    """``(node, saddle)`` where ``orbits`` are the two born in one saddle-node at a tongue's edge, else None: the
    saddle with one multiplier outside the unit circle, real and within :data:`PAIR_MULTIPLIER` of +1, the node
    with none outside and a real one within :data:`PAIR_MULTIPLIER` of +1."""
    if len(orbits) != 2:
        return None

    def near_one(mu):
        return (np.abs(mu.imag) < 1e-9) & (np.abs(mu.real - 1.0) < PAIR_MULTIPLIER)

    kinds = []
    for o in orbits:
        mu = np.asarray(o.multipliers, dtype=complex)
        outside = np.abs(mu) > 1.0
        if not outside.any() and near_one(mu).any():
            kinds.append("node")
        elif outside.sum() == 1 and near_one(mu[outside]).all():
            kinds.append("saddle")
        else:
            return None
    if sorted(kinds) != ["node", "saddle"]:
        return None
    node = kinds.index("node")
    return orbits[node], orbits[1 - node]
