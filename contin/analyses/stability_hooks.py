"""How a frequency response gets its stability, its events and its branch switching."""

from __future__ import annotations

from contin.scene.sweep_plan import runs_from_start
from contin.scene.parse import SceneError
from contin.stability import StabilityOptions
from contin.bifurcation.diagram import follow as follow_diagram
from contin.bifurcation.torus_branch import TorusSettings
from contin.analyses.shooting_rows import is_shooting, order_of
from contin.model.periodic import is_circle

__all__ = ["stability_setup"]


def stability_options(analysis: dict) -> StabilityOptions:
    """``analysis.stability`` and ``analysis.stability_options`` as :class:`StabilityOptions`."""
    d = dict(analysis.get("stability_options") or {})
    if "method" in d:
        raise SceneError("analysis.stability_options.method", "no method here (use analysis.stability)", d["method"])
    d["method"] = analysis["stability"]
    try:
        return StabilityOptions.from_dict(d)
    except ValueError as exc:
        raise SceneError("analysis.stability_options", "valid stability options", None, hint=f": {exc}") from None


def stability_setup(analysis: dict, hb):
    """The branch-following function of a frequency-response analysis.

    Returns
    -------
    follow : callable
        ``follow(hb, u0, lam0, lam_range, options, recorder, ctx, previous, first_id, both_ways=None)
        -> [(Branch, meta)]``:
        traces the first branch with stability (unless ``stability: none``),
        in both directions from the start if ``analysis.both_ways``,
        switches at the kinds listed in ``analysis.switch`` (one generation,
        at most ``analysis.max_branches`` branches), and records every point
        as it is found; branch ids start at ``first_id``. ``hb`` may be a
        shooting problem (the flow's multipliers; a period doubling starts a
        shooting branch of twice the period); ``both_ways`` overrides
        ``analysis.both_ways`` (a branch handed over at a grazing point runs on
        in its own direction only).
    """
    stab = stability_options(analysis)
    switch = tuple(analysis["switch"])
    for kind, what in (("pd", "period doubling"), ("ns", "Neimark-Sacker points")):
        if kind in switch and analysis["stability"] == "none":
            raise SceneError("analysis.switch", f"a stability method (analysis.stability) to detect {what}",
                             "stability: none")
    try:
        torus = TorusSettings.from_dict(analysis.get("torus") or {}, hb.H)
    except ValueError as exc:
        raise SceneError("analysis.torus", "valid torus settings", analysis.get("torus"), hint=f": {exc}") from None

    def follow(hb, u0, lam0, lam_range, options, rec, ctx, previous=None, first_id=0, both_ways=None):
        def factory(index, problem):
            nu = order_of(problem)

            def callback(branch, i):
                rec.point(index, nu, branch, i, getattr(problem, "H", None), problem=problem)
                ctx.progress.update(f"branch {index} (nu={nu})  {problem.parameter}={branch.parameter[i]:.6g}"
                                    f"  point {i}  ds={branch.step_sizes[i]:.3g}",
                                    parameter=branch.parameter, bounds=lam_range, task=f"branch {index}")
                return not ctx.stop_requested

            return callback

        def checkpoints(index, problem):
            return lambda branch, state: rec.checkpoint(index, branch, state)

        previous = previous or {}
        both = analysis["both_ways"] if both_ways is None else both_ways
        runs = runs_from_start(options, both, lam0, lam_range)
        pairs, offset = [], first_id
        for opts in runs:
            def shifted(index, problem, offset=offset):
                return factory(index + offset, problem)

            def shifted_checkpoints(index, problem, offset=offset):
                return checkpoints(index + offset, problem)

            prev = {j - offset: b for j, b in previous.items() if j >= offset}
            diagram = follow_diagram(hb, u0, lam0, lam_range, opts, stability=stab, switch=switch,
                                     max_depth=1 if switch else 0, parameter_name=hb.parameter,
                                     max_branches=analysis["max_branches"], callback_factory=shifted,
                                     checkpoint_factory=shifted_checkpoints, previous=prev, torus=torus)
            pairs += list(zip(diagram.branches, diagram.problems))
            rec.failed_switches.extend({**f, "parent": f["parent"] + offset} for f in diagram.failed_switches)
            offset += len(diagram.branches)
            if any(b.status.value == "interrupted" for b in diagram.branches):
                break
        out = []
        for j, (br, prob) in enumerate(pairs, start=first_id):
            rec.special_points(j, br, prob)
            org = br.info.get("origin")
            out.append((br, {"nu": order_of(prob), "harmonics": getattr(prob, "H", None),
                             "method": "shooting" if is_shooting(prob) or is_circle(prob) else "hb",
                             "parent": br.info.get("parent"),
                             "torus": br.info.get("torus"),
                             **({"end": br.info["end"]} if "end" in br.info else {}),
                             "origin": None if org is None else {k: org[k] for k in ("kind", "parameter", "located",
                                                                                     "note") if k in org}}))
        return out

    return follow
