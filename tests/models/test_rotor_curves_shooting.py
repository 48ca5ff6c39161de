"""The bearing rotor's curves in (w, f0) by shooting, against harmonic balance and against each other.

The period-doubling curve of the integrated flow (contin.bifurcation.shooting_curve_system)
against the harmonic-balance curve (H = 40, the bearing on its casing: the truncation converged),
an independent discretisation; the Neimark-Sacker curve of the harmonic orbit born at w = 2.0169
(f0 = 0.5) ends at a 1:2 resonance, which the period-doubling curve locates on its own by its
test (left and right null vectors of M + I orthogonal), and where the orbit has a double
multiplier -1.
"""

import numpy as np
import pytest

from contin.bifurcation.curve_system import FlipTestEvent
from contin.bifurcation.shooting_curve_system import ShootingCurveProblem
from contin.bifurcation.two_parameter import CurveOptions, curve_from_point, trace_curve
from contin.engine.continuation import ContinuationOptions, continuation
from contin.engine.newton import solve_at_parameter
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.model.catalog import build_model
from contin.timedomain.multiple_shooting import ShootingProblem
from contin.timedomain.shooting_options import ShootingOptions
from contin.timedomain.simulation import simulate

pytestmark = pytest.mark.slow  # about a minute: two curves of 4096-step flows, the harmonic-balance curve


@pytest.fixture(scope="module")
def orbits():
    """The harmonic orbit at f0 = 0.5 near its Neimark-Sacker point 2.0169 and its period doubling 2.1473."""
    model = build_model("bearing_rotor", {"f0": 0.5})
    run = simulate(model, {"w": 1.84}, np.array([0.5, 0.0, 0.0, 0.0]), np.zeros(4), periods=400,
                   steps_per_period=4096, record_every=4096, record_from=399)
    sp = ShootingProblem(model, "w", {}, ShootingOptions(steps_per_period=4096))
    z, out = run.section[-1], {}
    for w in np.arange(1.85, 2.1473, 0.01).tolist() + [2.0169, 2.1473]:
        z = solve_at_parameter(sp, z, w).x
        if w in (2.0169, 2.1473):
            out[w] = z.copy()
    return model, sp, out


def _curve(sp, kind, z0, lo2, hi2):
    cp = ShootingCurveProblem(sp, kind, "f0", u_scale=1.0, p1_scale=0.7)
    return cp, trace_curve(cp, z0, 0.5, (lo2, hi2), (1.6, 2.3), ContinuationOptions(ds=0.01, ds_max=0.05, direction=-1),
                           CurveOptions(both_ways=False), nu=1)


def test_the_period_doubling_curve_by_shooting_equals_harmonic_balances(orbits):
    model, sp, z = orbits
    _, cur = _curve(sp, "pd", np.concatenate([z[2.1473], [2.1473]]), 0.3, 0.5)
    hb = HarmonicBalance(model, "w", HBOptions(harmonics=40, samples=1024, crossings="none"))
    u0 = model.start(hb, 2.1)
    br = continuation(hb, u0, 2.1, (2.1, 2.16), ContinuationOptions(ds=0.02, ds_max=0.05), events=[FlipTestEvent(hb)])
    (pd,) = br.points_of_kind("pd")
    ref = curve_from_point(hb, pd, "f0", (0.3, 0.5), (2.0, 2.3), ContinuationOptions(ds=0.02, ds_max=0.1))
    for f0 in (0.3, 0.4, 0.45):
        (w_shoot,) = [q for q, _ in cur.crossings(f0)]
        w_hb = min((q for q, _ in ref.crossings(f0)), key=lambda q: abs(q - w_shoot))
        assert abs(w_shoot - w_hb) < 1e-8  # measured 3e-10 to 9e-10


def test_the_neimark_sacker_curve_ends_at_the_1_2_resonance_of_the_period_doubling_curve(orbits):
    _, sp, z = orbits
    mu = sp.multipliers(z[2.0169], 2.0169)
    theta = float(np.angle(mu[np.argmin(np.abs(np.abs(mu) - 1) + (mu.imag <= 0))]))
    cp, ns = _curve(sp, "ns", np.concatenate([z[2.0169], [theta, 2.0169]]), 0.3, 0.6)
    ns_end = [e for e in ns.ends if e["status"] == "boundary"]
    assert ns_end and "1:2 resonance" in ns_end[0]["message"]
    (r2_ns,) = ns.points_of_kind("r2")
    _, pd = _curve(sp, "pd", np.concatenate([z[2.1473], [2.1473]]), 0.3, 0.5)
    r2_pd = min(pd.points_of_kind("r2"), key=lambda p: abs(p.p1 - r2_ns.p1))
    assert abs(r2_pd.p1 - r2_ns.p1) < 1e-6 and abs(r2_pd.p2 - r2_ns.p2) < 1e-6  # measured 2e-8
    # a double multiplier -1 (with one eigenvector, it splits as the square root of the error: 1e-8 here)
    x = r2_pd.unknowns
    sp2 = sp.with_params({"f0": r2_pd.p2})
    mu = sp2.multipliers(solve_at_parameter(sp2, x, r2_pd.p1).x, r2_pd.p1)
    near = np.sort(np.abs(mu + 1.0))[:2]
    assert near.max() < 1e-6  # measured 1.2e-8
