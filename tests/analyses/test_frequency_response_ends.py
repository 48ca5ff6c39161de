"""A frequency response that ends at a grazing point says ``complete`` only where the orbit itself ends there.

Truth from outside the code: the one-sided stop's linear response reaches its
stop where ``F / |1 - w^2 + i c w| = g`` (closed form; the orbit goes on past
it, in contact); the bearing rotor of ``scenes/rotor_f0_05.yaml`` stays in
contact with its casing on its harmonic branch (with 40 harmonics the branch
runs through the whole range without a grazing point), while its
1/2-subharmonic ends where the bearing starts to bounce (w = 2.1478..2.1482
and 2.1856, docs/theory/events.md).
"""

import json
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import brentq

from contin.app.cli import main
from contin.app.runner import run_scene
from contin.output.results import read_csv
from contin.scene.parse import parse_scene
from contact_scenes import jeffcott

ROOT = Path(__file__).resolve().parents[2]

#: the Jeffcott rotor pressed on its casing, driven by its unbalance; three harmonics draw it bouncing
JEFFCOTT = jeffcott("""\
analysis:
  type: frequency_response
  parameter: w
  range: [0.9, 1.3]
  start_from: linear
  harmonics: 3
  samples: 64
  stability: none
output: {plots: false}
""")


def test_a_grazing_end_drawn_by_too_few_harmonics_makes_the_run_incomplete(tmp_path):
    s = run_scene(parse_scene(JEFFCOTT), tmp_path / "out", progress=False)
    (b,) = s["analysis"]["branches"]
    assert b["status"] == "boundary"
    assert s["status"] == "incomplete"
    (line,) = s["shortfalls"]
    graz = read_csv(tmp_path / "out" / "special_points.csv")
    wg = float(graz["w"][list(graz["kind"]).index("grazing")])
    assert 1.10 < wg < 1.13
    # at H' = 11 Newton does not converge from the padded three-harmonic orbit: not confirmed, a shortfall
    assert line.startswith(f"branch 0 (nu=1) ended at a grazing point at w={wg:.10g} that harmonics 3 may not "
                           "resolve (at H'=11 Newton did not converge there")
    assert line.endswith(f"raise analysis.harmonics; w in [{wg:.10g}, 1.3] not covered")
    assert b["end"] == "truncation" and b["uncovered"] == pytest.approx([wg, 1.3])
    assert b["end_check"]["verdict"] == "truncation" and b["end_check"]["check_harmonics"] == 11


def test_a_grazing_end_that_more_harmonics_confirm_stays_an_end_as_asked(tmp_path):
    # the same rotor with twelve harmonics, past its fold (w ~ 1.86) and back: the bearing starts to bounce
    # at w ~ 1.8206, where twenty harmonics put it too (1.8205): no orbit goes on past it at these harmonics
    text = (JEFFCOTT.replace("range: [0.9, 1.3]", "range: [1.8, 1.9]").replace("harmonics: 3", "harmonics: 12")
            .replace("samples: 64", "samples: 128"))
    s = run_scene(parse_scene(text), tmp_path / "out", progress=False)
    (b,) = s["analysis"]["branches"]
    assert b["status"] == "boundary" and s["status"] == "complete" and s["shortfalls"] == []
    check = b["end_check"]
    assert check["verdict"] == "grazing" and 1.82 < check["parameter"] < 1.8215
    assert check["check_harmonics"] == 24 and check["change"] < 0.05 and "end" not in b


@pytest.mark.slow
def test_a_stiff_stops_grazing_end_is_a_shortfall_with_the_uncovered_interval(tmp_path):
    # the gap oscillator with a one-sided stop of stiffness 1e8: the branch stopped at the contact onset
    # and said complete, leaving (0.897, 3] uncovered
    out = tmp_path / "out"
    code = main(["run", str(ROOT / "scenes/gap_oscillator.yaml"), "-o", str(out), "-q", "--set",
                 "model.forces=[{type: gap, dof: x, clearance: g, stiffness: 1.0e8, damping: 0, sides: '+'}]"])
    assert code == 1
    wg = brentq(lambda w: 0.2 / np.hypot(1 - w * w, 0.05 * w) - 1.0, 0.5, 0.99)
    s = json.loads((out / "summary.json").read_text())
    (b,) = s["analysis"]["branches"]
    assert s["status"] == "incomplete" and b["end"] == "numerics"
    assert b["uncovered"][0] == pytest.approx(wg, abs=1e-7) and b["uncovered"][1] == 3.0
    (line,) = s["shortfalls"]
    assert "ended at a grazing point at w=0.89727" in line and "the continuation could not pass" in line
    assert "w in [0.89727" in line and ", 3] not covered" in line


@pytest.mark.slow
def test_the_rotor_at_three_harmonics_is_incomplete_at_its_spurious_grazing_point(tmp_path):
    out = tmp_path / "out"
    code = main(["run", str(ROOT / "scenes/rotor_f0_05.yaml"), "-o", str(out), "-q", "--set",
                 "analysis.harmonics=3"])
    assert code == 1
    s = json.loads((out / "summary.json").read_text())
    b0, b1, b2 = s["analysis"]["branches"]
    assert b0["end"] == "truncation" and 1.64 <= b0["end_check"]["parameter"] <= 1.72
    assert b0["uncovered"][1] == 2.6
    (line,) = s["shortfalls"]
    # at H' = 11 Newton does not converge from the padded orbit: the end is not confirmed (nor is it at H = 40,
    # whose harmonic branch has no grazing there: tests/models/test_rotor_floquet.py)
    assert line.startswith("branch 0 (nu=1) ended at a grazing point at w=1.6") and "harmonics 3 may not" in line
    # the subharmonic branches keep their own 80 harmonics: their grazing ends are the orbit's
    assert b1["end_check"]["verdict"] == b2["end_check"]["verdict"] == "grazing"


@pytest.mark.slow
def test_the_rotors_subharmonic_grazing_ends_are_accepted(scene_run):
    s = json.loads((scene_run("rotor_f0_05.yaml") / "summary.json").read_text())
    assert s["status"] == "complete" and not s["shortfalls"]
    ends = {b["branch"]: b.get("end_check") for b in s["analysis"]["branches"]}
    assert ends[0] is None  # range_end: nothing to check
    assert ends[1]["verdict"] == "grazing" and ends[1]["parameter"] == pytest.approx(2.1855759, abs=1e-6)
    assert ends[2]["verdict"] == "grazing" and ends[2]["parameter"] == pytest.approx(2.1482376, abs=1e-6)
    # solved again with 160 harmonics the bearing's switching function moves by well under the tolerance
    assert ends[1]["check_harmonics"] == ends[2]["check_harmonics"] == 160
    assert ends[1]["change"] < 0.01 and ends[2]["change"] < 0.05
