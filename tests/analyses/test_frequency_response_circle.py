"""Tori as invariant circles in a scene: ``switch: [ns]`` on a shooting branch (scenes/van_der_pol_circle.yaml).

Truth from outside the code: the same tori of the two-frequency balance
(:mod:`contin.hb.torus`, H1 = H2 = 12), itself checked against averaging and
simulation (docs/validation/van-der-pol.md), at the range ends both reach
exactly; the torus' normal Lyapunov exponent against Liouville's mean
divergence ``mu T (1 - <x^2>)`` over that balance's torus (for a one-dof
system the tangential exponent is zero, so the normal one is the whole sum).
"""

import json
import math
from pathlib import Path

import numpy as np
import pytest

from contin.app.cli import main
from contin.bifurcation.diagram import follow
from contin.bifurcation.torus_branch import TorusSettings
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.hb.torus import TorusOptions, torus_measures
from contin.output.results import read_csv
from van_der_pol_model import MU, vdp_model

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    out = tmp_path_factory.mktemp("circle")
    assert main(["run", str(ROOT / "scenes/van_der_pol_circle.yaml"), "-o", str(out), "-q",
                 "--set", "output.plots=false"]) == 0
    hb = HarmonicBalance(vdp_model(), "w", HBOptions(5))
    d = follow(hb, hb.linear_solution(0.9), 0.9, (0.8, 1.2), {"ds": 0.02}, stability={"method": "hill"},
               switch=("ns",), torus=TorusSettings(TorusOptions(12, 12), stability="none"))
    return out, d


def test_the_circles_rows_are_the_two_frequency_balances_tori_at_the_range_ends(runs):
    out, d = runs
    rows = read_csv(out / "branches.csv")
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "complete"
    tori = [b for b in summary["analysis"]["branches"] if b.get("torus")]
    assert len(tori) == 2 and all(b["torus"]["circle"] and b["torus"]["points"] == 21 for b in tori)
    assert all(b["status"] == "range_end" for b in summary["analysis"]["branches"])
    for j in (1, 2):
        qb, qp = d.branches[j], d.problems[j]
        ref = torus_measures(qp, qb.unknowns[-1], float(qb.parameter[-1]), ["x"], 5)
        mine = np.flatnonzero(rows["branch"] == j)[-1]
        assert rows["w"][mine] == pytest.approx(float(qb.parameter[-1]), abs=1e-12)
        # measured: frequency2 3e-11, the lines 7e-11, amp 7.5e-5 (the balance's 4x grid under-reads the extremes)
        assert rows["frequency2"][mine] == pytest.approx(ref["frequency2"], abs=1e-8)
        for key in ("free_x", "forced_x", "h1_x", "h3_x", "rms_x"):
            assert rows[key][mine] == pytest.approx(ref[key], abs=1e-7), key
        assert rows["amp_x"][mine] == pytest.approx(ref["amp_x"], abs=2e-4)
        # stable by the normal exponent, which meets Liouville's mean divergence over the balance's torus
        x = qp.samples_of(qb.unknowns[-1], float(qb.parameter[-1]))[0]
        divergence = MU * (2 * math.pi / rows["w"][mine]) * (1.0 - float(np.mean(np.asarray(x) ** 2)))
        assert rows["stable"][mine] == "true" or rows["stable"][mine] is True
        assert math.log(rows["max_multiplier"][mine]) == pytest.approx(divergence, abs=1e-3)


def test_the_circles_start_at_the_shooting_branchs_neimark_sacker_points(runs):
    out, d = runs
    sp = read_csv(out / "special_points.csv")
    ns = sorted(float(w) for b, k, w in zip(sp["branch"], sp["kind"], sp["w"]) if b == 0 and k == "ns")
    ref = sorted(float(s.parameter) for s in d.branches[0].special_points if s.kind.value == "ns")
    np.testing.assert_allclose(ns, ref, atol=1e-8)  # the flow's and Hill's Neimark-Sacker points
    rows = read_csv(out / "branches.csv")
    for j, w_ns in zip((1, 2), ns):
        first = np.flatnonzero(rows["branch"] == j)[0]
        assert rows["w"][first] == pytest.approx(w_ns, abs=1e-6)


