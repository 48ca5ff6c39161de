"""A circle branch in natural-parameter steps, stored as an engine branch (``torus: {continuation: natural}``).

The circles come from :class:`~contin.bifurcation.circle_steps.CircleStepper`
(Newton at fixed ``lam``, the step halved where it fails); every one is
stored as a point of a :class:`~contin.engine.branch.Branch`, with the
monitors' values (the circle's size ``circle_spread`` and its stability),
the secant as its tangent and the secant's length as its arclength, so
that rows, special points, checkpoints and figures treat it as any branch.
The steps are ``continuation.ds`` (the first), at most ``ds_max`` and at
least ``ds_min``, in the options' ``direction``; Newton's iterations are
``newton_max_iter``, at least :data:`MIN_NEWTON_ITER` (the chord updates
of the lazy Jacobian count).

Ends: the range's end (``range_end``); a circle that collapses onto its
periodic orbit (``boundary`` with an unlocated ``ns`` point: a
Neimark-Sacker point, where the torus is born: an end as asked); Newton
failing at every step down to ``ds_min``, and a pass of steps at a fixed
size of the circle failing after it, with the rotation number at ``p/q`` of
small ``q`` (``boundary`` with a ``locking`` point,
:func:`~contin.bifurcation.circle_branch.classify_circle_end`), or
elsewhere (``step_too_small``: a breakdown of the torus, or a tongue's edge;
the run is incomplete). Where the size steps turn back in ``lam``, the
branch turns at a fold of the torus (a ``fold`` point, located between
circles at a fixed size: :mod:`contin.bifurcation.circle_fold`) and goes on
towards the range's other end. Where the stability
verdicts of two neighbouring circles differ, an unlocated ``stability`` point
between them says so: a bifurcation of the torus, or a step across a fold
of tori onto its other half (both tori exist on one side of the fold, and a
step from one half may land on the other, which natural steps cannot
tell). After each stored circle ``checkpoint(branch, state)`` receives
``{"points", "natural": CircleStepper.state(), "monitors"}``; a resumed
branch goes on from its last circles (two, or those of a pass of size
steps under way) and the same chord factorisation, as the uninterrupted
run would.
"""

from __future__ import annotations

import numpy as np

from contin.bifurcation.circle_branch import circle_spread, classify_circle_end
from contin.bifurcation.circle_steps import CircleStepper
from contin.bifurcation.torus_branch import end_as_boundary
from contin.engine.branch import Branch, BranchBuilder, BranchStatus, SpecialKind, SpecialPoint
from contin.engine.newton import NUMERICAL_ERRORS, solve_at_parameter
from contin.engine.options import ContinuationOptions
from contin.engine.problem import evaluate_monitors

__all__ = ["MIN_NEWTON_ITER", "follow_circle_steps"]

#: the fewest Newton updates a step is given (chord updates are cheap and many)
MIN_NEWTON_ITER = 20


