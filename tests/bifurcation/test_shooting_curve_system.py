"""Fold, period-doubling and Neimark-Sacker curves by shooting, against central differences, scipy and harmonic
balance.

The extended systems of contin.bifurcation.shooting_curve_system: their
Jacobians against central differences of their residuals; the points of a
traced curve against an independent monodromy (scipy's DOP853 with the
variational equations), which must have the curve's critical multiplier;
the damped Mathieu equation's period-doubling curve against brentq on
scipy's monodromy; the Duffing oscillator's cusp against converged harmonic balance's.
"""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from conftest import fd_jacobian
from contin.bifurcation.shooting_curve_system import ShootingCurveProblem
from contin.bifurcation.two_parameter import CurveOptions, trace_curve
from contin.engine.branch import BranchStatus
from contin.engine.continuation import ContinuationOptions
from contin.engine.newton import solve_at_parameter
from contin.model.catalog import build_model
from contin.scene.build import build_model as build_scene_model
from contin.scene.parse import scene_from_data
from contin.timedomain.multiple_shooting import ShootingProblem
from contin.timedomain.shooting_options import ShootingOptions
from contin.bifurcation.two_parameter import curve_from_point
from contin.engine.continuation import continuation
from contin.stability import orbit_state
from test_two_parameter import damped_mathieu_pd, duffing

MU, F = 0.1, 0.15  # forced van der Pol x'' - mu (1 - x^2) x' + x = F cos(w t)


def van_der_pol():
    data = {"model": {"name": "van_der_pol", "dofs": ["x"], "parameters": {"mu": MU, "F": F, "w": 1.0},
                      "mass": [[1]], "damping": [["-mu"]], "stiffness": [[1]],
                      "forces": [{"dof": "x", "expr": "mu*x**2*x_dot"}],
                      "excitation": [{"dof": "x", "expr": "F*cos(tau)"}], "frequency": "w"},
            "analysis": {"type": "frequency_response", "parameter": "w", "range": [0.8, 1.2]}}
    return build_scene_model(scene_from_data(data))


def vdp_monodromy(x0, w, Fv, periods=1):
    """The state after ``periods`` forcing periods and the monodromy, by scipy (independent of the integrator)."""
    def rhs(t, y):
        x, v = y[0], y[1]
        P = y[2:].reshape(2, 2)
        A = np.array([[0.0, 1.0], [-1.0 - 2 * MU * x * v, MU * (1 - x * x)]])
        return np.concatenate([[v, MU * (1 - x * x) * v - x + Fv * math.cos(w * t)], (A @ P).ravel()])

    sol = solve_ivp(rhs, (0, periods * 2 * math.pi / w), np.concatenate([x0, np.eye(2).ravel()]), method="DOP853",
                    rtol=1e-12, atol=1e-13)
    return sol.y[:2, -1], sol.y[2:, -1].reshape(2, 2)


def vdp_ns_start(steps=1024):
    """A Neimark-Sacker point of the van der Pol orbit near w = 0.95 (F = 0.15): ``(problem, z)``."""
    sp = ShootingProblem(van_der_pol(), "w", {}, ShootingOptions(steps_per_period=steps))
    z = solve_at_parameter(sp, np.array([1.9, 0.3]), 1.0).x
    for w in np.linspace(1.0, 0.95, 11)[1:]:
        z = solve_at_parameter(sp, z, w).x
    mu = sp.multipliers(z, 0.95)
    theta = float(abs(np.angle(mu[0])))
    cp = ShootingCurveProblem(sp, "ns", "F", u_scale=2.0, p1_scale=0.4)
    return cp, np.concatenate([z, [theta, 0.95]])


@pytest.mark.parametrize("kind", ["fold", "pd", "ns"])
def test_each_curve_systems_jacobian_matches_central_differences(kind):
    sp = ShootingProblem(van_der_pol(), "w", {}, ShootingOptions(steps_per_period=512))
    x = solve_at_parameter(sp, np.array([1.9, 0.3]), 1.0).x + np.array([1e-3, -2e-3])
    cp = ShootingCurveProblem(sp, kind, "F")
    z = np.concatenate([x, [2.5] if kind == "ns" else [], [1.01]])
    cp.initialize_borders(z, F)
    _, Jz, Jl = cp.linearize(z, F)
    y = np.concatenate([z, [F]])
    fd = fd_jacobian(lambda q: cp.residual(q[:-1], q[-1]), y, eps=1e-6)
    J = np.column_stack([Jz, Jl])
    assert np.abs(J - fd).max() <= 1e-6 * np.abs(J).max()


