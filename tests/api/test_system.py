"""System: a model from Python with the scene's vocabulary and the scene's messages."""

import numpy as np
import pytest

import contin
from contin.scene.schema import SceneError

DUFFING = dict(dofs=["x"], parameters={"c": 0.1, "g": 1.0, "F": 0.5, "w": 1.0}, mass=[[1]], damping=[["c"]],
               stiffness=[[1]], forces=[{"dof": "x", "expr": "g*x**3"}],
               excitation=[{"dof": "x", "expr": "F*cos(tau)"}], frequency="w")


def test_numpy_values_and_expressions_build_the_model():
    s = contin.System(**{**DUFFING, "mass": np.eye(1), "parameters": {**DUFFING["parameters"], "k2": "2*c"}})
    assert s.dofs == ("x",) and s.parameters["k2"] == pytest.approx(0.2)
    assert "x**3" in s.describe() or "x^3" in s.describe()
    t = s.with_parameters(g=2.0)
    assert t.parameters["g"] == 2.0 and s.parameters["g"] == 1.0


@pytest.mark.parametrize("change,match", [
    ({"stiffnes": [[1]]}, r"model\.stiffnes.*unknown key.*stiffness"),
    ({"mass": [[1, 0], [0, 1]]}, r"mass"),
    ({"forces": [{"dof": "x", "expr": "g*y**3"}]}, r"y"),
    ({"forces": [{"dof": "x", "expr": "__import__('os')"}]}, r"model\.forces"),
    ({"parameters": {"c": object()}}, r"model\.parameters\.c.*numbers, strings"),
])
def test_mistakes_are_named_like_in_a_scene(change, match):
    with pytest.raises((SceneError, ValueError), match=match):
        contin.System(**{**DUFFING, **change})


def test_builtin_and_scene_systems():
    assert contin.System.builtin("duffing", {"F": 0.3}).parameters["F"] == 0.3
    s = contin.System.from_scene("scenes/gap_oscillator.yaml")
    assert s.dofs == ("x",) and s.name == "gap_oscillator"
    with pytest.raises(SceneError, match=r"model\.parameters\.Q"):
        contin.System.builtin("duffing", {"Q": 1.0})


def test_unknown_analysis_keyword_is_refused_before_anything_runs(tmp_path):
    # a Python call's error, naming the keyword and the one meant (it was a SceneError in scene words)
    with pytest.raises(TypeError, match=r"frequency_response\(\) got an unexpected keyword argument 'harmonic' "
                       r"\(did you mean 'harmonics'\?\)"):
        contin.frequency_response("duffing", range=[0.5, 1.0], harmonic=5, outdir=tmp_path / "r")
    assert not (tmp_path / "r").exists()
