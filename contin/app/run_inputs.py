"""What a run read and built, so that ``--resume`` goes on only with the same.

``summary.json`` keeps ``inputs`` (absolute path -> sha256 of every file the
scene reads: the scene file, a rotor's ``.npz`` or ROSS file) and
``fingerprint`` (sha256 of the built model: its name, dofs, parameters and
their values, effects, terms and its linear matrices at the scene's
parameters). A resume whose files or model differ would mix rows of two
models in one table; :func:`check_same_inputs` refuses it.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np

from contin.scene.fe_model import rotor_path
from contin.scene.schema import SceneError

__all__ = ["file_sha256", "scene_inputs", "model_fingerprint", "check_same_inputs"]


def file_sha256(path) -> str:
    """The sha256 of a file's bytes (hex)."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def _read_files(scene) -> list[Path]:
    """The files a scene reads: its own file, and a finite-element rotor's file (``model.file``)."""
    paths = []
    if scene.source and not scene.source.startswith("<"):
        paths.append(Path(scene.source))
    if "from" in scene.model and scene.model.get("file"):
        paths.append(rotor_path(scene.model, scene.source))
    return paths


def scene_inputs(scene) -> dict[str, str]:
    """Absolute path -> sha256 of every file the scene reads.

    The hashes the scene loader recorded of the bytes it read
    (``scene.inputs``) where it did; the files of :func:`_read_files` it did
    not record are hashed here. A file that cannot be read is left out (the
    model was built from it, so it was there).
    """
    recorded = getattr(scene, "inputs", None)
    out = {str(k): str(v) for k, v in recorded.items()} if isinstance(recorded, dict) else {}
    for path in _read_files(scene):
        key = str(path.expanduser().resolve())
        if key in out:
            continue
        try:
            out[key] = file_sha256(key)
        except OSError:
            pass
    return out


def model_fingerprint(model) -> str:
    """sha256 of what the built model is: name, dofs, parameters with their values, effects, terms, and
    ``M``, ``C``, ``K`` at the scene's parameters (bit for bit)."""
    h = hashlib.sha256()
    p = np.asarray(model.parameter_vector(), dtype=np.float64)
    head = {"name": model.name, "dofs": list(model.dof_names), "parameters": list(model.param_names),
            "effects": list(model.effects), "describe": model.describe(), "frequency": model.frequency}
    h.update(json.dumps(head, sort_keys=True).encode())
    h.update(p.tobytes())
    for mat in model.linear(p):
        h.update(np.ascontiguousarray(mat, dtype=np.float64).tobytes())
    for name in sorted(getattr(model, "linear_observables", {}) or {}):
        h.update(name.encode())
        h.update(np.ascontiguousarray(model.linear_observables[name], dtype=np.float64).tobytes())
    return h.hexdigest()


def check_same_inputs(old: dict, inputs: dict, fingerprint: str, outdir) -> None:
    """Refuse a resume whose files or model differ from the run's (``old``: its ``summary.json``).

    A summary without ``inputs`` or ``fingerprint`` (a run of a version that did
    not record them) is not compared on what it lacks.

    Raises
    ------
    SceneError
        Naming each file whose content changed, or saying that the model
        built now differs from the run's.
    """
    before = old.get("inputs")
    changed = []
    if isinstance(before, dict):
        changed = [path for path, digest in before.items() if path in inputs and inputs[path] != digest]
        gone = [path for path in before if path not in inputs and not Path(path).exists()]
        changed += [f"{path} (no longer there)" for path in gone]
    if changed:
        raise SceneError("--resume", f"the files the run in {outdir} read, unchanged", None,
                         hint=f"; changed since it ran: {', '.join(changed)}. Resume with the files of that run, "
                         "or run again without --resume (or use another -o)")
    was = old.get("fingerprint")
    if isinstance(was, str) and was != fingerprint:
        raise SceneError("--resume", f"the model of the run in {outdir}", "a model built differently",
                         hint=" (its parameters, terms or matrices differ, from a file the scene reads or a version "
                         "of contin); run again without --resume, or use another -o")
