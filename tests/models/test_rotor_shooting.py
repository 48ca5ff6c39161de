"""Bearing rotor (seed 001): the 1/2-subharmonic branch of the equations of motion, by shooting.

The branch is switched at a period doubling of the integrated flow's harmonic orbit
(contin.timedomain.shooting.period_doubling_start) and followed by the continuation engine on the
flow map. The references are independent of it: the converged harmonic balance (H = 80
harmonics of w/2) where the bearing stays on its casing, the period doublings located
by a scan of the harmonic orbit, and a time simulation from rest.
"""

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from contin.model.catalog import build_model
from contin.output.results import read_csv
from contin.engine.continuation import ContinuationOptions, continuation
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.timedomain.shooting import (
    ShootingOptions,
    ShootingProblem,
    ShootingStability,
    period_doubling_scan,
    period_doubling_start,
)
from contin.timedomain.simulation import simulate
from contin.stability import orbit_state, stability_events
from contin.bifurcation.start import simulation_start

ROOT = Path(__file__).resolve().parents[2]
HARMONIC = ShootingOptions(steps_per_period=4096)
# the turn test relaxed for the corners where the bearing starts or stops bouncing (grazing)
STEPS = dict(ds=0.01, ds_max=0.05, newton_tol=1e-9, max_angle_deg=89.0)


@pytest.fixture(scope="module")
def model():
    return build_model("bearing_rotor", {"f0": 0.5})


def period_doubling(model, grid, xtol=1e-10):
    hb = HarmonicBalance(model, "w", HBOptions(harmonics=40, samples=1024, crossings="none"))
    u0 = model.start(hb, grid[0])
    scan = period_doubling_scan(model, {}, "w", grid, orbit_state(hb, u0, grid[0], 0.0), HARMONIC, xtol=xtol)
    assert scan.status == "complete" and len(scan.points) == 1
    return scan.points[0]


def radius(model, w, z):
    """+w/2 forward whirl radius of the disc on the period-2 orbit through z."""
    run = simulate(model, {"w": w}, z[:4], z[4:], periods=2, steps_per_period=4096, record_every=1)
    t, x = run.t[:-1], run.x[:-1]
    return abs(np.mean((x[:, 0] + 1j * x[:, 1]) * np.exp(-0.5j * w * t)))


def switched(model, pd, callback=None, **kw):
    w = pd.params["w"]
    doubled, u0, tangent = period_doubling_start(ShootingProblem(model, "w", options=HARMONIC), pd.state, w)
    mon = ShootingStability(doubled)
    return continuation(doubled, u0, w, (2.1, 2.25), ContinuationOptions(**STEPS, **kw), parameter_name="w",
                        monitors=[mon], events=stability_events(mon), tangent=tangent, solve_start=False,
                        callback=callback)