def test_a_neimark_sacker_curve_of_van_der_pol_has_a_unit_multiplier_pair_by_scipy():
    cp, z0 = vdp_ns_start()
    cur = trace_curve(cp, z0, F, (0.12, 0.18), (0.8, 1.2), ContinuationOptions(ds=0.01, ds_max=0.02),
                      CurveOptions())
    assert len(cur) >= 5 and cur.p2.min() <= 0.1201 and cur.p2.max() >= 0.1799
    for i in np.linspace(0, len(cur) - 1, 4).astype(int):
        x, theta, w = cp.split(np.concatenate([cur.unknowns[i], [cur.p1[i]]]))
        end, M = vdp_monodromy(x, w, cur.p2[i])
        assert np.abs(end - x).max() < 1e-6  # a periodic orbit of the flow
        mu = np.linalg.eigvals(M)
        k = np.argmax(mu.imag)
        assert abs(abs(mu[k]) - 1.0) < 1e-6
        assert abs(np.angle(mu[k]) - theta) < 1e-6


def test_the_damped_mathieu_period_doubling_curve_matches_brentq_on_scipys_monodromy():
    c = 0.05
    model = build_model("mathieu", {"c": c, "g": 1.0, "eps": 0.3})
    sp = ShootingProblem(model, "delta", {"w": 1.0}, ShootingOptions(steps_per_period=2048))
    d0 = damped_mathieu_pd(c, 0.3, (0.0, 0.25))  # the tongue's lower edge
    cp = ShootingCurveProblem(sp, "pd", "eps", u_scale=1.0, p1_scale=1.0)
    cur = trace_curve(cp, np.array([0.0, 0.0, d0]), 0.3, (0.2, 0.4), (0.0, 0.5),
                      ContinuationOptions(ds=0.02, ds_max=0.05), CurveOptions(both_ways=True))
    assert cur.p2.min() <= 0.2 + 1e-9 and cur.p2.max() >= 0.4 - 1e-9
    for eps in (0.22, 0.35):
        d_curve = min((q for q, _ in cur.crossings(eps)), key=lambda q: abs(q - d0))
        d_ref = damped_mathieu_pd(c, eps, (d_curve - 0.05, d_curve + 0.05))
        assert abs(d_curve - d_ref) < 1e-6  # RK4 with 2048 steps a period


def test_van_der_pols_neimark_sacker_curve_ends_at_a_1_1_resonance_which_scipy_confirms():
    cp, z0 = vdp_ns_start()
    cur = trace_curve(cp, z0, F, (0.0, 0.3), (0.5, 1.5), ContinuationOptions(ds=0.01, ds_max=0.02), CurveOptions())
    (r1,) = cur.points_of_kind("r1")
    (end,) = [e for e in cur.ends if e["side"] == "backward"]
    assert end["status"] == BranchStatus.BOUNDARY.value and "1:1 resonance" in end["message"]
    assert cur.p2.min() == pytest.approx(r1.p2, abs=1e-5)  # the curve stops there (on the entrainment's fold curve)
    x = r1.unknowns[:2]
    state, M = vdp_monodromy(x, r1.p1, r1.p2)
    assert np.abs(state - x).max() < 1e-6
    # both multipliers +1: trace 2 and determinant 1 (smooth in the data, unlike the double eigenvalue)
    assert abs(np.trace(M) - 2.0) < 1e-6 and abs(np.linalg.det(M) - 1.0) < 1e-6


def test_the_duffing_fold_curve_by_shooting_has_its_cusp_where_converged_harmonic_balance_has_it():
    hb = duffing(9)  # the forced Duffing oscillator of test_two_parameter, its truncation converged
    br = continuation(hb, hb.linear_solution(0.5), 0.5, (0.5, 3.0), ContinuationOptions(ds_max=0.1))
    fold = br.points_of_kind("fold")[0]
    ref = curve_from_point(hb, fold, "F", (0.0, 0.5), (0.5, 3.0), ContinuationOptions(ds=0.01, ds_max=0.05))
    (cusp_hb,) = ref.points_of_kind("cusp")
    sp = ShootingProblem(hb.model, "w", {}, ShootingOptions(steps_per_period=1024))
    x0 = np.asarray(orbit_state(hb, fold.unknowns, fold.parameter, 0.0), float)
    cp = ShootingCurveProblem(sp, "fold", "F", u_scale=1.0, p1_scale=2.5)
    cur = trace_curve(cp, np.concatenate([x0, [fold.parameter]]), 0.5, (0.0, 0.5), (0.5, 3.0),
                      ContinuationOptions(ds=0.01, ds_max=0.05), CurveOptions())
    (cusp,) = cur.points_of_kind("cusp")
    assert cusp.located
    assert abs(cusp.p1 - cusp_hb.p1) < 1e-9 and abs(cusp.p2 - cusp_hb.p2) < 1e-9  # measured 2e-11, 1e-11
