"""A model from Python in the scene's vocabulary: :class:`System`.

The keyword arguments of :class:`System` are the keys of a scene's ``model``
section (``dofs``, ``parameters``, ``mass``, ``damping``, ``stiffness``,
``forces``, ``excitation``, ``frequency``, ``symbols``, ``name``), with the same
expressions, force elements and checks: a mistake gets the message a scene
would get, naming the key, when the system is made. Matrices and vectors may be
numpy arrays; entries may be numbers or expression strings.
"""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from contin.model.base import Model
from contin.scene.build import build_model
from contin.scene.fe_model import rotor_path
from contin.scene.parse import Scene, SceneError, check_model_section, load_scene, parse_scene

__all__ = ["System", "plain"]


def plain(value: Any, key: str = "value") -> Any:
    """``value`` as the plain data a YAML scene would hold: lists for tuples and arrays, floats for numpy
    numbers, strings for paths.

    Raises
    ------
    SceneError
        For an object a scene cannot hold (naming ``key``).
    """
    if isinstance(value, Mapping):
        return {str(k): plain(v, f"{key}.{k}") for k, v in value.items()}
    if isinstance(value, np.ndarray):
        return plain(value.tolist(), key)
    if isinstance(value, (list, tuple)):
        return [plain(v, f"{key}[{i}]") for i, v in enumerate(value)]
    if isinstance(value, (np.bool_, bool)):
        return bool(value)
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, np.floating):
        return float(value)
    if value is None or isinstance(value, (str, int, float)):
        return value
    if isinstance(value, Path):
        return str(value)
    raise SceneError(key, "numbers, strings, lists or mappings (what a YAML scene holds)", type(value).__name__)


class System:
    """A mechanical system ``M x'' + C x' + K x + f_nl = f_ext(tau)``, custom or built in.

    Parameters
    ----------
    dofs : sequence of str
        Names of the degrees of freedom (``n`` of them).
    parameters : mapping, optional
        Name -> number or expression of other parameters.
    mass, damping, stiffness : (n, n) array_like, optional
        Numbers or expression strings of the parameters.
    forces : sequence of mapping, optional
        Internal forces, as in a scene: ``{"dof": "x", "expr": "g*x**3"}``,
        ``{"type": "gap", "dof": "y", "clearance": 0.1, "stiffness": 1e3}``,
        ``{"type": "radial_gap", "dofs": ["x", "y"], ...}``
        (:doc:`/reference/scenes`).
    excitation : sequence of mapping, optional
        Right-hand side: ``{"dof": "x", "expr": "F*cos(tau)"}`` or
        ``{"dof": "x", "amplitude": "F", "order": 1}``.
    frequency : str, optional
        The parameter that is the excitation frequency ``w`` (``tau = w t``).
    **keys
        Any other key of a custom ``model`` section (``name``, ``symbols``).

    Examples
    --------
    >>> duffing = System(dofs=["x"], parameters={"c": 0.1, "g": 1.0, "F": 0.5, "w": 1.0},
    ...                  mass=[[1]], damping=[["c"]], stiffness=[[1]],
    ...                  forces=[{"dof": "x", "expr": "g*x**3"}],
    ...                  excitation=[{"dof": "x", "expr": "F*cos(tau)"}], frequency="w")
    >>> duffing.dofs
    ('x',)
    """

    def __init__(self, dofs=None, *, section: Mapping | None = None, **keys):
        if section is None:
            section = {"dofs": dofs, **keys}
            section = {k: v for k, v in section.items() if v is not None}
        elif dofs is not None or keys:
            raise TypeError("System: give either section= or the keys of a model section, not both")
        data = plain(section, "model")
        self._section = check_model_section(data)
        self._model: Model | None = None
        self.model  # build now, so that a mistake is reported where the system is made

    # ------------------------------------------------------------ other ways in
    @classmethod
    def builtin(cls, name: str, parameters: Mapping | None = None, effects=None, options: Mapping | None = None
                ) -> "System":
        """A built-in model (``contin models`` lists them) with parameter overrides and effects.

        Parameters
        ----------
        name : str
            For example ``"duffing"``, ``"bearing_rotor"``.
        parameters : mapping, optional
            Overrides of the model's parameter defaults.
        effects : sequence of str, optional
            The effects to compile (all by default).
        options : mapping, optional
            The model's build options.
        """
        section = {"builtin": name, "parameters": dict(parameters or {}), "options": dict(options or {})}
        if effects is not None:
            section["effects"] = list(effects)
        return cls(section=section)

    @classmethod
    def from_scene(cls, scene) -> "System":
        """The model of a scene: a path to a scene file, its YAML text, or a dict (a whole scene or its
        ``model`` section)."""
        if isinstance(scene, (str, Path)) and not (isinstance(scene, str) and "\n" in scene):
            loaded = load_scene(scene)
            section = loaded.model
            if "from" in section:  # a rotor file named relative to the scene file: kept so when the model moves
                section["file"] = str(rotor_path(section, loaded.source).resolve())
            return cls(section=section)
        if isinstance(scene, str):
            return cls(section=parse_scene(scene).model)
        if isinstance(scene, Mapping):
            return cls(section=scene["model"] if "model" in scene else scene)
        raise TypeError(f"System.from_scene: a path, YAML text or a mapping, not {type(scene).__name__}")

    def with_parameters(self, **values) -> "System":
        """A copy with some parameter values (or expressions) changed."""
        section = self.section
        section["parameters"] = {**section.get("parameters", {}), **values}
        return type(self)(section=section)

    # ------------------------------------------------------------ what it is
    @property
    def section(self) -> dict:
        """The ``model`` section of a scene, defaults filled in (a copy)."""
        return copy.deepcopy(self._section)

    @property
    def model(self) -> Model:
        """The built :class:`contin.model.base.Model` (its compiled kernels are made on first use)."""
        if self._model is None:
            self._model = build_model(Scene({"model": self._section, "analysis": {}, "output": {}}, "<python>", {}))
        return self._model

    @property
    def name(self) -> str:
        return self.model.name

    @property
    def dofs(self) -> tuple:
        return tuple(self.model.dof_names)

    @property
    def parameters(self) -> dict:
        """Parameter name -> value (expressions evaluated)."""
        m = self.model
        values = dict(zip(m.param_names, map(float, m.parameter_vector())))
        for name, coef in (getattr(m, "dependent_parameters", None) or {}).items():
            values[name] = float(coef.value(m.parameter_vector()))
        return values

    def describe(self) -> str:
        """The equations of motion, term by term."""
        return self.model.describe()

    def __repr__(self) -> str:
        return f"System({self.name!r}, dofs={list(self.dofs)})"