TORUS_START = (ROOT / "scenes/van_der_pol_circle.yaml").read_text().split("analysis:")[0] + """\
analysis:
  type: frequency_response
  parameter: w
  range: [0.8, 0.9]
  start: 0.85
  solution: torus
  start_from: simulation
  start_simulation: {transient: 100}
  both_ways: true
  method: shooting
  torus: {points: 21}
output: {measure: amp_x, plots: false}
"""


def test_a_torus_start_from_simulation_reaches_the_balances_torus(tmp_path, runs):
    """``solution: torus``: the circle fitted to a simulation's sections at w = 0.85 (contin.analyses.torus_start),
    followed both ways; at w = 0.8 the same torus as the two-frequency balance's."""
    _, d = runs
    scene = tmp_path / "s.yaml"
    scene.write_text(TORUS_START)
    assert main(["run", str(scene), "-o", str(tmp_path / "out"), "-q"]) == 0
    rows = read_csv(tmp_path / "out/branches.csv")
    summary = json.loads((tmp_path / "out/summary.json").read_text())
    assert [b["status"] for b in summary["analysis"]["branches"]] == ["range_end", "range_end"]
    assert all(b["torus"]["circle"] for b in summary["analysis"]["branches"])
    qb, qp = d.branches[1], d.problems[1]
    ref = torus_measures(qp, qb.unknowns[-1], float(qb.parameter[-1]), ["x"], 5)
    i = int(np.flatnonzero(np.asarray(rows["w"]) == 0.8)[0])
    assert rows["frequency2"][i] == pytest.approx(ref["frequency2"], abs=1e-8)
    assert rows["free_x"][i] == pytest.approx(ref["free_x"], abs=1e-7)


def test_a_torus_start_in_natural_steps_reaches_the_balances_torus(tmp_path, runs):
    """``torus: {continuation: natural}``: the same start followed in natural steps of w (contin.bifurcation.
    circle_natural): at w = 0.8 the two-frequency balance's torus again, the steps as the scene sets them."""
    _, d = runs
    scene = tmp_path / "s.yaml"
    scene.write_text(TORUS_START.replace("torus: {points: 21}", "torus: {points: 21, continuation: natural}\n"
                                         "  continuation: {ds: 0.01, ds_max: 0.02, ds_min: 1.0e-3}"))
    assert main(["run", str(scene), "-o", str(tmp_path / "out"), "-q"]) == 0
    rows = read_csv(tmp_path / "out/branches.csv")
    branches = json.loads((tmp_path / "out/summary.json").read_text())["analysis"]["branches"]
    assert [b["status"] for b in branches] == ["range_end", "range_end"]
    assert all(b["torus"]["continuation"] == "natural" for b in branches)
    w = np.asarray(rows["w"])
    assert np.all(np.abs(np.diff(w[rows["branch"] == 1])) <= 0.02 + 1e-12)
    qb, qp = d.branches[1], d.problems[1]
    ref = torus_measures(qp, qb.unknowns[-1], float(qb.parameter[-1]), ["x"], 5)
    i = int(np.flatnonzero(w == 0.8)[0])
    assert rows["frequency2"][i] == pytest.approx(ref["frequency2"], abs=1e-8)
    assert rows["free_x"][i] == pytest.approx(ref["free_x"], abs=1e-7)


def test_tori_born_at_neimark_sacker_points_grow_in_natural_steps_to_the_balances_tori(tmp_path, capsys, runs):
    """``switch: [ns]`` with ``torus: {continuation: natural}``: each circle grows from its Neimark-Sacker point
    by steps at a fixed size until ``w`` has moved (the side of the point the torus lies on is not known
    before) and goes on in steps of ``w`` to the range's end, onto the two-frequency balance's torus there."""
    _, d = runs
    scene = tmp_path / "s.yaml"
    scene.write_text((ROOT / "scenes/van_der_pol_circle.yaml").read_text().replace(
        "torus: {points: 21}", "torus: {points: 21, continuation: natural}"))
    assert main(["run", str(scene), "-o", str(tmp_path / "out"), "-q", "--set", "output.plots=false"]) == 0
    rows = read_csv(tmp_path / "out/branches.csv")
    branches = json.loads((tmp_path / "out/summary.json").read_text())["analysis"]["branches"]
    assert [b["status"] for b in branches] == ["range_end"] * 3
    for j in (1, 2):
        assert branches[j]["torus"]["continuation"] == "natural"
        qb, qp = d.branches[j], d.problems[j]
        mine = np.flatnonzero(rows["branch"] == j)
        w = np.asarray(rows["w"])[mine]
        assert np.all(np.diff(w) * np.sign(w[-1] - w[0]) > 0)  # away from the point, one way
        assert w[-1] == pytest.approx(float(qb.parameter[-1]), abs=1e-12)
        ref = torus_measures(qp, qb.unknowns[-1], float(qb.parameter[-1]), ["x"], 5)
        assert rows["frequency2"][mine[-1]] == pytest.approx(ref["frequency2"], abs=1e-8)
        assert rows["free_x"][mine[-1]] == pytest.approx(ref["free_x"], abs=1e-7)
    scene.write_text(TORUS_START)
    assert main(["run", str(scene), "-o", str(tmp_path / "out2"), "-q", "--set", "analysis.torus.continuation=nat"]) \
        == 2
    assert "analysis.torus" in capsys.readouterr().err and not (tmp_path / "out2").exists()


