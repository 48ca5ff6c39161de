"""The model a scene describes: a built-in model from the catalogue, or a custom one."""

from __future__ import annotations

from contin.model.base import Model
from contin.model.catalog import get_spec
from contin.scene.custom_model import build_custom_model
from contin.scene.fe_model import build_fe_model
from contin.scene.parse import Scene, SceneError
from contin.scene.schema import is_number

__all__ = ["build_model"]


def build_model(scene: Scene) -> Model:
    """The model a scene describes, with exactly the effects it enables."""
    m = scene.model
    if "builtin" in m:
        try:
            spec = get_spec(m["builtin"])
        except ValueError as exc:
            raise SceneError("model.builtin", "the name of a built-in model (see `contin models`)", m["builtin"],
                             scene.lines.get("model.builtin"), hint=str(exc).split(m["builtin"] + "'", 1)[-1]) from None
        params = {}
        for k, v in m["parameters"].items():
            if not is_number(v):
                raise scene.error(f"model.parameters.{k}", "a finite number", v if not isinstance(v, int) else str(v)[:40])
            params[k] = float(v)
        for k in m["options"]:
            if not isinstance(k, str):
                raise scene.error("model.options", "option names (strings)", k)
        try:
            return spec.build(params, m["effects"], **m["options"])
        except ValueError as exc:
            raise SceneError("model", "a valid built-in model setup", None, hint=f": {exc}") from None
    if "from" in m:
        return build_fe_model(scene)
    return build_custom_model(scene)
