"""A frequency response that stops at a grazing point harmonic balance cannot pass is ``incomplete`` (the rest of
its range uncovered), unless the branch is handed to shooting there (``analysis.method: auto``).

Truth from outside the code: the one-sided stop's linear response reaches its
stop where ``F / |1 - w^2 + i c w| = g`` (closed form; the orbit goes on past
it, in contact); the bearing rotor of ``scenes/rotor_f0_05.yaml`` stays in
contact with its casing on its harmonic branch (with 40 harmonics the branch
runs through the whole range without a grazing point), while its
1/2-subharmonic ends where the bearing starts to bounce (w = 2.1478..2.1482
and 2.1856, docs/theory/events.md).
"""

import csv
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
  method: hb
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


def test_a_grazing_end_that_more_harmonics_confirm_still_leaves_its_range_uncovered(tmp_path):
    # the same rotor with twelve harmonics, past its fold (w ~ 1.86) and back: the bearing starts to bounce
    # at w ~ 1.8206, where twenty harmonics put it too (1.8205): harmonic balance goes no further, and the
    # rest of the range is not covered (once an accepted end; shooting passes it: analysis.method auto)
    text = (JEFFCOTT.replace("range: [0.9, 1.3]", "range: [1.8, 1.9]").replace("harmonics: 3", "harmonics: 12")
            .replace("samples: 64", "samples: 128"))
    s = run_scene(parse_scene(text), tmp_path / "out", progress=False)
    (b,) = s["analysis"]["branches"]
    assert b["status"] == "boundary" and s["status"] == "incomplete"
    check = b["end_check"]
    assert check["verdict"] == "grazing" and 1.82 < check["parameter"] < 1.8215
    assert check["check_harmonics"] == 24 and check["change"] < 0.05 and "end" not in b
    last = float(read_csv(tmp_path / "out" / "branches.csv")["w"][-1])  # running down, past the grazing point
    assert 1.8 < last < check["parameter"] and b["uncovered"] == [1.8, last]
    (line,) = s["shortfalls"]
    assert line.startswith("branch 0 (nu=1) stopped at a point it cannot pass (the branch cannot pass the grazing")
    assert line.endswith(f"w in [1.8, {last:.10g}] not covered; to go on: analysis.method: auto or shooting")


@pytest.mark.slow
def test_a_stiff_stops_grazing_end_is_a_shortfall_with_the_uncovered_interval(tmp_path):
    # the gap oscillator with a one-sided stop of stiffness 1e8: the branch stopped at the contact onset
    # and said complete, leaving (0.897, 3] uncovered
    out = tmp_path / "out"
    code = main(["run", str(ROOT / "scenes/gap_oscillator.yaml"), "-o", str(out), "-q", "--set",
                 "model.forces=[{type: gap, dof: x, clearance: g, stiffness: 1.0e8, damping: 0, sides: '+'}]",
                 "--set", "analysis.method=hb"])
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
                 "analysis.harmonics=3", "--set", "analysis.method=hb"])
    assert code == 1
    s = json.loads((out / "summary.json").read_text())
    b0, b1, b2 = s["analysis"]["branches"]
    assert b0["end"] == "truncation" and 1.64 <= b0["end_check"]["parameter"] <= 1.72
    assert b0["uncovered"][1] == 2.6
    # the subharmonic halves stop at grazing points harmonic balance cannot pass: no longer an end as asked
    (line,) = [r for r in s["shortfalls"] if r.startswith("branch 0 ")]
    rest = [r for r in s["shortfalls"] if r != line]
    assert len(rest) == 2 and all("stopped at a point it cannot pass" in r for r in rest)
    # at H' = 11 Newton does not converge from the padded orbit: the end is not confirmed (nor is it at H = 40,
    # whose harmonic branch has no grazing there: tests/models/test_rotor_floquet.py)
    assert line.startswith("branch 0 (nu=1) ended at a grazing point at w=1.6") and "harmonics 3 may not" in line
    # the subharmonic branches keep their own 80 harmonics: their grazing ends are the orbit's
    assert b1["end_check"]["verdict"] == b2["end_check"]["verdict"] == "grazing"


@pytest.mark.slow
def test_the_rotors_subharmonic_halves_are_handed_to_shooting_at_their_grazing_points(scene_run):
    s = json.loads((scene_run("rotor_f0_05.yaml") / "summary.json").read_text())
    b = {x["branch"]: x for x in s["analysis"]["branches"]}
    assert b[0]["status"] == "range_end" and b[0]["method"] == "hb"
    # harmonic balance follows each half from w = 2.16 to where the bearing starts bouncing
    assert b[1]["end"] == b[2]["end"] == "handover" and (b[1]["handed_over_to"], b[2]["handed_over_to"]) == (3, 4)
    # (their own uncovered intervals start at their last stored points, beside the grazing points)
    assert b[1]["uncovered"][1] == pytest.approx(2.1855759, abs=2e-5)
    assert b[2]["uncovered"] == [1.6, pytest.approx(2.1477848, abs=2e-5)]
    # shooting takes the upper half on through the bouncing motion back to the harmonic branch at its period
    # doubling (2.2063551 by harmonic balance on the harmonic branch, in contact there: docs/tutorials/rotor.md)
    assert b[3]["method"] == "shooting" and b[3]["status"] == "closed_loop"
    assert b[3]["returned"]["parameter"] == pytest.approx(2.2063551, abs=1e-4)


@pytest.mark.slow
def test_the_rotors_subharmonic_reaches_both_period_doublings(scene_run):
    """The issue's figures: the nu = 2 branch joins both period doublings of the harmonic branch, its fold E,
    Neimark-Sacker point and fold C where the shooting reference has them (scripts/figures/rotor/
    rotor_subharmonic_shooting.py, central-difference monodromies: docs/tutorials/rotor.md), to 1e-4."""
    out = scene_run("rotor_f0_05.yaml")
    s = json.loads((out / "summary.json").read_text())
    assert s["status"] == "complete" and not s["shortfalls"]
    returned = sorted(x["returned"]["parameter"] for x in s["analysis"]["branches"] if "returned" in x)
    assert returned == pytest.approx([2.14733105, 2.20635483], abs=1e-4)
    with open(out / "special_points.csv") as f:
        points = [(r["kind"], float(r["w"])) for r in csv.DictReader(f) if r["branch"] != "0"]  # the nu = 2 ones
    for kind, ref in (("fold", 2.19495939), ("ns", 2.14977936), ("fold", 2.14377192)):
        assert min(abs(w - ref) for k, w in points if k == kind) < 1e-4, (kind, ref)
