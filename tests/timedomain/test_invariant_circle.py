"""Invariant circles of the stroboscopic map (contin.timedomain.invariant_circle) on the forced van der Pol
oscillator, against its quasi-periodic harmonic balance and an independent scipy integration."""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import minimize_scalar

from contin.bifurcation.diagram import follow
from contin.bifurcation.torus_branch import TorusSettings
from contin.engine.continuation import ContinuationOptions, continuation
from contin.engine.newton import solve_at_parameter
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.hb.torus import TorusOptions
from contin.timedomain.invariant_circle import (CircleOptions, InvariantCircleProblem, circle_lyapunov, circle_start,
                                               point_jacobians,
                                               shift_matrix)
from contin.timedomain.shooting import ShootingOptions, periodic_orbit
from contin.util import workers
from van_der_pol_model import F, MU, vdp_model



@pytest.fixture(scope="module")
def qp_branch():
    """The quasi-periodic harmonic balance's torus branch (H1 = H2 = 12) from the Neimark-Sacker point down to 0.9."""
    hb = HarmonicBalance(vdp_model(), "w", HBOptions(5))
    d = follow(hb, hb.linear_solution(0.9), 0.9, (0.9, 0.97), {"ds": 0.02}, stability={"method": "hill"},
               switch=("ns",), torus=TorusSettings(TorusOptions(12, 12), stability="none"))
    return hb, d


def circle_of(qp, u, w, N):
    """The section at forcing phase 0 of a quasi-periodic harmonic-balance point: its states at theta2 = 2 pi j / N."""
    return np.array([np.concatenate([a.ravel() for a in qp.state_at(u, w, np.zeros(1), phase2=t)])
                     for t in 2 * np.pi * np.arange(N) / N])


def circle_at_092(qp_branch, N, steps):
    """The circle of N points and ``steps`` RK4 steps a period at the balance's point nearest w = 0.92, by Newton
    from the balance's section: ``(qp, u_qp, w, problem, section, NewtonResult)``."""
    _, d = qp_branch
    br, qp = d.branches[1], d.problems[1]
    i = int(np.argmin(np.abs(br.parameter - 0.92)))
    u_qp, w = br.unknowns[i], float(br.parameter[i])
    prob = InvariantCircleProblem(vdp_model(), "w", options=CircleOptions(points=N, steps_per_period=steps))
    U0 = circle_of(qp, u_qp, w, N)
    prob.set_anchor(U0)
    res = solve_at_parameter(prob, prob.unknowns(U0, (u_qp[-1] / w) % 1.0), w)
    assert res.converged, res.message
    return qp, u_qp, w, prob, U0, res


def vdp_rhs(w):
    """The oscillator's right-hand side for scipy, written here."""
    def rhs(t, y):
        return [y[1], MU * (1 - y[0] ** 2) * y[1] - y[0] + F * math.cos(w * t)]
    return rhs


def test_the_shift_matrix_moves_a_trigonometric_polynomial_exactly():
    N, rho = 9, 0.137
    theta = 2 * np.pi * np.arange(N) / N
    f = lambda t: 0.3 + np.cos(t) - 0.7 * np.sin(2 * t) + 0.2 * np.cos(4 * t)  # degree (N - 1) / 2 = 4
    np.testing.assert_allclose(shift_matrix(N, 0.0), np.eye(N), atol=1e-14)
    np.testing.assert_allclose(shift_matrix(N, rho) @ f(theta), f(theta + 2 * np.pi * rho), atol=1e-13)
    d = (shift_matrix(N, rho + 1e-6) - shift_matrix(N, rho - 1e-6)) / 2e-6
    np.testing.assert_allclose(shift_matrix(N, rho, derivative=True), d, atol=1e-7)


def small_circle(qp_branch, anchor_scale=1.0, drho=0.0):
    """A circle of 7 points at 256 steps from the balance's sixth torus point: ``(problem, U, u, w)``."""
    _, d = qp_branch
    br, qp = d.branches[1], d.problems[1]
    u_qp, w = br.unknowns[5], float(br.parameter[5])
    prob = InvariantCircleProblem(vdp_model(), "w", options=CircleOptions(points=7, steps_per_period=256))
    U = circle_of(qp, u_qp, w, 7)
    prob.set_anchor(anchor_scale * U)
    return prob, U, prob.unknowns(U, u_qp[-1] / w + drho), w


