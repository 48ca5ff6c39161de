"""A run's figures leave the caller's matplotlib as it was: backend, rcParams, pyplot's figures.

Figures are made on their own canvas (:mod:`contin.output.figures`) and each
run applies its ``output.style`` inside ``rc_context``; ``output.formats`` and
``output.dpi`` choose the files.
"""

import copy

import matplotlib
import pytest

from contin.app.runner import run_scene
from contin.scene.parse import parse_scene

MODES = """
model:
  builtin: linear_chain
  parameters: {m1: 1, m2: 2, k1: 1, k2: 1, k3: 2}
  effects: []
analysis:
  type: modes
output:
  formats: [svg, pdf]
  style: paper
"""

SIMULATE = """
model:
  builtin: duffing
  parameters: {m: 1, c: 0.1, k: 1, g: 1, F: 0.5}
analysis:
  type: simulate
  parameter: w
  values: [1.2]
  steps_per_period: 64
  samples_per_period: 16
  transient: 4
  record: 8
output:
  formats: [svg]
  style: presentation
"""


@pytest.fixture
def user_matplotlib():
    """A user's session: a backend other than Agg and rcParams of their own."""
    before = matplotlib.get_backend()
    matplotlib.use("svg")
    with matplotlib.rc_context({"lines.linewidth": 3.3, "axes.grid": False, "font.size": 9.5}):
        yield
    matplotlib.use(before)


@pytest.mark.parametrize("text, files", [
    (MODES, ["mode_shapes.svg", "mode_shapes.pdf"]),
    (SIMULATE, ["simulation_0.svg"]),
], ids=["modes", "simulate"])
def test_a_run_leaves_backend_and_rcparams_as_they_were(text, files, tmp_path, user_matplotlib):
    backend = matplotlib.get_backend()
    params = copy.deepcopy(dict(matplotlib.rcParams))
    summary = run_scene(parse_scene(text), tmp_path, progress=False)
    assert matplotlib.get_backend() == backend == "svg"
    assert dict(matplotlib.rcParams) == params
    assert summary["plots"] == files
    assert all((tmp_path / f).stat().st_size > 1000 for f in files)
    assert not list(tmp_path.glob("*.png"))  # only the formats asked for
    import sys

    if "matplotlib.pyplot" in sys.modules:  # nothing registered with pyplot
        assert sys.modules["matplotlib.pyplot"].get_fignums() == []
