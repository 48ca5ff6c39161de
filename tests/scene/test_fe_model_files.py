"""The rotor file of a finite-element scene: read once as a regular file, hashed into ``Scene.inputs``, and
every way it can be broken a message naming ``model.file`` (build_fe_model in contin/scene/fe_model.py)."""

import hashlib
import os
import shutil
from pathlib import Path

import numpy as np
import pytest

from conftest import no_hang
from contin.app.cli import main
from contin.scene.build import build_model
from contin.scene.parse import SceneError, load_scene

ROOT = Path(__file__).resolve().parents[2]
RIG = ROOT / "scenes" / "data" / "rig_001.npz"


def _scene(tmp_path, rotor="rig.npz") -> Path:
    path = tmp_path / "fe.yaml"
    path.write_text(f"""model:
  from: ross
  file: {rotor}
  contact: {{node: 18, clearance: 1.0e-4, stiffness: 6.2e8}}
  unbalance: [{{node: 11, magnitude: 3.9e-3}}]
  reduction: {{modes: 2}}
analysis: {{type: frequency_response, parameter: w, range: [1.6, 1.7], harmonics: 3, stability: none}}
output: {{plots: false}}
""")
    return path


def test_the_scene_and_its_rotor_file_are_hashed(tmp_path):
    shutil.copy(RIG, tmp_path / "rig.npz")
    scene = load_scene(_scene(tmp_path))
    build_model(scene)
    sha = {p: hashlib.sha256(Path(p).read_bytes()).hexdigest() for p in (tmp_path / "fe.yaml", tmp_path / "rig.npz")}
    assert scene.inputs == {str(Path(p).resolve()): h for p, h in sha.items()}


def _broken(tmp_path, kind: str):
    target = tmp_path / "rig.npz"
    if kind == "fifo":
        os.mkfifo(target)
    elif kind == "zero":
        target.symlink_to("/dev/zero")
    elif kind == "truncated":
        target.write_bytes(RIG.read_bytes()[:5000])
    elif kind == "npy":
        with open(target, "wb") as fh:
            np.save(fh, np.eye(4))
    elif kind == "complex":
        with np.load(RIG) as z:
            m = {k: z[k] for k in z.files}
        m["stiffness"] = m["stiffness"] * (1 + 0.5j)
        np.savez_compressed(target, **m)
    return target


@pytest.mark.parametrize("kind, match", [
    ("fifo", r"rig\.npz: a named pipe \(FIFO\), not a regular file"),
    ("zero", r"rig\.npz: a character device, not a regular file"),
    ("truncated", r"not a rotor matrix file .*not a complete zip archive"),
    ("npy", r"not a rotor matrix file .*a single \.npy array"),
    ("complex", r"array 'stiffness'.*real numbers, found complex"),
])
def test_a_broken_rotor_file_names_model_file(tmp_path, kind, match):
    _broken(tmp_path, kind)
    scene = load_scene(_scene(tmp_path))
    with no_hang(20), pytest.raises(SceneError, match=match) as exc:
        build_model(scene)
    assert exc.value.key == "model.file"


def test_contin_check_on_a_truncated_rotor_file_exits_2_without_a_traceback(tmp_path, capsys):
    _broken(tmp_path, "truncated")
    assert main(["check", str(_scene(tmp_path))]) == 2
    err = capsys.readouterr().err
    assert "model.file" in err and "Traceback" not in err