def follow_circle_steps(problem, u0, lam0: float, lam_range, options: ContinuationOptions, *, monitors=(),
                        callback=None, checkpoint=None, previous: Branch | None = None, solve_start: bool = False,
                        parameter_name: str | None = None, grow: bool = False) -> Branch:
    """Trace the circle branch from ``u0`` at ``lam0`` in natural steps (module docstring).

    Parameters
    ----------
    problem : InvariantCircleProblem
    u0 : array_like, shape (problem.size,)
    lam0 : float
    lam_range : (float, float)
    options : ContinuationOptions
        ``ds``, ``ds_min``, ``ds_max``, ``direction``, ``newton_tol``, ``newton_max_iter``, ``max_points``.
    monitors : sequence of callable
        ``monitor(u, lam, Ju, Jlam) -> dict`` at every stored circle (``Ju``, ``Jlam`` None).
    callback : callable, optional
        ``callback(branch, index)`` after each stored circle; False stops the branch (``interrupted``).
    checkpoint : callable, optional
        ``checkpoint(branch, state)`` after each stored circle and at the end (``state`` then holds only the
        monitors'), as the engine's.
    previous : Branch, optional
        The same branch of an interrupted run: a finished one is returned as it is, an unfinished one goes on
        from ``previous.info["restart"]``.
    solve_start : bool
        Correct ``u0`` at ``lam0`` first (a fitted guess).
    parameter_name : str, optional
    grow : bool
        ``u0`` is the first guess of a circle born at a Neimark-Sacker point at ``lam0``: size steps grow it
        until the parameter has moved away, and the steps go on the way it moved (the options' ``direction``
        does not apply; :class:`~contin.bifurcation.circle_steps.CircleStepper`). The guess is not stored.

    Returns
    -------
    Branch
        ``point_data["circle_spread"]`` at every point; ``info["continuation"] == "natural"``.
    """
    name = parameter_name or problem.parameter
    lo, hi = (float(v) for v in lam_range)
    mons = [lambda u, lam, Ju=None, Jlam=None: {"circle_spread": circle_spread(problem, u)}, *monitors]
    if previous is not None and previous.status is not BranchStatus.INTERRUPTED:
        _restore_monitors(mons, previous.info.get("monitor_states"))
        return previous
    opts = options.replace(newton_max_iter=max(options.newton_max_iter, MIN_NEWTON_ITER))
    end, other = (hi, lo) if options.direction > 0 else (lo, hi)
    first = options.direction * min(options.ds, options.ds_max)
    if previous is not None:
        state = previous.info.pop("restart", None)
        if state is None or not len(previous):
            raise ValueError("resume: a circle branch without the state of its last circle")
        builder = BranchBuilder(name, problem.size, branch=previous)
        previous.status, previous.message = BranchStatus.RUNNING, ""
        stepper = CircleStepper(problem, previous.unknowns[-1], float(previous.parameter[-1]), first, end,
                                min_step=options.ds_min, max_step=options.ds_max, options=opts, turn_to=other)
        k = CircleStepper.circles_needed(state["natural"])
        stepper.restore(previous.parameter[-k:], previous.unknowns[-k:], state["natural"])
        _restore_monitors(mons, state.get("monitors"))
    else:
        builder = BranchBuilder(name, problem.size)
        # no scales: the steps are in the parameter alone (the header of the branch's first row records these)
        builder.branch.info.update(unknown_scale=np.ones(problem.size), parameter_scale=1.0, continuation="natural",
                                   lam_range=(lo, hi))
        u, iterations, res = np.asarray(u0, dtype=float), 0, float("nan")
        if solve_start:
            try:
                r = solve_at_parameter(problem, u, lam0, opts)
            except NUMERICAL_ERRORS as exc:
                r = None
                why = f"{type(exc).__name__}: {exc}"
            if r is None or not r.converged:
                return builder.finish(BranchStatus.START_FAILED, f"no circle at {name}={lam0:.10g}: "
                                      + (why if r is None else r.message))
            u, iterations, res = r.x, r.iterations, r.residual_norm
        # a start at the range's end it goes to: one circle, the range's end reached
        stepper = CircleStepper(problem, u, lam0, first, end, min_step=options.ds_min, max_step=options.ds_max,
                                options=opts, turn_to=other, grow=grow)
        if not grow:
            builder.append_point(u, lam0, _start_tangent(problem.size, options.direction), 0.0, iterations, 0.0,
                                 _finite(res, problem, u, lam0), evaluate_monitors(mons, u, lam0, None, None))
            if not _after(builder.branch, callback, checkpoint, stepper, mons):
                return builder.branch
    branch = builder.branch
    guess = np.append(np.asarray(u0, dtype=float), float(lam0))
    while stepper.going():
        if len(branch) >= options.point_cap:
            capped = options.max_points is not None
            branch.status = BranchStatus.MAX_POINTS if capped else BranchStatus.DEFAULT_MAX_POINTS
            branch.message = (f"stored {'max_points=' if capped else 'the default cap of '}{options.point_cap} "
                              f"points; last at {name}={stepper.lam:.10g}"
                              + ("" if capped else ": raise max_points (continuation.max_points in a scene)"))
            break
        try:
            found = stepper.attempt()
        except NUMERICAL_ERRORS:  # an evaluation that failed is a failed step
            stepper.failed()
            continue
        if not found:
            continue
        if stepper.last_kind == "lam":
            saved = [_state_of(m) for m in mons]
            values = evaluate_monitors(mons, found[0][1].x, found[0][0], None, None)
            if _flips(branch, values, stepper.leap):
                # a step in lam whose circle's stability differs from the last one's: onto the other half of a
                # fold of tori (both halves exist on one side of the fold); refused, the steps shorten, and at
                # ds_min the size steps take the fold (a bifurcation of the torus is passed by them too, and marked)
                _restore_monitors(mons, saved)
                stepper.undo()
                continue
            stored = [(*found[0], values)]
        else:  # a circle grown from its Neimark-Sacker point, or the circles of a pass of size steps
            stored = [(lam, r, evaluate_monitors(mons, r.x, lam, None, None)) for lam, r in found]
        for k, (lam, r, values) in enumerate(stored):
            if len(branch):
                secant = np.append(r.x - branch.unknowns[-1], lam - float(branch.parameter[-1]))
                s = float(branch.arclength[-1]) + float(np.linalg.norm(secant))
            else:  # the first circle grown from a Neimark-Sacker point: from the guess it grew from
                secant, s = np.append(r.x, lam) - guess, 0.0
            builder.append_point(r.x, lam, secant / float(np.linalg.norm(secant)), s, r.iterations,
                                 abs(float(secant[-1])), r.residual_norm, values)
            _stability_change(branch)
            if k < len(stored) - 1 and callback is not None and callback(branch, len(branch) - 1) is False:
                branch.status = BranchStatus.INTERRUPTED
                branch.message = f"stopped by the callback at {name}={lam:.10g}"
                return branch
        if stepper.turned is not None:
            _fold(branch, stepper.turned)
            stepper.turned = None
        # the checkpoint after the last of them: a pass is taken up whole or not at all
        if not _after(branch, callback, checkpoint, stepper, mons):
            return branch
    else:
        if not len(branch):
            return builder.finish(BranchStatus.START_FAILED, f"no circle grew from the Neimark-Sacker point at "
                                  f"{name}={lam0:.10g}: {stepper.message()}")
        _finish(branch, problem, stepper.message(), stepper.reached(), stepper)
    branch.info.update(lam_range=(lo, hi), n_newton_iterations=int(np.sum(branch.newton_iterations)),
                       n_rejected_steps=stepper.failures, continuation="natural")
    if checkpoint is not None:
        checkpoint(branch, {"monitors": [_state_of(m) for m in mons]})
    return branch