def test_the_jacobian_against_central_differences(qp_branch):
    prob, U, u, w = small_circle(qp_branch, 1.01, 0.01)  # a residual away from zero in every row
    R, Ju, Jlam = prob.linearize(u, w)
    np.testing.assert_allclose(R, prob.residual(u, w), atol=1e-14)
    Jfd = np.empty_like(Ju)
    for k in range(u.size):
        e = np.zeros(u.size)
        e[k] = 1e-6
        Jfd[:, k] = (prob.residual(u + e, w) - prob.residual(u - e, w)) / 2e-6
    jl = (prob.residual(u, w + 1e-6) - prob.residual(u, w - 1e-6)) / 2e-6
    assert np.abs(Ju - Jfd).max() < 1e-8 * np.abs(Ju).max()
    assert np.abs(Jlam - jl).max() < 1e-8 * np.abs(Jlam).max()


def test_the_points_flows_in_threads_give_the_serial_numbers_bit_for_bit(qp_branch):
    prob, U, u, w = small_circle(qp_branch)
    before = workers.threads()
    got = {}
    try:
        for n in (1, 2, 3):
            workers.set_threads(n)
            got[n] = (*prob.linearize(u, w), prob.residual(u, w), point_jacobians(prob, u, w, midpoints=True))
    finally:
        workers.set_threads(before)
    for n in (2, 3):
        for a, b in zip(got[1], got[n]):
            assert np.array_equal(a, b)
    # the diagonal blocks of the threaded Jacobian are the single flows' Jacobians
    Phi = np.stack([prob.map.flow_jacobian(z, w)[1] for z in U])
    np.testing.assert_array_equal(point_jacobians(prob, u, w), Phi)


def test_the_circle_is_the_quasi_periodic_balance_section_and_invariant_under_scipy(qp_branch):
    """At w = 0.92: the rotation number equals w2 / w of the harmonic balance mod 1, the points its section,
    and a DOP853 integration of each point over one forcing period lands on the circle turned by rho."""
    N = 31
    qp, u_qp, w, prob, U0, res = circle_at_092(qp_branch, N, 2048)
    U, rho = prob.blocks(res.x)
    assert rho == pytest.approx((u_qp[-1] / w) % 1.0, abs=1e-10)  # measured 1.3e-12
    assert np.abs(U - U0).max() < 2e-7  # the balance's truncation at H2 = 12 (measured 8e-8)
    assert prob.second_frequency(res.x, w) == pytest.approx(u_qp[-1] - w, abs=1e-10)

    rhs = vdp_rhs(w)
    T = 2 * math.pi / w
    for j in (0, 7, 19):
        end = solve_ivp(rhs, (0, T), U[j], method="DOP853", rtol=1e-12, atol=1e-13).y[:, -1]
        target = prob.points_on_circle(res.x, 2 * np.pi * j / N + 2 * np.pi * rho)[0]
        assert np.abs(end - target).max() < 1e-8


def test_a_torus_branch_from_the_flows_neimark_sacker_point_meets_the_quasi_periodic_balance(qp_branch):
    hb, d = qp_branch
    (ns,) = [sp for sp in d.branches[0].special_points if sp.kind.value == "ns"]
    x, v = hb.orbit(ns.unknowns, ns.parameter, np.zeros(1))
    orbit = periodic_orbit(vdp_model(), {"w": ns.parameter}, np.r_[x.ravel(), v.ravel()],
                           ShootingOptions(steps_per_period=1024))
    assert orbit.converged
    prob, u0, tangent = circle_start(vdp_model(), "w", orbit.state, ns.parameter,
                                     options=CircleOptions(points=21, steps_per_period=1024), eps=0.02)
    br = continuation(prob, u0, ns.parameter, (0.9, 0.96), ContinuationOptions(ds=0.05), tangent=tangent,
                      solve_start=False, parameter_name="w")
    assert br.status.value == "range_end" and br.parameter[-1] == pytest.approx(0.9)
    for u, lam in zip(br.unknowns, br.parameter):
        assert np.abs(prob.residual(u, lam)).max() < 1e-9
    qb = d.branches[1]
    assert qb.parameter[-1] == pytest.approx(0.9)
    # the same torus at w = 0.9: the rotation number to 1e-8 (measured 2e-10)
    assert br.unknowns[-1, -1] == pytest.approx((qb.unknowns[-1, -1] / 0.9) % 1.0, abs=1e-8)


def test_options_and_shapes_are_checked():
    with pytest.raises(ValueError, match="points: expected an odd number"):
        CircleOptions(points=10)
    with pytest.raises(ValueError, match="steps_per_period: expected an integer >= 16"):
        CircleOptions(steps_per_period=8)
    with pytest.raises(ValueError, match="unknown"):
        CircleOptions.from_dict({"pointz": 11})
    prob = InvariantCircleProblem(vdp_model(), "w", options=CircleOptions(points=5, steps_per_period=64))
    with pytest.raises(ValueError, match="no anchor"):
        prob.residual(np.zeros(prob.size), 0.95)
    with pytest.raises(ValueError, match=r"shape \(11,\)"):
        prob.blocks(np.zeros(3))
    with pytest.raises(ValueError, match="not a Neimark-Sacker point"):
        circle_start(vdp_model(), "w", np.zeros(2), 2.0, options=CircleOptions(points=5, steps_per_period=256))


