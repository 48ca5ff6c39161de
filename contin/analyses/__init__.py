"""Analyses a scene can run, by ``analysis.type``.

Each entry maps a type name to a function ``run(context) -> dict`` (the
analysis part of ``summary.json``); see :mod:`contin.runner`.
"""

from __future__ import annotations

from typing import Callable

__all__ = ["ANALYSIS_RUNNERS", "register_analysis", "get_runner"]

ANALYSIS_RUNNERS: dict[str, Callable] = {}


def register_analysis(name: str):
    def deco(fn):
        ANALYSIS_RUNNERS[name] = fn
        return fn

    return deco


def get_runner(name: str) -> Callable:
    from contin.analyses import frequency_response, simulate  # noqa: F401  (registers)

    return ANALYSIS_RUNNERS[name]