def _fold(branch: Branch, turned: dict) -> None:
    """The fold the steps turned at (:class:`~contin.bifurcation.circle_steps.CircleStepper`): a ``fold`` point
    at the circle found there, indexed at the stored circle nearest it."""
    i = len(branch) - 1 - int(turned["back"])
    name, lam = branch.parameter_name, float(turned["lam"])
    a, b = turned["interval"]
    how = ("located" if turned["located"] else f"not located to the tolerance: between {a:.10g} and {b:.10g}")
    branch.special_points.append(SpecialPoint(
        kind=SpecialKind.FOLD, parameter=lam, unknowns=np.array(turned["u"]), interval=(float(a), float(b)), index=i,
        s=float(branch.arclength[i]), located=bool(turned["located"]), data={},
        message=f"a fold of the torus at {name}={lam:.10g} ({how}): the steps at a fixed size of the circle "
                f"turned there, and the steps in {name} go on the other way", event="circle fold"))


#: a verdict decides a refusal (:func:`_flips`) where its normal exponent is this many times its error from zero
DECISIVE = 3.0
#: an undecided circle is refused where its exponent lies on the other side of zero than the last decisive verdict
#: and it landed more than this many of its predictor's steps from the predictor (:func:`_flips`)
LEAP = 2.0


def _flips(branch: Branch, values: dict, leap: float | None = None) -> bool:
    """Whether the monitors' ``values`` of a new circle give a stability verdict other than the last stored
    circle's that has one, both decisive (where the monitor gives the normal exponent and its error, the
    exponent :data:`DECISIVE` times its error from zero: near a fold of tori, and near a Neimark-Sacker
    point, it is near zero, and a verdict there may go either way).

    Near a fold both halves' exponents are near zero, so a step that lands on the other half gets no decisive
    verdict; it lands off the predictor's line, though (``leap``: its distance from the predictor over the
    predictor's from the last circle, :attr:`~contin.bifurcation.circle_steps.CircleStepper.leap`). An
    undecided circle whose exponent lies on the other side of zero than the last decisive verdict is refused
    where ``leap`` exceeds :data:`LEAP` (a corner of the branch leaps too, but keeps its side). The verdicts
    compared are those stored since the last fold the size steps turned (across it the stability changes)."""
    pd = branch.point_data
    if not len(branch) or "stable" not in pd or "stable" not in values or not values.get("evaluated"):
        return False

    def decisive(exponent, error) -> bool:
        return exponent is None or not np.isfinite(exponent) or abs(exponent) > DECISIVE * error

    # the circles since the last fold turned: across it the stability changes as it should
    turned = max((sp.index for sp in branch.special_points if sp.event == "circle fold"), default=-1)
    last = next((bool(pd["stable"][k]) for k in range(len(branch) - 1, turned, -1)
                 if pd["evaluated"][k] and decisive(pd["normal_exponent"][k] if "normal_exponent" in pd else None,
                                                    pd["normal_exponent_error"][k] if "normal_exponent" in pd
                                                    else 0.0)), None)
    exponent = values.get("normal_exponent")
    if last is None:
        return False
    if decisive(exponent, values.get("normal_exponent_error", 0.0)):
        return last != bool(values["stable"])
    return leap is not None and leap > LEAP and exponent != 0.0 and (exponent < 0.0) != last