def test_the_van_der_pol_torus_is_stable_by_its_lyapunov_exponents(qp_branch):
    """Along the circle at w = 0.92: one exponent is the circle's direction (zero up to 1 / iterations), and by
    Liouville the exponents add up to the mean divergence mu T (1 - <x^2>), <x^2> averaged over the torus of
    the two-frequency balance, so the normal one is that sum; a scipy integration started off the circle
    comes back to it."""
    N = 21
    qp, u_qp, w, prob, _, res = circle_at_092(qp_branch, N, 1024)
    ly = circle_lyapunov(prob, res.x, w, iterations=400)
    assert ly.stable is True and abs(ly.exponents[ly.tangent]) < 2.0 / ly.iterations
    x, _ = qp.samples_of(u_qp, w)[:2]
    divergence = MU * (2 * math.pi / w) * (1.0 - float(np.mean(np.asarray(x) ** 2)))
    # measured at 400 iterations: sum -0.5253, normal -0.5257, tangential 4.5e-4, the divergence -0.5270
    assert float(np.sum(ly.exponents)) == pytest.approx(divergence, abs=2.0 / ly.iterations)
    assert ly.largest_normal == pytest.approx(divergence, abs=4.0 / ly.iterations)

    rhs = vdp_rhs(w)
    # the circle's trigonometric interpolant, by numpy's FFT, on 200000 angles
    U = prob.blocks(res.x)[0]
    k = np.fft.fftfreq(N, 1.0 / N)
    dense = np.real(np.exp(1j * np.outer(np.linspace(0, 2 * np.pi, 200000, endpoint=False), k))
                    @ (np.fft.fft(U, axis=0) / N))
    y0 = 1.02 * U[0]
    y = solve_ivp(rhs, (0, 20 * 2 * math.pi / w), y0, method="DOP853", rtol=1e-11, atol=1e-12).y[:, -1]
    gap = lambda p: float(np.min(np.linalg.norm(dense - p, axis=1)))  # noqa: E731
    # after 20 periods: measured 3.6e-4 of the start's distance (exp(-0.52 * 20) = 3e-5: the contraction
    # varies along the circle, and the start is not small)
    assert gap(y) < 1e-3 * gap(y0)


def test_the_exponents_from_the_points_jacobians_meet_liouville_without_a_flow(qp_branch):
    """The map's Jacobians at the circle's points, read off the circle's own Jacobian, equal the variational
    flow's there; interpolated along the circle they give the Lyapunov exponents with no flow integrated, so
    many periods can be averaged: the tangential exponent then sits within 1 / iterations of zero and the sum
    meets Liouville's mean divergence mu T (1 - <x^2>) tighter than the flow's 400 periods above."""
    N = 21
    qp, u_qp, w, prob, _, res = circle_at_092(qp_branch, N, 1024)
    _, Ju, _ = prob.linearize(res.x, w)
    from_Ju = point_jacobians(prob, res.x, w, Ju)
    by_flow = point_jacobians(prob, res.x, w)
    assert from_Ju.shape == (N, 2, 2)
    assert np.abs(from_Ju - by_flow).max() < 1e-12 * np.abs(by_flow).max()
    ly = circle_lyapunov(prob, res.x, w, iterations=20000, jacobians=from_Ju)
    x, _ = qp.samples_of(u_qp, w)[:2]
    divergence = MU * (2 * math.pi / w) * (1.0 - float(np.mean(np.asarray(x) ** 2)))
    # measured: tangential 2.8e-5, sum -0.526921 against the divergence -0.527015, normal -0.526949
    assert ly.stable is True and abs(ly.exponents[ly.tangent]) < 1e-4
    assert float(np.sum(ly.exponents)) == pytest.approx(divergence, abs=2e-4)
    assert ly.largest_normal == pytest.approx(divergence, abs=1.5e-4)
    # the same torus run backwards (mu -> -mu; the points with their velocities reversed, rho -> -rho) is the
    # same circle of the inverse map: unstable, its normal exponent the opposite (measured +0.526943)
    rev = InvariantCircleProblem(vdp_model(w=w, mu=-MU), "w", options=CircleOptions(points=N, steps_per_period=1024))
    U, rho = prob.blocks(res.x)
    U = U * np.array([1.0, -1.0])
    rev.set_anchor(U)
    r = solve_at_parameter(rev, rev.unknowns(U, -rho), w)
    assert r.converged and np.abs(rev.blocks(r.x)[0] - U).max() < 1e-5  # the RK4 steps backwards: 1.3e-6
    ly = circle_lyapunov(rev, r.x, w, iterations=20000, jacobians=point_jacobians(rev, r.x, w))
    assert ly.stable is False and ly.largest_normal == pytest.approx(-divergence, abs=1.5e-4)
    with pytest.raises(ValueError, match=r"jacobians: expected shape \(K, 2, 2\)"):
        circle_lyapunov(prob, res.x, w, jacobians=np.zeros((2, 2, 2)))


