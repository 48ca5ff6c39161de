"""The catalogue of built-in models, filled by :func:`register_model`.

Each entry is a :class:`ModelSpec`: its parameters with defaults, its named
effects, and a function that builds a :class:`contin.model.Model` holding
exactly the enabled effects.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Mapping

from contin.model import Model, suggest

__all__ = ["ModelSpec", "register_model", "MODELS", "build_model", "get_spec"]


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
    """

    name: str
    summary: str
    parameters: dict
    effects: dict
    default_effects: tuple
    builder: Callable[..., Model]
    options: dict = field(default_factory=dict)

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
        return self.builder(params, eff, **opts)


MODELS: dict[str, ModelSpec] = {}


def register_model(spec: ModelSpec) -> ModelSpec:
    """Add a built-in model to the catalogue."""
    MODELS[spec.name] = spec
    return spec


def _load():
    import contin.models  # noqa: F401  (registers the built-in models)


def get_spec(name: str) -> ModelSpec:
    """The :class:`ModelSpec` of a built-in model, with a suggestion on typos."""
    _load()
    if name not in MODELS:
        raise ValueError(f"model.builtin: unknown model '{name}'{suggest(name, MODELS)}; expected one of {sorted(MODELS)}")
    return MODELS[name]


def build_model(name: str, parameters=None, effects=None, **options) -> Model:
    """Build a built-in model by name."""
    return get_spec(name).build(parameters, effects, **options)