@pytest.mark.parametrize("change, key, expected", [
    ("start_from: simulation", "analysis.start_from", "simulation with solution: torus"),
    ("method: shooting", "analysis.method", "shooting or auto with solution: torus"),
    ("both_ways: true", "analysis.switch", "no switch with solution: torus"),
])
def test_a_torus_start_says_what_it_needs(tmp_path, capsys, change, key, expected):
    bad = {"start_from: simulation": "start_from: model", "method: shooting": "method: hb",
           "both_ways: true": "both_ways: true\n  switch: [ns]"}[change]
    scene = tmp_path / "s.yaml"
    scene.write_text(TORUS_START.replace(change, bad))
    assert main(["run", str(scene), "-o", str(tmp_path / "out"), "-q"]) == 2
    err = capsys.readouterr().err
    assert key in err and expected in err
    assert not (tmp_path / "out").exists()


@pytest.mark.slow
@pytest.mark.parametrize("steps", ["arclength", "natural"])
def test_a_torus_start_killed_midway_resumes_to_the_same_rows(tmp_path, steps):
    """Killed inside the first circle branch of a torus start: the resumed run fits the same circle again (the
    same simulation, the same anchor), takes the branch up from its last point (in natural steps: with the same
    step and chord factorisation) and ends with the rows of the uninterrupted run."""
    import signal
    import subprocess
    import sys
    import time

    scene = tmp_path / "s.yaml"
    natural = "torus: {points: 21, continuation: natural}\n  continuation: {ds: 0.002, ds_max: 0.002}"
    scene.write_text(TORUS_START if steps == "arclength" else TORUS_START.replace("torus: {points: 21}", natural))
    ref = tmp_path / "ref"
    assert main(["run", str(scene), "-o", str(ref), "-q"]) == 0
    out = tmp_path / "run"
    proc = subprocess.Popen([sys.executable, "-m", "contin", "run", str(scene), "-o", str(out), "-q"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)

    def rows():
        try:
            return max(0, sum(1 for _ in open(out / "branches.csv")) - 1)
        except FileNotFoundError:
            return 0

    t0 = time.time()
    while rows() < 6 and proc.poll() is None and time.time() - t0 < 120:
        time.sleep(0.005)
    assert proc.poll() is None, "the run finished before it could be killed"
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    assert main(["run", str(scene), "-o", str(out), "-q", "--resume"]) == 0
    a, b = read_csv(ref / "branches.csv"), read_csv(out / "branches.csv")
    assert len(a["branch"]) == len(b["branch"])
    for col in ("w", "frequency2", "free_x", "amp_x", "max_multiplier"):
        np.testing.assert_allclose(b[col], a[col], rtol=1e-9, atol=1e-12, err_msg=col, equal_nan=True)


def test_check_says_the_tori_are_invariant_circles(tmp_path, capsys):
    assert main(["check", str(ROOT / "scenes/van_der_pol_circle.yaml")]) == 0
    assert "tori: invariant circles of 21 points (1024 steps a period); stability by their Lyapunov exponents" \
        in capsys.readouterr().out
    scene = tmp_path / "s.yaml"
    scene.write_text(TORUS_START)
    assert main(["check", str(scene)]) == 0
    assert "; the first fitted to a simulation" in capsys.readouterr().out
