"""Starts of frequency_response: at many harmonics by a homotopy in H, and a failed start that says what to try."""

import numpy as np
import yaml

import contin
from contin.api.system import System

#: two masses in a chain, a cubic spring to ground on the first, a one-sided stop on the second
CHAIN = """
model:
  dofs: [x1, x2]
  parameters: {m1: 1, m2: 1, k1: 1, k2: 1, c: 0.02, g3: 0.5, gap: 0.3, ks: 20, F: 0.1, w: 0.5}
  mass: [[m1, 0], [0, m2]]
  damping: [[2*c, -c], [-c, c]]
  stiffness: [[k1 + k2, -k2], [-k2, k2]]
  forces:
    - {dof: x1, expr: "g3*x1**3"}
    - {type: gap, dof: x2, clearance: gap, stiffness: ks, damping: 0, sides: "+"}
  excitation:
    - {dof: x1, expr: "F*cos(tau)"}
  frequency: w
"""


def chain(**parameters):
    data = yaml.safe_load(CHAIN)
    data["model"]["parameters"].update(parameters)
    return System.from_scene(data)


def test_a_failed_start_says_what_to_try():
    # before: "Newton did not converge at the start parameter w=0.3: ..." and nothing more
    r = contin.frequency_response(chain(F=5.0), parameter="w", range=[0.3, 0.5], harmonics=9, stability="none")
    (b,) = r.summary["analysis"]["branches"]
    assert b["status"] == "start_failed" and b["points"] == 0
    assert b["message"].startswith("Newton did not converge at the start parameter w=0.3")
    assert b["message"].endswith(
        "; to try: start at the other end of the range (--set analysis.start=0.5; the direction follows), or start "
        "from a time simulation (--set analysis.start_from=simulation), or fewer harmonics first "
        "(--set analysis.harmonics=5), then raise them")
    assert any("to try: start at the other end" in s for s in r.summary["analysis"]["shortfalls"])


def test_the_chain_with_25_harmonics_starts_at_w_0_5_and_runs():
    # before: start_failed at w=0.5 (Newton from the linear solution diverged); w=2 as the start worked
    r = contin.frequency_response(chain(), parameter="w", range=[0.5, 0.6], harmonics=25, stability="none")
    (b,) = r.summary["analysis"]["branches"]
    assert b["status"] == "range_end" and b["points"] > 2
    w = r.tables["branches"]["w"]
    assert w[0] == 0.5 and np.isclose(w[-1], 0.6)
