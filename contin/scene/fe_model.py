"""Scenes of finite-element rotors: ``model: {from: ross, file: ..., contact: {...}, ...}``.

The rotor file is a ``.npz`` written by contin (:meth:`contin.model.fem.matrices.RotorMatrices.save`, no
ROSS needed) or a rotor file ROSS writes (``.toml``, ``.json``; needs ``contin[ross]``), read relative to
the scene file, once, only if it is a regular file of at most 256 MiB (:func:`contin.scene.files.read_input`;
its sha256 goes to ``Scene.inputs``); a ``.npz`` has its arrays checked before they are inflated
(:func:`contin.model.fem.matrices.load_matrices`). Lengths, masses, forces and frequencies of the items
are in SI; the model's parameters (``w``, ``e``, ``f0``, ``delta``, ``kbn``, ``cbn``) are in the model's units
(:mod:`contin.model.fem.builder`), and ``parameters`` overrides them.
"""

from __future__ import annotations

import functools
from pathlib import Path

from contin.model.base import Model
from contin.scene.files import MODEL_FILE_CAP, input_key, read_input
from contin.scene.schema import Key, SceneError, check_section, flag, integer, is_number, listing, mapping, \
    number, string
from contin.util.naming import suggest

__all__ = ["FE_MODEL", "FE_RULES", "check_fe_section", "build_fe_model", "rotor_path"]

#: the parameters' physical constraints (rules of :data:`contin.model.catalog.RULES`)
FE_RULES = {"e": ("nonnegative", "the unbalance"), "f0": ("nonnegative", "the side load's magnitude"),
            "delta": ("nonnegative", "the radial clearance"), "kbn": ("nonnegative", "the contact stiffness"),
            "cbn": ("nonnegative", "the contact damping")}

FE_MODEL = {
    "from": string(required=True, choices=("ross",)),
    "file": string(required=True),
    "name": string("fe_rotor"),
    "contact": Key("a mapping {node, clearance, stiffness, damping, clip, type, direction, sides}",
                   lambda v: isinstance(v, dict)),
    "unbalance": listing([], expected="a list of {node, magnitude, phase} items"),
    "side_load": Key("a mapping {node, force}", lambda v: isinstance(v, dict)),
    "units": mapping(),
    "reduction": Key("a mapping {modes, speed}", lambda v: isinstance(v, dict)),
    "parameters": mapping(),
    "symbols": mapping(),
}

_NODE = integer(required=True, minimum=0)
ITEMS = {
    "contact": {"node": _NODE, "clearance": number(required=True, min_value=0), "stiffness": number(required=True,
                                                                                                     positive=True),
                "damping": number(0.0, min_value=0), "clip": flag(False),
                "type": string("radial_gap", choices=("radial_gap", "gap")),
                "direction": string("y", choices=("x", "y")), "sides": string("both", choices=("both", "+", "-"))},
    "unbalance": {"node": _NODE, "magnitude": number(required=True, positive=True), "phase": number(0.0)},
    "side_load": {"node": _NODE, "force": Key("[fx, fy] in N, not both zero",
                                              lambda v: isinstance(v, list) and len(v) == 2
                                              and all(is_number(x) for x in v) and any(x != 0 for x in v),
                                              required=True)},
    "units": {"length": number(1e-3, positive=True), "mass": Key("a positive number (kg) or null",
                                                                 lambda v: v is None or (is_number(v) and v > 0)),
              "frequency": Key("a positive number (rad/s) or null", lambda v: v is None or (is_number(v) and v > 0))},
    "reduction": {"modes": integer(required=True, minimum=0), "speed": number(0.0, min_value=0)},
}


def check_fe_section(model: dict, lines: dict) -> dict:
    """The ``model`` section of a finite-element rotor, its items checked and defaults filled in.

    Raises
    ------
    SceneError
        Naming the key (``model.contact.stiffness``, ``model.unbalance[1].node``).
    """
    model = check_section(model, FE_MODEL, "model", lines)
    for key in ("contact", "side_load", "units", "reduction"):
        if model[key] is not None:  # units: always (its defaults)
            model[key] = check_section(model[key], ITEMS[key], f"model.{key}", lines)
    items = []
    for i, item in enumerate(model["unbalance"]):
        where = f"model.unbalance[{i}]"
        if not isinstance(item, dict):
            raise SceneError(where, "a mapping {node, magnitude, phase}", item, lines.get(where))
        items.append(check_section(item, ITEMS["unbalance"], where, lines))
    model["unbalance"] = items
    for k, v in model["parameters"].items():
        if not is_number(v):
            raise SceneError(f"model.parameters.{k}", "a finite number (model units)", v,
                             lines.get(f"model.parameters.{k}"))
    return model


