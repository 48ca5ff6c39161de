"""Scenes of finite-element rotors (``model: {from: ross, ...}``): checks, errors naming keys, a short run."""

import json
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest

from contin.scene.build import build_model
from contin.scene.parse import SceneError, load_scene, parse_scene

ROOT = Path(__file__).resolve().parents[2]
SCENE = ROOT / "scenes" / "rotor_fe_rig.yaml"


def _scene(tmp_path, model_extra="", contact="{node: 18, clearance: 1.0e-4, stiffness: 6.2e8, damping: 316}"):
    shutil.copy(ROOT / "scenes" / "data" / "rig_001.npz", tmp_path / "rig.npz")
    text = f"""model:
  from: ross
  file: rig.npz
  contact: {contact}
  unbalance: [{{node: 11, magnitude: 3.9e-3}}]
  side_load: {{node: 11, force: [0, 24.1]}}
{model_extra}analysis:
  type: frequency_response
  parameter: w
  range: [1.6, 1.604]
  start: 1.6
  harmonics: 20
  samples: 512
  crossings: interval
  stability: floquet
output: {{plots: false}}
"""
    path = tmp_path / "fe.yaml"
    path.write_text(text)
    return path


def test_shipped_scene_builds_the_reduced_rig():
    model = build_model(load_scene(SCENE))
    assert model.n_dof == 12 and model.dof_names[:4] == ("x_18", "y_18", "x_11", "y_11")
    assert model.fe.units.length == 1e-3 and model.fe.units.mass == pytest.approx(7.80408)
    assert model.parameters["delta"] == pytest.approx(0.1) and model.start is not None


@pytest.mark.parametrize("extra, contact, key, match", [
    ("", "{node: 18, clearance: 1.0e-4, stifness: 6.2e8}", "model.contact.stifness", "did you mean 'stiffness'"),
    ("", "{node: 18, clearance: 1.0e-4}", "model.contact.stiffness", "required"),
    ("", "{node: -1, clearance: 1.0e-4, stiffness: 1e8}", "model.contact.node", "integer >= 0"),
    ("  units: {length: 0}\n", None, "model.units.length", "positive"),
    ("  reduction: {modes: two}\n", None, "model.reduction.modes", "integer"),
    ("  parameters: {kbn: fast}\n", None, "model.parameters.kbn", "finite number"),
])
def test_bad_items_are_named(tmp_path, extra, contact, key, match):
    path = _scene(tmp_path, extra, contact or "{node: 18, clearance: 1.0e-4, stiffness: 6.2e8}")
    with pytest.raises(SceneError, match=match) as exc:
        load_scene(path)
    assert exc.value.key == key


def test_build_errors_name_the_key(tmp_path, monkeypatch):
    with pytest.raises(SceneError, match=r"model.contact.*node 0 has a bearing stiffness"):
        build_model(load_scene(_scene(tmp_path, contact="{node: 0, clearance: 1.0e-4, stiffness: 6.2e8}")))
    with pytest.raises(SceneError, match=r"model.parameters.kbm.*did you mean 'kbn'"):
        build_model(load_scene(_scene(tmp_path, "  parameters: {kbm: 3}\n")))
    path = _scene(tmp_path)
    path.write_text(path.read_text().replace("file: rig.npz", "file: nowhere.npz"))
    with pytest.raises(SceneError, match=r"model.file.*no such rotor file"):
        build_model(load_scene(path))
    path.write_text(path.read_text().replace("file: nowhere.npz", "file: rotor.toml"))
    (tmp_path / "rotor.toml").write_text("[x]\n")
    monkeypatch.setitem(sys.modules, "ross", None)  # ROSS not installed
    with pytest.raises(SceneError, match=r"model.file.*pip install 'contin\[ross\]'"):
        build_model(load_scene(path))
    with pytest.raises(SceneError, match="model.from"):
        parse_scene("model: {from: ansys, file: x}\nanalysis: {type: frequency_response, range: [1, 2]}\n")


def test_short_run_is_complete_with_whirl_columns(tmp_path):
    from contin.app.cli import main
    from contin.output.results import read_csv

    out = tmp_path / "out"
    assert main(["run", str(_scene(tmp_path, "  reduction: {modes: 6}\n")), "-o", str(out), "-q"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "complete"
    rows = read_csv(out / "branches.csv")
    assert rows["w"][0] == pytest.approx(1.6) and rows["w"][-1] == pytest.approx(1.604)
    assert np.all(rows["whirl_fwd_1_disc"] > 0.5) and np.all(rows["whirl_fwd_half_disc"] == 0.0)
    assert np.all(np.asarray(rows["max_multiplier"]) > 1.0)  # the harmonic whirl is unstable here (self-excited)


def test_python_api_keeps_the_rotor_file_of_a_scene(tmp_path, monkeypatch):
    from contin.api import System

    system = System.from_scene(SCENE)
    monkeypatch.chdir(tmp_path)  # elsewhere: the file stays the scene's
    assert Path(system.section["file"]).is_absolute()
    assert system.model.n_dof == 12
