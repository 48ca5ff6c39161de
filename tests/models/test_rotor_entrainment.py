"""Bearing rotor: the period-doubling curve in (w, f0) against one-parameter runs and the monodromy.

H = 40 harmonics and 1024 samples, as in scenes/rotor_harmonic.yaml: with fewer harmonics the
truncated orbit dips out of the clearance and the harmonic branch itself is wrong (docs/tutorials/rotor.md), so
the discretisation is not reduced here; the cost is kept down by a short stretch of the curve
(f0 from 0.3 to 0.5, one side of the region) and short one-parameter runs.
"""

import numpy as np
import pytest

from contin.bifurcation.curve_system import FlipTestEvent
from contin.bifurcation.two_parameter import curve_from_point
from contin.model.catalog import build_model
from contin.engine.continuation import ContinuationOptions, continuation
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.timedomain.shooting import period_doubling_scan, periodic_orbit
from contin.stability import StabilityMonitor, StabilityOptions, floquet_multipliers, orbit_state, stability_events

OPTIONS = HBOptions(harmonics=40, samples=1024, crossings="none")  # plainly sampled contact: the cheapest form, exact enough in permanent contact
F0S = (0.3, 0.4)


@pytest.fixture(scope="module")
def rotor():
    model = build_model("bearing_rotor", {"f0": 0.5})
    hb = HarmonicBalance(model, "w", OPTIONS)
    u0 = model.start(hb, 2.1)
    br = continuation(hb, u0, 2.1, (2.1, 2.16), ContinuationOptions(ds=0.02, ds_max=0.05), events=[FlipTestEvent(hb)])
    (pd,) = br.points_of_kind("pd")
    curve = curve_from_point(hb, pd, "f0", (0.3, 0.5), (2.0, 2.3), ContinuationOptions(ds=0.02, ds_max=0.1))
    # starts at the other forces: the f0 = 0.5 solution at w = 2.1 followed in f0
    hbf = HarmonicBalance(model, "f0", OPTIONS, {"w": 2.1})
    path = continuation(hbf, u0, 0.5, (0.3, 0.5), ContinuationOptions(ds=0.05, ds_max=0.2, direction=-1),
                        solve_start=False)
    starts = {f0: path.unknowns[int(np.argmin(np.abs(path.parameter - f0)))] for f0 in F0S}
    return model, pd, curve, starts


def test_curve_passes_from_f0_0_5_to_0_3(rotor):
    _, pd, curve, _ = rotor
    assert curve.kind.value == "pd" and curve.complete
    assert curve.p2.min() == 0.3 and curve.p2[curve.start_index] == 0.5
    assert curve.p1[curve.start_index] == pytest.approx(2.1473310, abs=1e-6)
    # the boundary moves to higher speeds as the static force falls (the region narrows)
    order = np.argsort(curve.p2)
    assert np.all(np.diff(curve.p1[order]) < 0)


@pytest.mark.parametrize("f0", F0S)
def test_one_parameter_period_doublings_lie_on_the_curve(rotor, f0):
    model, _, curve, starts = rotor
    hb = HarmonicBalance(model, "w", OPTIONS, {"f0": f0})
    (w_curve, u_curve), = curve.crossings(f0)
    # (1) independent: the multiplier count of the monodromy (RK4 along the HB orbit) changes at -1;
    # located to the event tolerance, biased by tolerance / |d|mu|/dw| (see contin.stability.events)
    mon = StabilityMonitor(hb, StabilityOptions(method="floquet", steps_per_period=4096))
    br = continuation(hb, starts[f0], 2.1, (2.1, w_curve + 0.02), ContinuationOptions(ds=0.02, ds_max=0.05),
                      events=stability_events(mon), monitors=[mon])
    (pd,) = [p for p in br.special_points if p.kind.value == "pd"]
    assert pd.located and abs(pd.parameter - w_curve) < 2e-6
    # (2) the flip test located on the one-parameter branch: the curve's own condition, to 1e-9
    br = continuation(hb, starts[f0], 2.1, (2.1, w_curve + 0.02), ContinuationOptions(ds=0.02, ds_max=0.05),
                      events=[FlipTestEvent(hb)])
    (pd,) = br.points_of_kind("pd")
    assert pd.located and abs(pd.parameter - w_curve) < 1e-9
    # (3) on the curve the monodromy has a multiplier -1 (fourth order: the bearing stays in contact)
    mu = floquet_multipliers(hb, u_curve, w_curve, StabilityOptions(method="floquet", steps_per_period=4096)).multipliers
    assert np.min(np.abs(mu + 1)) < 1e-7