def _stability_change(branch: Branch) -> None:
    """An unlocated ``stability`` point between the last two circles where their verdicts differ (both given):
    a bifurcation of the torus, or, near a fold of tori, a step that landed on the fold's other half, which
    natural steps cannot tell apart (docs/theory/quasi-periodic.md)."""
    pd, i = branch.point_data, len(branch) - 1
    if i < 1 or "stable" not in pd or not (pd["evaluated"][i] and pd["evaluated"][i - 1]):
        return
    before, now = bool(pd["stable"][i - 1]), bool(pd["stable"][i])
    if before == now:
        return
    a, b = float(branch.parameter[i - 1]), float(branch.parameter[i])
    branch.special_points.append(SpecialPoint(
        kind=SpecialKind.STABILITY, parameter=0.5 * (a + b), unknowns=np.array(branch.unknowns[i]), interval=(a, b),
        index=i - 1, s=float(branch.arclength[i]), located=False,
        data={"from": "stable" if before else "unstable", "to": "stable" if now else "unstable"},
        message=f"the torus is {'stable' if before else 'unstable'} at {branch.parameter_name}={a:.10g} and "
                f"{'stable' if now else 'unstable'} at {b:.10g}: a bifurcation of the torus between, or a step "
                "across a fold of tori onto its other half", event="circle stability"))


def _finish(branch: Branch, problem, message: str, reached: bool, stepper: CircleStepper | None = None) -> Branch:
    """The end: the range's, a collapse (an ``ns`` point), a locking or a failure (module docstring)."""
    if reached:
        branch.status, branch.message = BranchStatus.RANGE_END, message
        return branch
    branch.status, branch.message = BranchStatus.STEP_TOO_SMALL, message
    if stepper is not None and stepper.collapsed is not None:
        i = len(branch) - 1
        end_as_boundary(branch, SpecialKind.NS, float(stepper.collapsed[0]), branch.unknowns[i], i,
                        {"circle_spread": float(stepper.collapsed[1])}, "the torus collapses onto its periodic orbit",
                        "circle end")
        return branch
    classify_circle_end(branch, problem)
    return branch


def _after(branch: Branch, callback, checkpoint, stepper: CircleStepper, mons) -> bool:
    """The callback and the checkpoint after a stored circle; False where the callback stops the branch."""
    index = len(branch) - 1
    if callback is not None and callback(branch, index) is False:
        branch.status = BranchStatus.INTERRUPTED
        branch.message = f"stopped by the callback at {branch.parameter_name}={float(branch.parameter[index]):.10g}"
        return False
    if checkpoint is not None:
        checkpoint(branch, {"points": len(branch), "natural": stepper.state(),
                            "monitors": [_state_of(m) for m in mons]})
    return True


def _start_tangent(m: int, direction: int) -> np.ndarray:
    """The first circle's tangent: the parameter's direction."""
    t = np.zeros(m + 1)
    t[-1] = float(direction)
    return t


def _finite(res: float, problem, u, lam: float) -> float:
    """The residual's norm at a start that was not corrected (its own evaluation)."""
    return res if np.isfinite(res) else float(np.max(np.abs(problem.residual(u, lam))))


def _state_of(mon):
    return mon.state() if hasattr(mon, "state") else None


def _restore_monitors(mons, states) -> None:
    for mon, st in zip(mons, states or ()):
        if st is not None and hasattr(mon, "restore"):
            mon.restore(st)