@pytest.mark.slow  # by default the rotor's shooting period doublings are checked against the harmonic balance (tests/test_shooting.py)
def test_branch_switched_at_F_is_the_converged_harmonic_balance_branch(model):
    """Near F the bearing stays on its casing (the gap closes to 6e-6): both methods give one orbit.

    Measured state differences at the three points compared: 2.5e-6, 2.4e-7, 2.0e-6 with H = 80 harmonics
    of w/2 (the bearing's velocity converges last), 1.5e-7, 4.6e-8, 1.4e-7 with H = 120, the same with
    H = 160 (the integrator's share).
    """
    # located to 1e-8 (the branch's start; its points are converged on the flow each): 2.206354836, 2e-9 from
    # the location to 1e-10
    pd = period_doubling(model, np.linspace(2.200, 2.212, 3), xtol=1e-8)
    assert abs(pd.params["w"] - 2.2063548) < 1e-6
    br = switched(model, pd, max_points=10)
    assert len(br) == 10 and br.status.value == "max_points"
    hb = HarmonicBalance(model, "w", HBOptions(harmonics=120, subharmonic=2, samples=2048, crossings="none"))
    radii = []
    assert br.unknowns.shape[1] == 2 * 8  # the doubled problem: two segments of one revolution, 8 states each
    # the harmonic balance's Newton at fixed w is singular at the period doubling and at the folds near F (its
    # answer there moves by 1e-6 to 7e-5): every other point 1e-4 or more from all of them
    singular = [pd.params["w"]] + [sp.parameter for sp in br.special_points if sp.kind.value == "fold"]
    away = [i for i in range(len(br)) if min(abs(br.parameter[i] - s) for s in singular) >= 1e-4][::2]
    assert len(singular) >= 2 and len(away) >= 3
    for point, w in zip(br.unknowns[away], br.parameter[away]):
        z = point[:8]  # the state at t = 0 (the first segment's start)
        # the harmonic balance's Newton from the Fourier series of the shooting orbit (two revolutions)
        u = simulation_start(hb, float(w), transient=2, x0=z[:4], v0=z[4:])
        np.testing.assert_allclose(orbit_state(hb, u, float(w), 0.0), z, atol=5e-7)
        radii.append(radius(model, float(w), z))
    assert radii[0] > 0.02 and np.all(np.diff(radii) > 0)  # a growing +w/2 whirl: a new branch
    assert not np.asarray(br.point_data["stable"]).any()  # unstable near F (part of the paper's EF)


@pytest.mark.slow
def test_fig4_script_follows_the_branch_from_F_to_D_through_E_and_C(tmp_path):
    """scripts/figures/rotor/rotor_subharmonic_shooting.py: the paper's F-E-C-B-D as one branch of the flow (about 8 minutes).

    From its result files: the branch leaves the harmonic orbit at F, passes the folds E and
    C, where the bearing bounces on its casing in between, and returns to the harmonic orbit
    at D, located independently by the scan; the orbit a time simulation from rest reaches at
    w = 2.16 lies on it, and each stretch's verdict holds over 400 revolutions of a time
    simulation.
    """
    out = subprocess.run([sys.executable, str(ROOT / "scripts" / "figures" / "rotor" / "rotor_subharmonic_shooting.py"), "-o",
                          str(tmp_path)], capture_output=True, text=True, timeout=3000)
    assert out.returncode == 0, out.stderr[-2000:]
    rows, special = read_csv(tmp_path / "branch.csv"), read_csv(tmp_path / "special_points.csv")
    d = float(re.search(r"period doubling D is at ([0-9.]+)", out.stdout).group(1))
    assert abs(rows["w"][-1] - d) < 1e-5 and rows["radius"][-1] < 0.02 and rows["radius"].max() > 1.4
    folds = special["w"][special["kind"] == "fold"]
    assert np.any(np.abs(folds - 2.19496) < 1e-4)  # E, the jump
    assert np.any((2.1435 < folds) & (folds < 2.1440))  # C
    assert (rows["stable"] == "True")[(rows["w"] > 2.155) & (rows["w"] < 2.19) & (rows["radius"] > 0.3)
                          & (rows["radius"] < 1.1)].all()  # C-E
    assert rows["contact_switches"].max() >= 20  # the bearing bounces on the way
    gap = float(re.search(r"settles on an orbit ([0-9.e+-]+) from the branch's", out.stdout).group(1))
    assert gap < 1e-7
    decided = set()
    for verdict, mu, end in re.findall(r"\((stable|unstable), largest multiplier ([0-9.]+)\): 400 revolutions from "
                                       r"1e-6 off the orbit end ([0-9.e+-]+)", out.stdout):
        # 400 revolutions tell only where the multiplier grows or damps the kick tenfold (1.0004^400 = 1.17 does not)
        if not 0.1 <= float(mu) ** 400 <= 10.0:
            assert (float(end) < 1e-6) == (verdict == "stable")
            decided.add(verdict)
    assert decided == {"stable", "unstable"}