def _tip_branch(model, f0):
    """The harmonic branch at ``f0`` over w = 2.16 .. 2.21 with its period doublings (the flip test)."""
    hb = HarmonicBalance(model, "w", OPTIONS, {"f0": f0})
    u0 = model.start(hb, 2.16)
    br = continuation(hb, u0, 2.16, (2.16, 2.21), ContinuationOptions(ds=0.01, ds_max=0.02),
                      events=[FlipTestEvent(hb)])
    return hb, u0, br


@pytest.mark.slow  # the region's curve from f0 = 0.5 to 0.3 by default
def test_tip_of_the_region_in_f0_by_the_flow_at_the_harmonic_balances_period_doublings():
    """Either side of the tongue's tip, the flow's orbit (contin.timedomain.shooting) at a few speeds only.

    At f0 = 0.145 the harmonic balance has the pair w1 < w2 (2.18493, 2.18785); the flow's flip test
    det(Phi + I) changes sign between w - 1e-7 and w + 1e-7 at each (measured +-2e-10 there, linear in the
    offset: its zeros lie within 3e-9 of the harmonic balance's) and is negative between them. At f0 = 0.135
    the harmonic balance has none and the flow's flip test is positive where the pair was. (The scan of the
    flow over a grid, with the pair hidden between grid values: the slow test below.)
    """
    model = build_model("bearing_rotor", {"f0": 0.5})

    def flip(f0, hb, br, w):
        i = int(np.argmin(np.abs(br.parameter - w)))  # the HB orbit nearest w: Newton's start on the flow
        orb = periodic_orbit(model, {"f0": f0, "w": w}, orbit_state(hb, br.unknowns[i], float(br.parameter[i]), 0.0))
        assert orb.converged, (f0, w, orb.message)
        return orb.flip_test

    hb, _, br = _tip_branch(model, 0.145)
    w1, w2 = sorted(p.parameter for p in br.points_of_kind("pd"))
    assert 2.184 < w1 < w2 < 2.189
    assert flip(0.145, hb, br, w1 - 1e-7) > 0 > flip(0.145, hb, br, w1 + 1e-7)
    assert flip(0.145, hb, br, w2 - 1e-7) < 0 < flip(0.145, hb, br, w2 + 1e-7)
    assert flip(0.145, hb, br, 0.5 * (w1 + w2)) < 0
    hb, _, br = _tip_branch(model, 0.135)
    assert not br.points_of_kind("pd")
    assert flip(0.135, hb, br, 0.5 * (w1 + w2)) > 0


@pytest.mark.slow
def test_tip_of_the_region_in_f0_by_shooting_and_by_harmonic_balance():
    """Either side of the tongue's tip (f0 = 0.14045 on the curve of scenes/rotor_entrainment_f0.yaml).

    At f0 = 0.145 both methods find the pair of period doublings (w = 2.18493 and 2.18785) to 1e-7
    of each other; at f0 = 0.135 neither finds one. Shooting (contin.timedomain.shooting) integrates the
    equations of motion; its pair at 0.145 falls between two grid values (det(Phi + I) > 0 at all
    three) and is found from the minimum of det(Phi + I).
    """
    model = build_model("bearing_rotor", {"f0": 0.5})
    pairs = {}
    for f0 in (0.145, 0.135):
        hb = HarmonicBalance(model, "w", OPTIONS, {"f0": f0})
        u0 = model.start(hb, 2.16)
        br = continuation(hb, u0, 2.16, (2.16, 2.21), ContinuationOptions(ds=0.01, ds_max=0.02),
                          events=[FlipTestEvent(hb)])
        hb_pd = sorted(p.parameter for p in br.points_of_kind("pd"))
        sc = period_doubling_scan(model, {"f0": f0}, "w", [2.16, 2.18, 2.20], orbit_state(hb, u0, 2.16, 0.0))
        assert sc.status == "complete"
        pairs[f0] = (hb_pd, sorted(p.params["w"] for p in sc.points))
    hb_pd, sh_pd = pairs[0.145]
    assert len(hb_pd) == 2 and len(sh_pd) == 2
    np.testing.assert_allclose(sh_pd, hb_pd, atol=1e-7)
    assert pairs[0.135] == ([], [])