def rotor_path(model: dict, source: str) -> Path:
    """The rotor file of a checked ``model`` section: ``model.file``, relative to the scene file ``source``
    (to the working directory for a scene that is no file: ``<string>``, ``<python>``)."""
    path = Path(model["file"]).expanduser()
    if not path.is_absolute() and not source.startswith("<"):
        path = Path(source).parent / path
    return path


def build_fe_model(scene) -> Model:
    """The model of a checked ``model: {from: ross, ...}`` section.

    Raises
    ------
    SceneError
        Naming ``model.file`` for a missing, unreadable or malformed file (or
        ROSS missing for a ROSS file), the item's key for a value the rotor
        cannot take (a node off the rotor), ``model.parameters.NAME`` for an
        unknown parameter.
    """
    # every scene's check reads this module's schema: what only builds a rotor is imported here
    from contin.bifurcation.start import contact_start  # deferred: the starts and their solvers (0.4 s)
    from contin.model.fem.builder import (  # deferred: scipy.interpolate (0.12 s), for a rotor's scene alone
        Contact, Reduction, SideLoad, Unbalance, Units, fe_rotor_model)
    from contin.model.fem.matrices import load_matrices  # deferred: a rotor file's reader, for a rotor's scene
    from contin.model.fem.ross_bridge import load_rotor  # deferred: scipy.interpolate, as the builder

    m = scene.model
    path = rotor_path(m, scene.source)
    try:
        if not path.exists():
            raise OSError(f"{path}: no such rotor file")
        # read once, a regular file under its cap; its hash tells a resumed run whether it changed
        data, digest = read_input(path, MODEL_FILE_CAP)
        scene.inputs[input_key(path)] = digest
        rotor = load_matrices(path, data) if path.suffix == ".npz" else load_rotor(path)
    except (OSError, ImportError, ValueError) as exc:
        why = f"{exc.filename}: {exc.strerror}" if isinstance(exc, OSError) and exc.filename else exc
        raise SceneError("model.file", "a rotor file (.npz written by contin, or ROSS's .toml/.json)", m["file"],
                         scene.lines.get("model.file"), hint=f": {why}") from None
    units = m["units"]
    try:
        model = fe_rotor_model(
            rotor,
            contact=Contact(**m["contact"]) if m["contact"] else None,
            unbalance=[Unbalance(**u) for u in m["unbalance"]],
            side_load=SideLoad(m["side_load"]["node"], tuple(m["side_load"]["force"])) if m["side_load"] else None,
            units=Units(units.get("length", 1e-3), units.get("mass"), units.get("frequency")),
            reduction=Reduction(**m["reduction"]) if m["reduction"] else None,
            name=m["name"])
    except ValueError as exc:
        key = str(exc).split(":", 1)[0]
        raise SceneError(f"model.{key}" if "." in key or key in ITEMS else "model", "a value the rotor can take",
                         None, scene.lines.get(f"model.{key}"), hint=f": {exc}") from None
    for k, v in m["parameters"].items():
        if k not in model.parameters:
            raise SceneError(f"model.parameters.{k}", f"a parameter of the rotor model ({', '.join(model.parameters)})",
                             k, scene.lines.get(f"model.parameters.{k}"), hint=suggest(k, model.parameters))
        model.parameters[k] = float(v)
    model.symbols.update(m["symbols"])
    if m["contact"]:
        direction = tuple(m["side_load"]["force"]) if m["side_load"] else (0.0, 1.0)
        if m["contact"]["type"] == "gap":  # the gap's own dof: towards the side the load pushes it
            along = direction["xy".index(m["contact"]["direction"])]
            sides = m["contact"]["sides"]
            direction = (-1.0,) if sides == "-" or (sides == "both" and along < 0) else (1.0,)
        model.start = functools.partial(contact_start, direction=direction)
    return model
