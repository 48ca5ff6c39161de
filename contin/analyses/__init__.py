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

__all__ = ["ANALYSIS_RUNNERS", "ANALYSIS_SCHEMAS", "ANALYSIS_MODULES", "register_analysis", "get_runner",
           "load_all"]

ANALYSIS_RUNNERS: dict[str, Callable] = {}
ANALYSIS_SCHEMAS: dict[str, dict] = {}

#: modules that register analyses on import
ANALYSIS_MODULES = (
    "contin.analyses.frequency_response",
    "contin.analyses.simulate",
    "contin.analyses.modes",
    "contin.analyses.frf",
    "contin.analyses.bifurcation_curve",
    "contin.analyses.static",
    "contin.analyses.backbone",
)


def register_analysis(name: str, schema: dict | None = None):
    """Decorator registering ``run`` for ``analysis.type: name`` (and its section schema)."""

    def deco(fn):
        ANALYSIS_RUNNERS[name] = fn
        if schema is not None:
            ANALYSIS_SCHEMAS[name] = schema
        return fn

    return deco


def load_all() -> None:
    for mod in ANALYSIS_MODULES:
        importlib.import_module(mod)


def get_runner(name: str) -> Callable:
    load_all()
    return ANALYSIS_RUNNERS[name]
