"""Analyses a scene can run, by ``analysis.type``.

Each analysis module registers a function ``run(context) -> dict`` (the
analysis part of ``summary.json``; see :mod:`contin.runner`) and, except for
``frequency_response`` whose schema lives in :mod:`contin.scene`, the schema
of its ``analysis`` section (built from :mod:`contin.schema`). A new analysis
is a new module listed in :data:`ANALYSIS_MODULES`; nothing else changes.
"""

from __future__ import annotations

import importlib
from typing import Callable

__all__ = ["ANALYSIS_RUNNERS", "ANALYSIS_SCHEMAS", "ANALYSIS_MODULES", "ANALYSIS_VALIDATORS", "register_analysis", "get_runner",
           "load_all"]

ANALYSIS_RUNNERS: dict[str, Callable] = {}
ANALYSIS_SCHEMAS: dict[str, dict] = {}
#: ``analysis.type`` -> ``validate(data, model, analysis, lines)``, further checks of a scene
#: beyond its section schema (run by :func:`contin.scene.parse_scene`; raises ``SceneError``)
ANALYSIS_VALIDATORS: dict[str, Callable] = {}

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


def register_analysis(name: str, schema: dict | None = None, validate: Callable | None = None):
    """Decorator registering ``run`` for ``analysis.type: name`` (its section schema and checks).

    Parameters
    ----------
    name : str
        The ``analysis.type``.
    schema : dict, optional
        Keys of the ``analysis`` section (:mod:`contin.schema`).
    validate : callable, optional
        ``validate(data, model, analysis, lines)``: further checks of the whole
        scene after the section schema (``data`` the scene as loaded, ``model``
        and ``analysis`` its checked sections), raising ``SceneError``.
    """

    def deco(fn):
        ANALYSIS_RUNNERS[name] = fn
        if schema is not None:
            ANALYSIS_SCHEMAS[name] = schema
        if validate is not None:
            ANALYSIS_VALIDATORS[name] = validate
        return fn

    return deco


def load_all() -> None:
    for mod in ANALYSIS_MODULES:
        importlib.import_module(mod)


def get_runner(name: str) -> Callable:
    load_all()
    return ANALYSIS_RUNNERS[name]
