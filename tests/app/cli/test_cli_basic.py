"""The command line: entry points, the Duffing scene end to end, bad input."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from contin.app.cli import main
from contin.output.results import read_csv

ROOT = Path(__file__).resolve().parents[3]


def amplitude_equation(A, w, c=0.1, F=0.5):
    return ((1 - w**2 + 0.75 * A**2) ** 2 + (c * w) ** 2) * A**2 - F**2


def test_run_duffing_scene_writes_consistent_files(tmp_path):
    out = tmp_path / "duff"
    code = main(["run", str(ROOT / "scenes/duffing.yaml"), "-o", str(out), "-q",
                 "--set", "analysis.harmonics=1", "--set", "analysis.range=[0.5, 3.0]"])
    assert code == 0
    rows = read_csv(out / "branches.csv")
    # H = 1: the first harmonic satisfies the amplitude equation at every row
    np.testing.assert_allclose(amplitude_equation(rows["h1_x"], rows["w"]), 0.0, atol=1e-9)
    assert rows["w"][0] == 0.5 and rows["w"][-1] == 3.0
    sp = read_csv(out / "special_points.csv")
    kinds = list(sp["kind"])
    assert kinds.count("fold") == 2 and kinds[-1] == "end"
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "complete"
    assert summary["scene"]["analysis"]["harmonics"] == 1  # the override is echoed
    assert summary["scene"]["analysis"]["subharmonic"] == 1  # a default is filled in
    assert summary["analysis"]["branches"][0]["status"] == "range_end"
    assert (out / "bifurcation_diagram.png").stat().st_size > 10_000


def test_python_dash_m_and_console_script_agree(tmp_path):
    r1 = subprocess.run([sys.executable, "-m", "contin", "models"], capture_output=True, text=True, check=True)
    assert "duffing" in r1.stdout and "effects" in r1.stdout
    r2 = subprocess.run(["contin", "models"], capture_output=True, text=True, check=True)
    assert r2.stdout == r1.stdout


def test_check_prints_terms_and_unknowns(capsys):
    assert main(["check", str(ROOT / "scenes/duffing.yaml")]) == 0
    out = capsys.readouterr().out
    assert "unknowns: 19 = 1 dof x (2H+1)" in out
    assert "g" in out and "cos(1*tau" in out


def test_check_without_forcing_effect_has_no_forcing_term(tmp_path, capsys):
    assert main(["check", str(ROOT / "scenes/duffing.yaml"), "--set", "model.effects=[damping, cubic]"]) == 0
    out = capsys.readouterr().out
    assert "excitation" not in out and "polynomial" in out


@pytest.mark.parametrize("override,fragment", [
    ("analysis.harmonic=3", "analysis.harmonic.*did you mean 'harmonics'"),
    ("analysis.range=[1, 1]", "analysis.range.*two different numbers"),
    ("analysis.harmonics=0", "analysis.harmonics.*integer from 1 to 2000"),
    ("model.builtin=dufing", "model.builtin.*did you mean 'duffing'"),
    ("model.parameters.FF=1", "model.parameters.FF.*did you mean 'F'"),
])
def test_bad_input_names_the_key(override, fragment, capsys):
    assert main(["run", str(ROOT / "scenes/duffing.yaml"), "--set", override, "-q", "-o", "/tmp/never"]) == 2
    err = capsys.readouterr().err.replace("\n", " ")
    import re
    assert re.search(fragment, err), err


def test_rotor_scene_checks_and_a_failed_start_is_reported(tmp_path, capsys):
    assert main(["check", str(ROOT / "scenes/rotor_harmonic.yaml")]) == 0
    out = capsys.readouterr().out
    assert "contact" in out and "unknowns: 324 = 4 dof x (2H+1)" in out
    # a start from a simulation stopped long before the motion settles: a numerical failure, exit 1 (a negative
    # contact stiffness, which once served here, is bad input now: tests/cli/test_check_parity.py)
    code = main(["run", str(ROOT / "scenes/rotor_harmonic.yaml"), "-o", str(tmp_path / "r"), "-q",
                 "--set", "analysis.harmonics=10", "--set", "analysis.samples=256", "--set", "analysis.crossings=none",
                 "--set", "analysis.start_from=simulation",
                 "--set", "analysis.start_simulation={transient: 0.01, steps_per_period: 2048}"])
    assert code == 1
    assert "no starting solution at w=1.6" in capsys.readouterr().err
    summary = json.loads((tmp_path / "r" / "summary.json").read_text())
    assert summary["status"] == "failed" and "after 0.01 revolutions" in summary["message"]


@pytest.mark.parametrize("var, value", [("CONTIN_THREADS", "0"), ("CONTIN_THREADS", "two"),
                                        ("CONTIN_BLAS_THREADS", "abc"), ("CONTIN_BLAS_THREADS", "-1")])
def test_a_bad_thread_count_in_the_environment_is_named_before_anything_runs(var, value, tmp_path, monkeypatch,
                                                                              capsys):
    from contin.util import workers

    monkeypatch.setenv(var, value)
    monkeypatch.setattr(workers, "_threads", None)  # read the environment again
    out = tmp_path / "never"
    assert main(["run", str(ROOT / "scenes/duffing.yaml"), "-o", str(out), "-q"]) == 2
    assert f"{var} must be a positive integer, got {value!r}" in capsys.readouterr().err
    assert not out.exists()