def test_a_circles_row_equals_the_two_frequency_balances_torus(qp_branch):
    """The row measures of the circle (its points' trajectories over a period, module
    contin.timedomain.circle_measures) against those of the two-frequency balance's torus at the same w: the
    second frequency, the forced, free and combination lines and the harmonics of the forcing, each a
    different computation of the same torus; the extremes against the balance's surface sampled on a 64 times
    finer grid than its own (2.4213560; on its 4x grid, what its rows say, 2.4212875)."""
    from contin.hb import aft2d
    from contin.hb.torus import torus_measures
    from contin.timedomain.circle_measures import circle_measures

    from contin.timedomain.circle_measures import strongest_winding

    qp, u_qp, w, prob, _, res = circle_at_092(qp_branch, 21, 2048)
    # the self-excited line near 1 (0.9937) is w + rho w: the winding 1, found as the strongest line
    prob.winding = strongest_winding(prob, res.x, w)
    assert prob.winding == 1
    mine = circle_measures(prob, res.x, w, ["x"], 3)
    ref = torus_measures(qp, u_qp, w, ["x"], 3)
    assert mine["frequency2"] == pytest.approx(ref["frequency2"], abs=1e-8)
    for key in ("forced_x", "free_x", "comb_x", "h1_x", "h2_x", "h3_x", "rms_x", "h0_x"):
        assert mine[key] == pytest.approx(ref[key], abs=1e-7), key
    x = aft2d.synthesize2(qp.blocks(u_qp), qp.basis.pairs, 64 * qp.N1, 64 * qp.N2)[0][:, 0]
    assert mine["max_x"] == pytest.approx(x.max(), abs=1e-5)
    assert mine["min_x"] == pytest.approx(x.min(), abs=1e-5)
    assert ref["free_x"] > 0.1 and ref["forced_x"] > 0.1  # both lines are there to compare


def test_a_circle_fitted_to_a_scipy_simulation_converges_to_the_balances_torus(qp_branch):
    """The sections of a DOP853 integration (scipy) settled on the stable torus at w = 0.92, fitted by the
    circle's trigonometric polynomial (contin.timedomain.circle_fit), are a first guess from which Newton
    finds the circle of the two-frequency balance's section: the same rotation number, and every point on it."""
    from contin.timedomain.circle_fit import fit_circle

    N = 21
    _, _, w, ref, _, res = circle_at_092(qp_branch, N, 1024)
    T = 2 * math.pi / w
    t = np.arange(60, 360) * T
    sol = solve_ivp(vdp_rhs(w), (0, t[-1]), [1.0, 0.0], method="DOP853", t_eval=t, rtol=1e-11, atol=1e-12)
    fit = fit_circle(sol.y.T, N)
    assert fit.misfit < 1e-5 and fit.rho == pytest.approx(ref.blocks(res.x)[1] % 1.0, abs=1e-6)
    prob = InvariantCircleProblem(vdp_model(), "w", options=CircleOptions(points=N, steps_per_period=1024))
    prob.set_anchor(fit.points)
    got = solve_at_parameter(prob, prob.unknowns(fit.points, fit.rho), w)
    assert got.converged
    assert prob.blocks(got.x)[1] % 1.0 == pytest.approx(ref.blocks(res.x)[1] % 1.0, abs=1e-10)
    # the same curve in another parametrisation: the reference's interpolant at the angles shifted by the
    # best phase (found on a grid, then refined by scipy)
    P = prob.blocks(got.x)[0]
    theta = 2 * np.pi * np.arange(N) / N

    def misfit(shift):
        return float(np.abs(ref.points_on_circle(res.x, theta + shift) - P).max())

    grid = np.linspace(0.0, 2 * np.pi, 2000, endpoint=False)
    start = grid[int(np.argmin([misfit(a) for a in grid]))]
    gap = minimize_scalar(misfit, bounds=(start - 0.01, start + 0.01), method="bounded",
                          options={"xatol": 1e-13}).fun
    assert gap < 1e-6  # measured 3.0e-7: two anchors, two discrete circles of N = 21 on one curve
    with pytest.raises(ValueError, match="at least 42 states"):
        fit_circle(sol.y.T[:10], N)
    with pytest.raises(ValueError, match="odd integer"):
        fit_circle(sol.y.T, 20)
