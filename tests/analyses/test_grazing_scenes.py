"""The grazing example scenes end to end, against the event-driven scipy reference.

``scenes/impact_oscillator.yaml`` (one dof, a stiff one-sided stop) and
``scenes/chain_stop_grazing.yaml`` (two masses, a cubic spring and a stop on
the second) have harmonic branches that graze their stop inside the range,
where harmonic balance cannot go on. They are run as a user runs them
(``contin run``, the method ``auto`` of the scene, or ``--set
analysis.method=shooting``), and what they store is compared with
``tests/timedomain/impact_reference.py``: ``solve_ivp`` (DOP853) with located
switches and Newton, which shares no code with contin. The truths:

- every stored shooting point's state ``(x, x')`` at ``t = 0`` (``state.jsonl``)
  against the reference's periodic orbit at the same ``w`` (1e-6), and its
  ``h0``/``h1`` columns against the reference's Fourier coefficients (1e-6);
- the grazing point against the frequency where the reference's contact-free
  orbit touches the stop (for one dof also the closed form ``F / |1 - w^2 +
  2 i zeta w| = g``), 1e-6;
- the whole range covered, ``complete``, nothing uncovered.
"""

import json
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import brentq

from contin.app.cli import main
from contin.output.checkpoint import read_records
from contin.output.results import read_csv
from tests.timedomain import impact_reference as ref

ROOT = Path(__file__).resolve().parents[2]
IMPACT = ROOT / "scenes" / "impact_oscillator.yaml"
CHAIN = ROOT / "scenes" / "chain_stop_grazing.yaml"
#: the impact oscillator's parameters (scenes/impact_oscillator.yaml)
ZETA, KS, G, F = 0.05, 500.0, 1.0, 0.3
W_GRAZE = ref.impact_grazing_closed_form(ZETA, G, F)[0]  # 0.84386793801...


def run(scene, out, *sets):
    args = ["run", str(scene), "-o", str(out), "-q"]
    for s in sets:
        args += ["--set", s]
    code = main(args)
    summary = json.loads((out / "summary.json").read_text())
    return code, summary, read_csv(out / "branches.csv"), read_csv(out / "special_points.csv")


def shooting_points(out, summary):
    """``[(branch, row, w, z0)]`` of the branches followed by shooting: their unknowns' first state."""
    methods = {b["branch"]: b.get("method") for b in summary["analysis"]["branches"]}
    out_ = []
    for rec in read_records(out / "state.jsonl"):
        if rec["type"] == "point" and methods.get(rec["branch"]) == "shooting":
            out_.append((rec["branch"], rec["row"], float(rec["lam"]), np.asarray(rec["u"], dtype=float)))
    return out_


def check_points(system, points, rows, n, dofs):
    """Each point's state against the reference orbit at its ``w`` (1e-6), and its h0, h1 columns."""
    assert points
    for branch, row, w, u in points:
        z = u[:2 * n]
        orbit = ref.periodic_orbit(system, w, z)
        np.testing.assert_allclose(z, orbit.z, rtol=0, atol=1e-6, err_msg=f"branch {branch} row {row} w={w}")
        i = row  # the point's row in branches.csv
        assert rows["branch"][i] == branch and rows["w"][i] == pytest.approx(w, rel=1e-12)
        for d, name in enumerate(dofs):
            a, b = ref.harmonics(system, orbit, d, 1)
            assert rows[f"h0_{name}"][i] == pytest.approx(abs(a[0]), abs=1e-6)
            assert rows[f"h1_{name}"][i] == pytest.approx(math.hypot(a[1], b[1]), abs=1e-6)


def covered(rows, lo, hi):
    """Whether the branches' parameter intervals (each branch a connected curve) together cover ``[lo, hi]``."""
    spans = sorted((rows["w"][rows["branch"] == b].min(), rows["w"][rows["branch"] == b].max())
                   for b in np.unique(rows["branch"]))
    reach = lo
    for a, b in spans:
        if a > reach + 1e-12:
            break
        reach = max(reach, b)
    return spans[0][0] == pytest.approx(lo, abs=1e-12) and reach == pytest.approx(hi, abs=1e-12)


# --- the impact oscillator --------------------------------------------------------------------------------


@pytest.mark.slow
def test_the_impact_scene_grazes_where_harmonic_balance_ends(tmp_path):
    """With method hb the branch ends at the grazing point (why the scene needs shooting): exit 1, uncovered."""
    code, summary, rows, sp = run(IMPACT, tmp_path / "hb", "analysis.method=hb")
    assert code == 1 and summary["status"] != "complete"
    g = sp["w"][sp["kind"] == "grazing"]
    assert g.size == 1 and g[0] == pytest.approx(W_GRAZE, abs=1e-6)
    assert rows["w"].max() < 0.85
    assert any("0.84386" in line and "not covered" in line for line in summary["shortfalls"])


