"""A run loads only what it uses: no matplotlib without figures, no time-domain modules for harmonic balance."""

import json
import subprocess
import sys
from pathlib import Path

SCENES = Path(__file__).resolve().parents[2] / "scenes"

PROBE = """
import json, sys
from contin.app.cli import main
code = main(["run", sys.argv[1], "-o", sys.argv[2], "--quiet", *sys.argv[3:]])
print(json.dumps({"code": code, "loaded": sorted(m for m in sys.modules if m.split(".")[0] in
                  ("matplotlib", "scipy", "contin"))}))
"""


def loaded_by(tmp_path, *overrides) -> tuple[int, set]:
    out = subprocess.run([sys.executable, "-c", PROBE, str(SCENES / "duffing.yaml"), str(tmp_path / "out"),
                          *overrides], capture_output=True, text=True, timeout=300, check=True)
    got = json.loads(out.stdout.strip().splitlines()[-1])
    return got["code"], set(got["loaded"])


def test_a_run_without_figures_loads_no_plotting_and_no_time_domain(tmp_path):
    code, loaded = loaded_by(tmp_path, "--set", "output.plots=false", "--set", "analysis.stability=hill")
    assert code == 0
    heavy = {"matplotlib", "scipy.integrate", "scipy.optimize", "scipy.interpolate", "contin.timedomain.shooting",
             "contin.timedomain.multiple_shooting", "contin.output.figures"}
    assert not heavy & loaded, sorted(heavy & loaded)
    assert "contin.hb.problem" in loaded  # (the probe sees the run's modules)


def test_a_run_with_figures_loads_matplotlib(tmp_path):
    code, loaded = loaded_by(tmp_path, "--set", "analysis.stability=hill")
    assert code == 0 and "matplotlib" in loaded and "contin.output.figures" in loaded
