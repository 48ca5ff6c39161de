"""A shooting branch of twice the period that comes back to the harmonic branch ends there, located, as asked.

x'' + (0.1 + x^2) x' + (delta + 0.4 cos t) x = 0: the nonlinear damping narrows the
first instability tongue of the damped Mathieu equation with the amplitude, so the
1/2-subharmonic born at one period doubling of the trivial orbit dies at the other
(a closed bubble). Truth from outside the code: the two period doublings are those
of the linear damped Mathieu equation (scipy's DOP853 monodromy, Liouville's
determinant), and the returning orbit is the trivial one (zero amplitude).
"""


import numpy as np
import pytest

from contin.app.runner import run_scene
from contin.output.results import read_csv
from contin.scene.parse import parse_scene
from mathieu_reference import damped_mathieu_pd

BUBBLE = """\
model:
  name: mathieu_bubble
  dofs: [x]
  parameters: {c: 0.1, d: 1.0, delta: 0.0, eps: 0.4, w: 1.0}
  mass: [[1]]
  damping: [[c]]
  stiffness: [[0]]
  forces:
    - {dof: x, expr: "d*x**2*x_dot + (delta + eps*cos(tau))*x"}
  frequency: w
analysis:
  type: frequency_response
  parameter: delta
  range: [-0.05, 0.5]
  harmonics: 6
  method: shooting
  shooting: {steps_per_period: 128}
  stability: floquet
  switch: [pd]
  continuation: {ds: 0.05, ds_max: 0.1}
output: {measure: amp_x, plots: false}
"""


def test_the_subharmonic_bubble_returns_to_the_other_period_doubling_and_ends_there(tmp_path):
    out = tmp_path / "out"
    s = run_scene(parse_scene(BUBBLE), out, progress=False)
    assert s["status"] == "complete" and s["shortfalls"] == []
    pds = [damped_mathieu_pd(0.0, 0.2), damped_mathieu_pd(0.3, 0.6)]
    b0, *subs = s["analysis"]["branches"]
    assert b0["status"] == "range_end" and len(subs) == 2
    for b in subs:
        born = b["origin"]["parameter"]
        other = pds[1] if abs(born - pds[0]) < abs(born - pds[1]) else pds[0]
        assert b["nu"] == 2 and b["status"] == "closed_loop"  # ended as asked, at the other period doubling
        assert b["returned"]["order"] == 1 and b["returned"]["parameter"] == pytest.approx(other, abs=1e-6)
        assert b["message"].startswith("returned to the branch of order nu=1 at its period doubling at delta=")
    sp = read_csv(out / "special_points.csv")
    rows = read_csv(out / "branches.csv")
    for bid in (1, 2):
        at = [i for i, (b, k) in enumerate(zip(sp["branch"], sp["kind"])) if int(b) == bid and k == "pd"]
        assert len(at) == 1 and float(sp["amp_x"][at[0]]) < 1e-6  # the orbit there is the trivial one
        on = np.asarray(rows["branch"]) == bid
        # never run on past it: every row of the bubble between the two period doublings
        d = np.asarray(rows["delta"])[on]
        assert d.min() >= pds[0] - 1e-6 and d.max() <= pds[1] + 1e-6
        assert np.asarray(rows["amp_x"])[on].max() > 0.3