def test_the_impact_scene_passes_grazing_by_auto(tmp_path):
    """The scene as shipped: harmonic balance to the grazing point, shooting beyond it, to w = 1."""
    out = tmp_path / "auto"
    code, summary, rows, sp = run(IMPACT, out)
    assert code == 0 and summary["status"] == "complete" and summary["shortfalls"] == []
    assert covered(rows, 0.5, 1.0)
    assert {b.get("method") for b in summary["analysis"]["branches"]} == {"hb", "shooting"}
    # the grazing point, where harmonic balance hands over, is the closed form's
    g = sp["w"][sp["kind"] == "grazing"]
    assert g.size >= 1 and np.all(np.abs(g - W_GRAZE) <= 1e-6)
    # beyond it the orbit bounces on the stop: its largest x is above the gap
    beyond = rows["w"] > W_GRAZE + 1e-3
    assert beyond.sum() >= 3 and np.all(rows["max_x"][beyond] > G)
    # the first points past the grazing point and the last against the reference
    pts = shooting_points(out, summary)
    system = ref.impact_oscillator(ZETA, KS, G, F)
    check_points(system, [pts[1], pts[2], pts[-1]], rows, 1, ["x"])


@pytest.mark.slow
def test_the_impact_oscillator_by_shooting_equals_the_reference_at_every_point(tmp_path):
    """method: shooting over the whole range: every point, the grazing point and the period doublings."""
    out = tmp_path / "shooting"
    code, summary, rows, sp = run(IMPACT, out, "analysis.method=shooting")
    assert code == 0 and summary["status"] == "complete" and summary["shortfalls"] == []
    assert covered(rows, 0.5, 1.0)
    assert {b.get("method") for b in summary["analysis"]["branches"]} == {"shooting"}
    system = ref.impact_oscillator(ZETA, KS, G, F)
    check_points(system, shooting_points(out, summary), rows, 1, ["x"])
    # the grazing point located by the branch against the reference's own (Brent on max x - g)
    w_g = ref.grazing_frequency(system, 0.8438, 0.844, ref.linear_orbit_state(system, 0.8438))
    g = sp["w"][sp["kind"] == "grazing"]
    assert g.size == 1 and g[0] == pytest.approx(w_g, abs=1e-6)
    # the period doublings against the reference's flip test det(Phi + I) = 0
    pds = np.sort(sp["w"][sp["kind"] == "pd"])
    assert pds.size == 2
    for w_pd in pds:
        z = ref.periodic_orbit(system, w_pd, ref.linear_orbit_state(system, 0.84) if w_pd < 0.85 else [0.85, 0.6]).z

        def flip(w, z=z):
            return np.linalg.det(ref.periodic_orbit(system, w, z).monodromy + np.eye(2))

        lo, hi = max(w_pd - 2e-3, W_GRAZE + 1e-9), w_pd + 2e-3
        assert brentq(flip, lo, hi, xtol=1e-12) == pytest.approx(w_pd, abs=1e-6)


@pytest.mark.slow
def test_every_shooting_point_of_the_impact_auto_run_equals_the_reference(tmp_path):
    out = tmp_path / "auto"
    code, summary, rows, _ = run(IMPACT, out)
    assert code == 0
    check_points(ref.impact_oscillator(ZETA, KS, G, F), shooting_points(out, summary), rows, 1, ["x"])


# --- the chain with a stop ----------------------------------------------------------------------------------


def test_the_chain_by_shooting_on_its_stop_equals_the_reference(tmp_path):
    """A stretch of the chain's range where x2 bounces on its stop, by shooting from a settled simulation:
    its first and last points against the reference (1e-6)."""
    out = tmp_path / "chain"
    code, summary, rows, _ = run(CHAIN, out, "analysis.method=shooting", "analysis.range=[1.65, 1.68]")
    assert code == 0 and summary["status"] == "complete"
    assert covered(rows, 1.65, 1.68)
    assert np.all(rows["max_x2"] > 0.3)  # in contact all along
    pts = shooting_points(out, summary)
    check_points(ref.chain_stop(), [pts[0], pts[-1]], rows, 2, ["x1", "x2"])


@pytest.mark.slow
def test_the_chain_covers_its_whole_range_with_the_default_method(scene_run):
    """The chain of the scene, nothing set: complete, [0.5, 2] covered, two shooting points against the reference.
    The run (exit status 0 asserted there) is the session's one of the shipped scene, shared with the connection
    check of tests/hard/test_invariants.py."""
    out = scene_run(CHAIN.name)
    summary = json.loads((out / "summary.json").read_text())
    rows = read_csv(out / "branches.csv")
    assert summary["status"] == "complete" and summary["shortfalls"] == []
    # a branch that leaves part of the range uncovered only where another took it over
    assert all(not b.get("uncovered") or b.get("handed_over_to") is not None for b in summary["analysis"]["branches"])
    assert covered(rows, 0.5, 2.0)
    pts = shooting_points(out, summary)
    system = ref.chain_stop()
    # two points: one bouncing on the stop near the grazing point, one farthest from it
    near = min(pts, key=lambda p: abs(p[2] - 0.83))
    far = max(pts, key=lambda p: p[2])
    check_points(system, [near, far], rows, 2, ["x1", "x2"])
