"""Branch ends at grazing points: made by the orbit, by the truncation, or by the continuation's numerics.

Truth from outside the code:

- the linear response of a one-sided stop oscillator reaches its stop where
  ``F / |1 - w^2 + i c w|`` equals the clearance (closed form); beyond it the
  linear orbit would pass through the stop, so the orbit there is in contact:
  a branch that ends at that grazing point leaves an orbit that goes on;
- a rotor pressed on its casing by a static force stays in contact at the
  speeds where three harmonics draw it bouncing: the event-located time
  integration sees no contact switch there (slow test).
"""

import math

import numpy as np
import pytest
from scipy.optimize import brentq

from contin.bifurcation.end_check import (EndCheckOptions, branch_end_checks, check_grazing_end, grazing_end,
                                          higher_harmonics)
from contin.engine.branch import Branch, BranchStatus, SpecialPoint
from contin.engine.newton import newton
from contin.hb.grazing import orbit_contacts
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.model.base import Monomial
from contin.model.elements import GapForce
from contin.models.polynomial import polynomial_model
from contin.scene.build import build_model
from contin.scene.parse import parse_scene
from contact_scenes import jeffcott

C, F, G = 0.05, 0.2, 1.0

JEFFCOTT = jeffcott("analysis: {type: frequency_response, parameter: w, range: [0.9, 1.3]}\n")


def stop_oscillator(kc, harmonics=15, samples=1024):
    """``x'' + c x' + x + kc (x - G)_+ = F cos(w t)``: one stop, at ``x = G``."""
    model = polynomial_model(["x"], {"c": C, "F": F, "w": 0.5}, mass=[[1.0]], damping=[["c"]], stiffness=[[1.0]],
                             forcing=[{"dof": "x", "amplitude": "F"}])
    model.forces.append(GapForce(0, Monomial(G), Monomial(kc), sides="+"))
    return HarmonicBalance(model, "w", HBOptions(harmonics=harmonics, samples=samples))


def linear_grazing_speed():
    return brentq(lambda w: F / np.hypot(1 - w * w, C * w) - G, 0.5, 0.99)


def point(u, lam, tangent=None):
    return SpecialPoint(kind="grazing", parameter=lam, unknowns=np.asarray(u, dtype=float), interval=(lam, lam),
                        index=0, s=0.0, tangent=tangent)


def solve(hb, u, lam):
    res = newton(lambda v: hb.linearize(v, lam)[:2], u, 1e-10, 30, backtrack=6)
    assert res.converged, res.message
    return res.x


def jeffcott_grazing(harmonics, samples, w0=0.9, dw=0.01):
    """The first grazing point of the Jeffcott rotor's orbits from ``w0`` up, at the given truncation.

    Newton at fixed ``w`` in steps of ``dw``, then bisection on the number of contact switches
    (the near side kept), independently of the continuation engine.
    """
    model = build_model(parse_scene(JEFFCOTT))
    hb = HarmonicBalance(model, "w", HBOptions(harmonics=harmonics, samples=samples))
    w, u = w0, solve(hb, hb.linear_solution(w0), w0)
    n0 = orbit_contacts(hb, u, w).switches
    while True:
        u1 = solve(hb, u, w + dw)
        if orbit_contacts(hb, u1, w + dw).switches != n0:
            break
        w, u = w + dw, u1
    a, b = w, w + dw
    while b - a > 1e-12:
        m = 0.5 * (a + b)
        um = solve(hb, u, m)
        if orbit_contacts(hb, um, m).switches == n0:
            a, u = m, um
        else:
            b = m
    return hb, u, a


def test_the_check_is_made_with_more_harmonics():
    assert [higher_harmonics(H) for H in (1, 3, 8, 15, 40, 80)] == [9, 11, 16, 30, 80, 160]


@pytest.mark.parametrize("kc", [1e3, 1e8])
def test_a_stop_whose_orbit_goes_on_past_the_grazing_point_is_a_numerics_made_end(kc):
    # the stop's contact onset: the linear orbit at the closed-form grazing speed touches the stop
    hb = stop_oscillator(kc)
    wg = linear_grazing_speed()
    u = hb.linear_solution(wg)
    assert orbit_contacts(hb, u, wg).extremum == pytest.approx(0.0, abs=1e-12)
    v = grazing_end(hb, point(u, wg), +1, (0.5, 3.0), name="w")
    assert v.verdict == "numerics" and not v.accepted
    # the grazing itself is the orbit's: with more harmonics the linear orbit is the same
    assert v.check_harmonics == 30 and v.change < 1e-9 and abs(v.extremum) < 1e-9
    # past it the orbit is in contact (two switches per period) over 1% of the range
    assert v.past == pytest.approx(wg + 0.025) and v.past_switches == 2 and v.switches == 0
    assert v.uncovered == (wg, 3.0)
    assert "goes on past it" in v.reason


