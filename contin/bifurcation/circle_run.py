"""A circle branch traced as a scene asks: by pseudo-arclength (:func:`~contin.bifurcation.circle_branch.follow_circle`)
or in natural steps of the parameter (:func:`~contin.bifurcation.circle_natural.follow_circle_steps`), with its
stability and its ends told."""

from __future__ import annotations

from contin.bifurcation.circle_branch import CircleStabilityMonitor, CircleStart, follow_circle
from contin.bifurcation.circle_natural import follow_circle_steps
from contin.engine.branch import Branch
from contin.engine.options import ContinuationOptions

__all__ = ["run_circle"]


def run_circle(start: CircleStart, lam_range, options: ContinuationOptions, parameter_name: str, *,
               stability: bool = True, callback=None, checkpoint=None, resume=None, natural: bool = False,
               previous: Branch | None = None) -> Branch:
    """Trace the circle branch from ``start`` with its stability (:class:`CircleStabilityMonitor`) and its ends
    told (:func:`follow_circle`; with ``natural``, in natural steps of the parameter:
    :func:`contin.bifurcation.circle_natural.follow_circle_steps`, which takes up ``previous``, the same
    branch of an interrupted run, where ``resume`` takes up an arclength one).

    Returns
    -------
    Branch
        Its ``info["torus"]`` says the discretisation: ``{"circle": True, "points", "steps_per_period",
        "winding", "continuation"}``.
    """
    problem = start.problem
    monitors = [CircleStabilityMonitor(problem)] if stability else []
    opts = options.replace(unknown_scale=None, parameter_scale=None)
    if natural:
        # a torus born at a Neimark-Sacker point grows from its first guess there, to the side it lies on
        br = follow_circle_steps(problem, start.u, start.lam, lam_range, opts, monitors=monitors, callback=callback,
                                 checkpoint=checkpoint, previous=previous, solve_start=start.solve_start,
                                 parameter_name=parameter_name, grow=start.kind == "ns" and not start.solve_start)
    else:
        br = follow_circle(problem, start.u, start.lam, lam_range, opts, tangent=start.tangent,
                           parameter_name=parameter_name, monitors=monitors, callback=callback, checkpoint=checkpoint,
                           resume=resume, solve_start=start.solve_start)
    for mon in monitors:
        if mon.simulated:
            br.message = (f"{br.message}; stability by a simulation off the circle at {len(mon.simulated)} point(s) "
                          "(the Lyapunov exponents within their error of zero)")
        if mon.undecided:
            br.message = (f"{br.message}; no stability verdict at {len(mon.undecided)} point(s) (the largest normal "
                          f"Lyapunov exponent within its error of zero; first at {parameter_name}="
                          f"{mon.undecided[0]:.10g})")
    br.info["torus"] = {"circle": True, "points": problem.points, "steps_per_period": problem.options.steps_per_period,
                        "winding": int(problem.winding), "continuation": "natural" if natural else "arclength"}
    return br
