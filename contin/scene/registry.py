"""The analyses a scene can run, by ``analysis.type``, and what a run hands them.

Each analysis module (:data:`ANALYSIS_MODULES`) registers with
:func:`register_analysis` a function ``run(context) -> dict`` (the analysis
part of ``summary.json``; see :mod:`contin.app.runner`), the schema of its
``analysis`` section (built from :mod:`contin.scene.schema`) and its checks.
A new analysis is a new module listed in :data:`ANALYSIS_MODULES`; nothing
else changes. The modules are imported by name when a scene is checked, as
the built-in models are (:mod:`contin.model.catalog`).
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Callable

from contin.model.base import Model

if TYPE_CHECKING:
    from contin.scene.parse import Scene

__all__ = ["RunContext", "RunError", "ANALYSIS_CHECKS", "ANALYSIS_RUNNERS", "ANALYSIS_SCHEMAS", "ANALYSIS_MODULES", "ANALYSIS_VALIDATORS",
           "check_output", "check_scene", "register_analysis", "get_runner", "load_all", "shortfalls"]


class RunError(RuntimeError):
    """A run that could not proceed for numerical reasons (for example no starting solution)."""


@dataclass
class RunContext:
    """What an analysis needs while it runs."""

    scene: Scene
    model: Model
    outdir: Path
    #: a :class:`contin.app.progress.Progress`
    progress: object
    timings: dict = field(default_factory=dict)
    stop_requested: bool = False
    interrupted: bool = False
    plot: object = None
    recorder: object = None
    resume: bool = False
    #: what the analysis's check returned (see :func:`check_scene`)
    plan: object = None
    #: ``run_scene(scene, outdir, progress=False)``, for analyses made of whole runs (a convergence study)
    run_scene: Callable | None = None


ANALYSIS_RUNNERS: dict[str, Callable] = {}
ANALYSIS_SCHEMAS: dict[str, dict] = {}
#: ``analysis.type`` -> ``validate(data, model, analysis, lines)``, further checks of a scene
#: beyond its section schema (run by :func:`contin.scene.parse.parse_scene`; raises ``SceneError``)
ANALYSIS_VALIDATORS: dict[str, Callable] = {}
#: ``analysis.type`` -> ``check(scene, model)``: every check that needs the built model (parameter
#: names, problem sizes, options objects, output columns), run by ``contin check`` and by
#: :func:`contin.app.runner.run_scene` before anything is written; raises ``SceneError``
ANALYSIS_CHECKS: dict[str, Callable] = {}

#: modules that register analyses on import
ANALYSIS_MODULES = (
    "contin.analyses.frequency_response",
    "contin.analyses.simulate",
    "contin.analyses.modes",
    "contin.analyses.frf",
    "contin.analyses.bifurcation_curve",
    "contin.analyses.static",
    "contin.analyses.backbone",
    "contin.analyses.convergence",
)


def register_analysis(name: str, schema: dict | None = None, validate: Callable | None = None,
                      check: Callable | None = None):
    """Decorator registering ``run`` for ``analysis.type: name`` (its section schema and checks).

    Parameters
    ----------
    name : str
        The ``analysis.type``.
    schema : dict, optional
        Keys of the ``analysis`` section (:mod:`contin.scene.schema`).
    validate : callable, optional
        ``validate(data, model, analysis, lines)``: further checks of the whole
        scene after the section schema (``data`` the scene as loaded, ``model``
        and ``analysis`` its checked sections), raising ``SceneError``.
    check : callable, optional
        ``check(scene, model)``: the checks that need the built model (see
        :data:`ANALYSIS_CHECKS`). A scene that passes them is refused by
        nothing later: a run writes its files only after them.
    """

    def deco(fn):
        ANALYSIS_RUNNERS[name] = fn
        if schema is not None:
            ANALYSIS_SCHEMAS[name] = schema
        if validate is not None:
            ANALYSIS_VALIDATORS[name] = validate
        if check is not None:
            ANALYSIS_CHECKS[name] = check
        return fn

    return deco


def load_all() -> None:
    for mod in ANALYSIS_MODULES:
        importlib.import_module(mod)


def get_runner(name: str) -> Callable:
    load_all()
    return ANALYSIS_RUNNERS[name]


def check_scene(scene, model):
    """Every check of ``scene`` with its built ``model`` that a run would make (raises ``SceneError``).

    Returns what the analysis's check returns (its prepared setup, handed to
    its run as ``RunContext.plan``), or None.

    First the memory and work the scene asks (:func:`contin.scene.budget.check_resources`:
    before the analysis's check, which builds its problems and their arrays);
    after it, the texts its figures draw and ``continuation.unknown_scale``
    against the problems' unknowns (:mod:`contin.scene.preflight`).
    """
    from contin.scene.budget import check_resources
    from contin.scene.preflight import check_texts, check_unknown_scale

    load_all()
    check_resources(scene, model)
    check = ANALYSIS_CHECKS.get(scene.analysis["type"])
    plan = None if check is None else check(scene, model)
    check_texts(scene, model)
    check_unknown_scale(scene, plan)
    return plan


def check_output(scene, measures, names=()) -> None:
    """``output.measure`` one of ``measures``; ``output.labels`` and ``output.units`` keys among them or ``names``.

    Parameters
    ----------
    scene : Scene
    measures : sequence of str
        Columns the analysis can plot (``output.measure``).
    names : sequence of str
        Further names an axis can show (parameters).
    """
    from contin.util.naming import suggest

    out = scene.output
    measures = list(measures)
    if out.get("measure") is not None and out["measure"] not in measures:
        raise scene.error("output.measure", "one of the measures " + ", ".join(measures), out["measure"],
                          hint=suggest(str(out["measure"]), measures))
    known = measures + [n for n in names if n not in measures]
    for key in ("labels", "units"):
        for name in out.get(key) or {}:
            if name not in known:
                raise scene.error(f"output.{key}.{name}", "a column of the results: " + ", ".join(known), name,
                                  hint=suggest(str(name), known))


def shortfalls(branches: list[dict], parameter: str, failed_switches=(), what: str = "branch") -> list[str]:
    """What a run did not do that its scene asked: branches whose numerics gave up, switches without a branch.

    A branch ends as asked at a range end (also after turning back), a
    closed loop, a located point it cannot pass, or the ``max_points`` the
    scene set (:attr:`contin.engine.branch.BranchStatus.as_asked`; the default
    cap, ``default_max_points``, is a shortfall); an interrupted one is the
    run's interruption, not a shortfall.

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
    from contin.engine.branch import BranchStatus

    out = []
    for i, b in enumerate(branches):
        status = BranchStatus(b["status"])
        if status is BranchStatus.INTERRUPTED or status.as_asked:
            continue
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