def test_a_grazing_drawn_by_too_few_harmonics_is_a_truncation_made_end():
    hb, u, wg = jeffcott_grazing(3, 64)
    assert 1.10 < wg < 1.13  # where three harmonics draw the bearing lifting off its casing
    v = grazing_end(hb, point(u, wg), +1, (0.9, 1.3), name="w")
    assert v.verdict == "truncation" and not v.accepted
    assert v.harmonics == 3 and v.check_harmonics == 11
    assert v.uncovered == (wg, 1.3)
    assert v.reason.startswith("at H'=11")


def test_options_are_checked_and_name_the_field():
    with pytest.raises(ValueError, match=r"EndCheckOptions.resolved must be a number in \(0, 1\]"):
        EndCheckOptions(resolved=0.0)
    with pytest.raises(ValueError, match=r"EndCheckOptions.reach must be a number in \(0, 1\], got nan"):
        EndCheckOptions(reach=math.nan)
    with pytest.raises(ValueError, match=r"EndCheckOptions.first_step must be an integer >= 1, got 2.5"):
        EndCheckOptions(first_step=2.5)
    with pytest.raises(ValueError, match=r"EndCheckOptions.max_iter must be an integer >= 1, got True"):
        EndCheckOptions(max_iter=True)


def boundary_branch(hb, u, lam, status=BranchStatus.BOUNDARY, message=None):
    br = Branch("w", hb.size)
    br.status = status
    br.message = message if message is not None else (
        f"the branch cannot pass the grazing point at w={lam:.10g} (grazing): 8 steps beyond it failed")
    t = np.zeros(hb.size + 1)
    t[-1] = 1.0  # running towards larger w
    br.special_points.append(point(u, lam, t))
    return br


def test_only_a_boundary_end_at_a_grazing_point_is_checked_and_its_entry_says_why():
    hb = stop_oscillator(1e8)
    wg = linear_grazing_speed()
    u = hb.linear_solution(wg)
    ended = boundary_branch(hb, u, wg)
    assert check_grazing_end(hb, boundary_branch(hb, u, wg, BranchStatus.RANGE_END), (0.5, 3.0)) is None
    info = [{"branch": 0, "nu": 1, "status": "boundary"}]
    lines = branch_end_checks([(ended, {})], {0: hb}, info, (0.5, 3.0), 1e-10, "w")
    assert len(lines) == 1
    assert lines[0].startswith(f"branch 0 (nu=1) ended at a grazing point at w={wg:.10g} that the continuation "
                               "could not pass")
    assert lines[0].endswith(f"w in [{wg:.10g}, 3] not covered")
    assert info[0]["end"] == "numerics" and info[0]["uncovered"] == [wg, 3.0]
    assert info[0]["end_check"]["verdict"] == "numerics"
    # a branch whose problem is unknown is not judged
    assert branch_end_checks([(ended, {})], {}, [{}], (0.5, 3.0), 1e-10, "w") == []


@pytest.mark.slow
def test_the_truncation_made_grazing_is_absent_from_the_time_simulation():
    from contin.timedomain.simulation import simulate

    hb, u, wg = jeffcott_grazing(3, 64)
    H = hb.H
    for w in (wg - 0.01, wg, wg + 0.01):
        U = u.reshape(-1, 2)
        x0, v0 = U[0] + U[1::2].sum(axis=0), w * (np.arange(1, H + 1)[:, None] * U[2::2]).sum(axis=0)
        settle = simulate(hb.model, {"w": w}, x0, v0, periods=300, steps_per_period=1024)
        rec = simulate(hb.model, {"w": w}, settle.final_state[:2], settle.final_state[2:], periods=20,
                       steps_per_period=1024)
        assert rec.events == 0  # the bearing never leaves its casing


@pytest.mark.slow
def test_the_jeffcott_rotors_grazing_at_twenty_harmonics_is_its_own_and_accepted(tmp_path):
    from contin.app.runner import run_scene

    scene = parse_scene(JEFFCOTT.replace("analysis: {type: frequency_response, parameter: w, range: [0.9, 1.3]}",
                                         "analysis: {type: frequency_response, parameter: w, range: [1.7, 2.0], "
                                         "start_from: linear, harmonics: 20, samples: 256, stability: none, "
                                         "method: hb}\n"
                                         "output: {plots: false}"))
    s = run_scene(scene, tmp_path / "out", progress=False)
    (b,) = s["analysis"]["branches"]
    # the grazing is the truncated orbit's own, but the flow's orbit goes on past it (bouncing): with harmonic
    # balance alone the rest of the range is not covered, and the run says so
    assert b["status"] == "boundary" and s["status"] == "incomplete"
    assert b["end_check"]["verdict"] == "grazing" and b["end_check"]["change"] < 0.05
    (line,) = s["shortfalls"]
    assert "not covered" in line and "analysis.method: auto or shooting" in line
