"""``contin absorber``: Den Hartog's design printed, plotted and written, and its bad input."""

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest

from contin.app.cli import main

ROOT = Path(__file__).resolve().parents[3]


def test_seed000_exercise_from_the_command_line(tmp_path, capsys):
    png, js = tmp_path / "absorber.png", tmp_path / "absorber.json"
    assert main(["absorber", "--m1", "100", "--k1", "5e5", "--m2", "10", "--plot", str(png), "--json", str(js)]) == 0
    out = capsys.readouterr().out
    assert "k2 = k1 beta/(1+beta)^2 = 41322.3" in out and "c = 237.379" in out
    assert "zeta   = c/(2 m2 p)" in out and "zeta_a = c/(2 sqrt(m2 k2))" in out
    assert "sqrt((2+beta)/beta) = 4.58258" in out and "true peak" in out
    d = json.loads(js.read_text())
    beta = 0.1
    assert d["k2"] == pytest.approx(5e5 * beta / (1 + beta) ** 2, rel=1e-14)
    assert d["zeta"] == pytest.approx(math.sqrt(3 * beta / (8 * (1 + beta) ** 3)), rel=1e-14)
    assert d["zeta_a"] == pytest.approx(math.sqrt(3 * beta / (8 * (1 + beta))), rel=1e-14)
    assert d["c"] == pytest.approx(2 * 10 * math.sqrt(5e3) * d["zeta"], rel=1e-14)
    assert d["P"]["height"] == pytest.approx(math.sqrt(21), rel=1e-12)
    assert math.sqrt(21) < d["true_peak"]["amplification"] < 1.002 * math.sqrt(21)
    assert d["anti_resonance"] == pytest.approx(math.sqrt(d["k2"] / 10), rel=1e-14)
    assert png.stat().st_size > 10_000


def test_sizing_by_a_maximum_amplification(capsys):
    assert main(["absorber", "--m1", "100", "--k1", "5e5", "--max-amplification", "5"]) == 0
    out = capsys.readouterr().out
    assert "beta = m2/m1 = 0.0833333" in out  # 2/(A^2 - 1)
    assert "the true peak exceeds the allowed 5" in out
    assert main(["absorber", "--m1", "100", "--k1", "5e5", "--max-amplification", "5", "--sizing", "peak"]) == 0
    out = capsys.readouterr().out
    assert "|X1|/delta_st = 5 at" in out and "exceeds" not in out


@pytest.mark.parametrize("args, match", [
    (["--m1", "-100", "--k1", "5e5", "--m2", "10"], "--m1: expected a positive finite number"),
    (["--m1", "100", "--k1", "nan", "--m2", "10"], "--k1: expected a positive finite number"),
    (["--m1", "100", "--k1", "5e5", "--m2", "0"], "--m2: expected a positive finite number"),
    (["--m1", "100", "--k1", "5e5", "--max-amplification", "1"], "--max-amplification: expected a number above 1"),
    (["--m1", "100", "--k1", "5e5", "--m2", "10", "--sizing", "peak"], "--sizing: expected to be used with"),
])
def test_bad_values_name_the_option(args, match, capsys):
    assert main(["absorber"] + args) == 2
    assert match in capsys.readouterr().err


def test_missing_mass_and_amplification_is_a_usage_error(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["absorber", "--m1", "100", "--k1", "5e5"])
    assert exc.value.code == 2
    assert "one of the arguments --m2 --max-amplification is required" in capsys.readouterr().err


def test_python_dash_m_contin_absorber(tmp_path):
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    r = subprocess.run([sys.executable, "-m", "contin", "absorber", "--m1", "100", "--k1", "5e5", "--m2", "10"],
                       capture_output=True, text=True, cwd=tmp_path, env=env, timeout=300)
    assert r.returncode == 0, r.stderr
    assert "c = 237.379" in r.stdout
