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
  special point naming ``p/q``.

Any other end keeps the engine's status and message.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np

from contin.bifurcation.torus_branch import end_as_boundary
from contin.engine.branch import Branch, BranchStatus, SpecialKind
from contin.engine.continuation import ContinuationOptions, continuation

__all__ = ["FLIP_SPREAD", "LOCKING_TOL", "MAX_DENOMINATOR", "classify_circle_end", "follow_circle"]

#: a flip counts as the collapse where the circle is this small against its largest (elsewhere it would be the
#: parametrisation turning, not the circle shrinking)
FLIP_SPREAD = 0.25
#: a failing branch whose rotation number lies this close to ``p/q`` (``q <= MAX_DENOMINATOR``) has locked
LOCKING_TOL = 2e-3
MAX_DENOMINATOR = 6

#: the engine's ends that are as asked (nothing to tell)
_AS_ASKED = (BranchStatus.RANGE_END, BranchStatus.MAX_POINTS, BranchStatus.CLOSED_LOOP)


def _spread(problem, u) -> float:
    U, _ = problem.blocks(u)
    return float(np.max(np.ptp(U, axis=0)))


def follow_circle(problem, u0, lam0: float, lam_range, options: ContinuationOptions | None = None, *,
                  tangent=None, solve_start: bool = False, parameter_name: str | None = None,
                  max_denominator: int = MAX_DENOMINATOR, locking_tol: float = LOCKING_TOL) -> Branch:
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

    Returns
    -------
    Branch
        ``point_data["circle_spread"]`` at every point.
    """
    flipped = []

    def monitor(u, lam, Ju=None, Jlam=None):
        return {"circle_spread": _spread(problem, u)}

    def watch(branch: Branch, index: int):
        if index > 0:
            spread = branch.point_data["circle_spread"]
            small = min(spread[index], spread[index - 1]) < FLIP_SPREAD * max(spread[:index + 1])
            now, before = (_centred(problem, branch.unknowns[i]) for i in (index, index - 1))
            if small and float(np.sum(now * before)) < 0.0:
                flipped.append(index)
                return False
        return True

    br = continuation(problem, u0, lam0, lam_range, options, parameter_name=parameter_name or problem.parameter,
                      monitors=[monitor], tangent=tangent, solve_start=solve_start, callback=watch)
    classify_circle_end(br, problem, max_denominator, locking_tol, collapsed=bool(flipped))
    return br


def _centred(problem, u) -> np.ndarray:
    U, _ = problem.blocks(u)
    return U - U.mean(axis=0)


def classify_circle_end(branch: Branch, problem, max_denominator: int = MAX_DENOMINATOR,
                        locking_tol: float = LOCKING_TOL, collapsed: bool = False) -> None:
    """Tell a circle branch's end: collapse (``collapsed``: stopped at a flip) or locking (module docstring);
    changes ``branch`` in place."""
    if not len(branch) or branch.status in _AS_ASKED:
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
    elif branch.status is not BranchStatus.INTERRUPTED and abs(rho - float(f)) < locking_tol:
        kind = SpecialKind.LOCKING
        why = (f"the torus locks: its rotation number {rho:.6g} sits at {f} at {name}={lam:.10g} (periodic "
               f"orbits of {f.denominator} forcing periods on it)")
    else:
        return
    end_as_boundary(branch, kind, lam, u, i, {"rotation_number": rho, "rational": str(f)}, why, "circle end")
