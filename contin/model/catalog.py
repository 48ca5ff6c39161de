"""The catalogue of built-in models, filled by :func:`register_model`.

Each entry is a :class:`ModelSpec`: its parameters with defaults, its named
effects, a function that builds a :class:`contin.model.base.Model` holding
exactly the enabled effects, and the values of its parameters that make
physical sense (``constraints``, by the rules of :data:`RULES`): a model is
never built with a value its table forbids (a negative mass, damping or
contact stiffness, ...), and a scene holding one is refused with the key
named before anything runs (:mod:`contin.scene.parse`).
"""

from __future__ import annotations

import importlib

import math
from dataclasses import dataclass, field
from typing import Callable, Mapping

from contin.model.base import Model

from contin.util.naming import suggest

__all__ = ["ModelSpec", "RULES", "register_model", "MODELS", "build_model", "get_spec", "rule_violation",
           "load_builtin_models"]

#: rules a parameter value may be held to: name -> (test of a finite float, what it asks for)
RULES: dict[str, tuple[Callable[[float], bool], str]] = {
    "positive": (lambda v: v > 0, "a number > 0"),
    "nonnegative": (lambda v: v >= 0, "a number >= 0"),
    "position": (lambda v: 0 < v < 1, "a position strictly between 0 and 1"),
    "terms": (lambda v: v == int(v) and 1 <= v <= 200, "an integer from 1 to 200"),
}


def rule_violation(rule: tuple[str, str], value) -> str | None:
    """What ``value`` should have been under ``rule = (RULES name, meaning)``, or None if it obeys it.

    Values that are not finite numbers are left to the checks of their type.
    """
    name, meaning = rule
    try:
        v = float(value)
    except (TypeError, ValueError, OverflowError):
        return None
    if isinstance(value, bool) or not math.isfinite(v):
        return None
    test, expected = RULES[name]
    return None if test(v) else f"{expected} ({meaning})"


@dataclass(frozen=True)
class ModelSpec:
    """Description of a built-in model.

    Parameters
    ----------
    name : str
    summary : str
        One line for ``contin models``.
    parameters : dict
        Parameter names to default values (the order is the parameter vector).
    effects : dict
        Effect names to a one-line description.
    default_effects : tuple of str
        Effects enabled when a scene does not list any.
    builder : callable
        ``builder(parameters: dict, effects: tuple, **options) -> Model``.
    options : dict
        Model options (not parameters) with defaults, e.g. ``{"clip": True}``.
    constraints : dict
        Parameter name -> ``(rule, meaning)``: the values that make physical
        sense, ``rule`` a key of :data:`RULES` (``positive`` for masses and
        inertias, ``nonnegative`` for stiffnesses, dampings, clearances and
        frequencies whose negative values mean nothing), ``meaning`` what the
        parameter is (for the message). A scene's values and the ranges it
        continues such a parameter over are held to them.
    frequency : str
        The excitation-frequency parameter.
    """

    name: str
    summary: str
    parameters: dict
    effects: dict
    default_effects: tuple
    builder: Callable[..., Model]
    options: dict = field(default_factory=dict)
    constraints: dict = field(default_factory=dict)
    frequency: str = "w"

    def parameter_constraints(self, options: Mapping | None = None) -> dict:
        """Parameter name -> ``(rule, meaning)`` for the model built with ``options`` (see ``constraints``)."""
        return dict(self.constraints)

    def check_parameters(self, parameters: Mapping, options: Mapping | None = None) -> None:
        """Refuse a parameter value that breaks its constraint.

        Raises
        ------
        ValueError
            ``model.parameters.NAME: expected ..., found ...``.
        """
        rules = self.parameter_constraints(options)
        for k, v in parameters.items():
            bad = rule_violation(rules[k], v) if k in rules else None
            if bad:
                raise ValueError(f"model.parameters.{k}: expected {bad}, found {v!r}")

    def build(self, parameters: Mapping | None = None, effects=None, **options) -> Model:
        """Build the model with parameter overrides and the enabled effects."""
        params = dict(self.parameters)
        for k, v in (parameters or {}).items():
            if k not in params:
                raise ValueError(
                    f"model.parameters.{k}: unknown parameter of '{self.name}'{suggest(k, params)}; "
                    f"expected one of {list(params)}"
                )
            params[k] = v
        eff = tuple(self.default_effects if effects is None else effects)
        for e in eff:
            if e not in self.effects:
                raise ValueError(
                    f"model.effects: unknown effect '{e}' of '{self.name}'{suggest(e, self.effects)}; "
                    f"expected some of {list(self.effects)}"
                )
        opts = dict(self.options)
        for k, v in options.items():
            if k not in opts:
                raise ValueError(
                    f"model.options.{k}: unknown option of '{self.name}'{suggest(k, opts)}; expected one of {list(opts)}"
                )
            opts[k] = v
        self.check_parameters(params, opts)
        return self.builder(params, eff, **opts)


MODELS: dict[str, ModelSpec] = {}


def register_model(spec: ModelSpec) -> ModelSpec:
    """Add a built-in model to the catalogue."""
    MODELS[spec.name] = spec
    return spec


#: the package of built-in models, imported by name: its modules register themselves (plug-ins)
BUILTIN_MODELS = "contin.models"


def load_builtin_models() -> None:
    """Import the built-in models' package, whose modules register themselves in :data:`MODELS`."""
    importlib.import_module(BUILTIN_MODELS)


#: the former private name (contin.app imports it)
_load = load_builtin_models


def get_spec(name: str) -> ModelSpec:
    """The :class:`ModelSpec` of a built-in model, with a suggestion on typos."""
    load_builtin_models()
    if name not in MODELS:
        raise ValueError(f"model.builtin: unknown model '{name}'{suggest(name, MODELS)}; expected one of {sorted(MODELS)}")
    return MODELS[name]


def build_model(name: str, parameters=None, effects=None, **options) -> Model:
    """Build a built-in model by name."""
    return get_spec(name).build(parameters, effects, **options)
