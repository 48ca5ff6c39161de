"""An analysis added by one class and one table line is seen by every reader of the table: the scene
parser, `contin check`, `contin run`, the Python API in memory and the scene reference
(the class of docs/howto/new-analysis.md, against the closed form of a linear oscillator)."""

import re
from pathlib import Path

import numpy as np
import pytest

import contin
from contin.app.cli import main
from contin.output.results import read_csv
from contin.scene import registry
from contin.scene.parse import SceneError, analysis_schemas, scene_from_data

PAGE = Path(__file__).resolve().parents[2] / "docs" / "howto" / "new-analysis.md"
SCENE = {"model": {"builtin": "duffing", "parameters": {"m": 2.0, "c": 0.3, "k": 5.0}},
         "analysis": {"type": "receptance", "dof": "x", "range": [0.5, 3.0], "points": 26},
         "output": {"plots": False}}


@pytest.fixture
def receptance(monkeypatch):
    """The page's class, listed in the table for the test only."""
    namespace: dict = {}
    exec(re.search(r"```python\n(from dataclasses import dataclass.*?)```", PAGE.read_text(), re.S).group(1),
         namespace)
    monkeypatch.setitem(registry.ANALYSES, "receptance", namespace["Receptance"])
    return namespace["Receptance"]


def exact(w):
    return 1.0 / np.abs(5.0 - 2.0 * w ** 2 + 0.3j * w)


def test_the_table_line_makes_it_a_scene_type_with_its_keys(receptance):
    assert "receptance" in analysis_schemas() and "receptance" in registry.analysis_names()
    with pytest.raises(SceneError, match=r"analysis\.pionts: expected one of the keys type, dof, range, points"):
        scene_from_data({**SCENE, "analysis": {**SCENE["analysis"], "pionts": 3}}, "<test>")
    with pytest.raises(SceneError, match=r"analysis\.dof: expected a dof of the model \['x'\], found 'y'"):
        contin.run({**SCENE, "analysis": {**SCENE["analysis"], "dof": "y"}})


def test_it_runs_in_memory_and_into_a_directory_alike(receptance, tmp_path, capsys):
    held = contin.run(SCENE)
    assert held.outdir is None and held.status == "complete"
    table = held.tables["receptance"]
    np.testing.assert_allclose(table["amp_x"], exact(table["w"]), rtol=1e-13)
    path = tmp_path / "receptance.yaml"
    import yaml

    path.write_text(yaml.safe_dump(SCENE))
    assert main(["check", str(path)]) == 0
    assert "  receptance of the linear part at 26 frequencies, unit force on x" in capsys.readouterr().out
    assert main(["run", str(path), "-o", str(tmp_path / "out"), "-q"]) == 0
    on_disk = read_csv(tmp_path / "out" / "receptance.csv")
    assert on_disk.keys() == table.keys() and all(np.array_equal(on_disk[k], table[k]) for k in table)
    loaded = contin.load(tmp_path / "out")
    assert loaded.summary["analysis"] == held.summary["analysis"]
    # the peak of the grid: the closed form's largest value on it
    assert held.summary["analysis"]["peak_frequency"] == pytest.approx(table["w"][np.argmax(exact(table["w"]))])


def test_a_table_line_naming_another_analysis_is_refused(receptance, monkeypatch):
    monkeypatch.setitem(registry.ANALYSES, "other", receptance)
    with pytest.raises(RuntimeError, match=r"named 'receptance', listed as 'other'"):
        registry.analysis("other")
