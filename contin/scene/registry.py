"""The analyses a scene can run, by ``analysis.type``: the one table :data:`ANALYSES`.

Each entry names the class of an analysis (a subclass of
:class:`contin.analyses.base.Analysis`, whose docstring lists the steps to add
one). The scene schemas (:func:`contin.scene.parse.analysis_schemas`),
``contin check``, ``contin run``, the Python API's calls and the generated
scene reference all read this table; an analysis's module is imported by name
when first asked for, as the built-in models are (:mod:`contin.model.catalog`).
"""

from __future__ import annotations

import importlib

__all__ = ["ANALYSES", "analysis", "analysis_names", "check_output", "check_scene", "shortfalls"]

#: ``analysis.type`` -> ``module:Class`` of its :class:`~contin.analyses.base.Analysis` (or the class itself,
#: for one defined outside the package), in the order the reference and the API list them
ANALYSES = {
    "frequency_response": "contin.analyses.frequency_response:FrequencyResponse",
    "simulate": "contin.analyses.simulate:Simulate",
    "modes": "contin.analyses.modes:Modes",
    "frf": "contin.analyses.frf:Frf",
    "bifurcation_curve": "contin.analyses.bifurcation_curve:BifurcationCurve",
    "static": "contin.analyses.static:Static",
    "backbone": "contin.analyses.backbone:Backbone",
    "convergence": "contin.analyses.convergence:Convergence",
}

#: ``analysis.type`` -> (its table entry, the instance made of it)
_MADE: dict = {}


def analysis(name: str):
    """The analysis ``analysis.type: name`` runs (one instance, made on first use; KeyError if none)."""
    entry = ANALYSES[name]
    made_from, made = _MADE.get(name, (None, None))
    if made_from is not entry:  # first use, or its table line changed
        if isinstance(entry, str):
            module, _, cls = entry.partition(":")
            entry_class = getattr(importlib.import_module(module), cls)
        else:
            entry_class = entry
        made = entry_class()
        if made.name != name:
            raise RuntimeError(f"{entry} is named {made.name!r}, listed as {name!r}")
        _MADE[name] = (entry, made)
    return made


def analysis_names() -> list[str]:
    """Every ``analysis.type``, in the table's order."""
    return list(ANALYSES)


def check_scene(scene, model):
    """Every check of ``scene`` with its built ``model`` that a run would make (raises ``SceneError``).

    Returns the analysis's plan (:meth:`contin.analyses.base.Analysis.plan`),
    which its run is handed.

    First the memory and work the scene asks (:func:`contin.scene.budget.check_resources`:
    before the plan, which builds its problems and their arrays);
    after it, the texts its figures draw (when it draws any) and ``continuation.unknown_scale``
    against the problems' unknowns (:mod:`contin.scene.preflight`).
    """
    from contin.scene.budget import check_resources  # deferred: hb, stability (0.8 s); ``import contin`` reads ANALYSES
    from contin.scene.preflight import check_texts, check_unknown_scale  # deferred: numpy, as budget

    made = analysis(scene.analysis["type"])
    check_resources(scene, made.demands(scene, model))
    plan = made.plan(scene, model)
    if scene.output.get("plots", True):  # the texts are a figure's: without figures matplotlib is never loaded
        check_texts(scene, model)
    check_unknown_scale(scene, made.scale_checks(plan))
    return plan


def check_output(scene, measures, names=(), panels: bool = False) -> None:
    """``output.measure`` one of ``measures``; ``output.labels`` and ``output.units`` keys among them or ``names``.

    Parameters
    ----------
    scene : Scene
    measures : sequence of str
        Columns the analysis can plot (``output.measure``).
    names : sequence of str
        Further names an axis can show (parameters).
    panels : bool
        Whether the analysis draws ``output.panels`` and ``output.zoom``
        (each panel one of ``measures``; ``output.measure``, if given, one
        of the panels; ``output.zoom.measure_range`` keys among the measures
        drawn, the first of ``measures`` when neither is given). Else those keys are refused: nothing would
        draw them.
    """
    from contin.util.naming import suggest  # deferred: numpy (0.1 s), not for ``import contin``

    out = scene.output
    measures = list(measures)
    if out.get("measure") is not None and out["measure"] not in measures:
        raise scene.error("output.measure", "one of the measures " + ", ".join(measures), out["measure"],
                          hint=suggest(str(out["measure"]), measures))
    _check_panels(scene, measures, panels)
    known = measures + [n for n in names if n not in measures]
    for key in ("labels", "units"):
        for name in out.get(key) or {}:
            if name not in known:
                raise scene.error(f"output.{key}.{name}", "a column of the results: " + ", ".join(known), name,
                                  hint=suggest(str(name), known))


def _check_panels(scene, measures: list, panels: bool) -> None:
    """``output.panels`` and ``output.zoom`` against the analysis's measures (:func:`check_output`)."""
    from contin.util.naming import suggest  # deferred: numpy (0.1 s), not for ``import contin``

    out = scene.output
    if not panels:
        for key in ("panels", "zoom"):
            if out.get(key) is not None:
                raise scene.error(f"output.{key}", f"no {key}: the figure of analysis type "
                                  f"{scene.analysis.get('type')!r} draws one measure (output.panels and output.zoom "
                                  "are drawn by frequency_response)", out[key])
        return
    stacked = list(out.get("panels") or ())
    for i, name in enumerate(stacked):
        if name not in measures:
            raise scene.error(f"output.panels[{i}]", "one of the measures " + ", ".join(measures), name,
                              hint=suggest(str(name), measures))
    if stacked and out.get("measure") is not None and out["measure"] not in stacked:
        raise scene.error("output.measure", "one of output.panels (" + ", ".join(stacked) + "): the figure draws "
                          "the panels", out["measure"])
    # without either, the figure draws the analysis's first measure
    drawn = stacked or ([out["measure"]] if out.get("measure") is not None else measures[:1])
    for name in (out.get("zoom") or {}).get("measure_range") or {}:
        if name not in drawn:
            raise scene.error(f"output.zoom.measure_range.{name}", "a measure the figure draws: " + ", ".join(drawn),
                              name, hint=suggest(str(name), drawn))


def _stopped_short(b: dict) -> bool:
    """A ``boundary`` end (a point the branch cannot pass) that leaves part of the range uncovered, neither handed
    over to another method (``end: handover``), nor a torus going on as the branches of its locked orbits
    (``end: locking``) or shrinking onto the periodic orbit it is born from (``end: collapse``), nor reported by
    the end checks already (another ``end``)."""
    gap = b.get("uncovered")
    return b.get("end") is None and gap is not None and gap[1] > gap[0]


def shortfalls(branches: list[dict], parameter: str, failed_switches=(), what: str = "branch") -> list[str]:
    """What a run did not do that its scene asked: branches whose numerics gave up, switches without a branch.

    A branch ends as asked at a range end (also after turning back), a
    closed loop, or the ``max_points`` the
    scene set (:attr:`contin.engine.branch.BranchStatus.as_asked`; the default
    cap, ``default_max_points``, is a shortfall); an interrupted one is the
    run's interruption, not a shortfall. A branch stopped at a located point
    it cannot pass (``boundary``, a grazing point of harmonic balance) falls
    short when it leaves part of its range uncovered (its ``uncovered``),
    unless it was handed over to shooting (``end: handover``) or is a torus
    that locked and goes on as its periodic orbits' branches (``end: locking``)
    or collapsed onto its periodic orbit at a Neimark-Sacker point (``end: collapse``). A shooting branch
    that crawled and goes on with its orbits cut at another section (``end: recut``) is no shortfall: the
    continuation's end decides.

    Parameters
    ----------
    branches : list of dict
        ``status``, ``message`` and optionally ``branch``, ``nu``, ``points``
        and ``uncovered`` (``[lo, hi]``) of each branch.
    parameter : str
        The continuation parameter (in the messages).
    failed_switches : sequence of dict
        ``parent``, ``kind``, ``parameter``, ``side``, ``message`` of each
        switch that found no first point, or that was not tried because its
        point was not located (``side`` None).
    what : str
        What the entries are called in the messages.
    """
    from contin.engine.branch import BranchStatus  # deferred: numpy (0.1 s), not for ``import contin``

    out = []
    for i, b in enumerate(branches):
        status = BranchStatus(b["status"])
        if status is BranchStatus.BOUNDARY and _stopped_short(b):
            gap = b["uncovered"]
            name = f"{what} {b.get('branch', i)}" + (f" (nu={b['nu']})" if "nu" in b else "")
            tip = (f"; shooting could not take it over: {b['handover_failed']}" if b.get("handover_failed") else
                   "" if b.get("method") == "shooting" else "; to go on: analysis.method: auto or shooting")
            out.append(f"{name} stopped at a point it cannot pass ({b.get('message', '')}); {parameter} in "
                       f"[{gap[0]:.10g}, {gap[1]:.10g}] not covered{tip}")
            continue
        if status is BranchStatus.INTERRUPTED or status.as_asked or b.get("end") == "recut":
            continue  # a crawl continued at another section of the orbits: the continuation's end decides
        gap = b.get("uncovered")
        where = f"; {parameter} in [{gap[0]:.10g}, {gap[1]:.10g}] not covered" if gap else ""
        name = f"{what} {b.get('branch', i)}" + (f" (nu={b['nu']})" if "nu" in b else "")
        after = f" after {b['points']} points" if "points" in b else ""
        out.append(f"{name} ended {status.value}{after}: {b.get('message', '')}{where}")
    for f in failed_switches:
        side = "" if f.get("side") is None else f" (side {f['side']:+d})"  # None: no side was tried
        out.append(f"no branch switched from branch {f['parent']} at its {f['kind']} point {parameter}="
                   f"{f['parameter']:.10g}{side}: {f['message']}")
    return out
