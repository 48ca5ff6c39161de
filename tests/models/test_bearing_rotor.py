"""Bearing rotor with a radial clearance (seed 001): equations, contact Jacobian, dimensional helpers, simulation."""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from contin.model.catalog import build_model
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.models.bearing_rotor import contact_damping, hertz_cylinder_stiffness, restitution_coefficient
from contin.timedomain.poincare import steady_state
from contin.timedomain.simulation import compile_model, simulate

NAMES = ("alpha", "ks2", "ip", "beta", "delta", "e", "f0", "kbn", "cbn", "c1", "c2", "w")


def random_parameters(rng):
    return {"alpha": rng.uniform(0.3, 0.9), "ks2": rng.uniform(0.3, 0.9), "ip": rng.uniform(0.01, 0.3),
            "beta": rng.uniform(0.01, 0.1), "delta": rng.uniform(0.05, 0.2), "e": rng.uniform(0.1, 1.0),
            "f0": rng.uniform(0.0, 1.0), "kbn": rng.uniform(1e3, 2e4), "cbn": rng.uniform(0.1, 1.0),
            "c1": rng.uniform(0.001, 0.05), "c2": rng.uniform(0.01, 0.5), "w": rng.uniform(1.5, 2.7)}


def paper_acceleration(P, x, v, tau, contact=None):
    """Eq. 11 of the paper solved for the accelerations, written out by hand (``tau = w t``).

    ``contact``: None decides by ``r2 >= delta`` (eq. 3); True/False freezes the law (event-driven reference).
    """
    x1, y1, x2, y2 = x
    dx1, dy1, dx2, dy2 = v
    w = P["w"]
    r2 = math.hypot(x2, y2)
    Fn = 0.0
    if (r2 >= P["delta"]) if contact is None else contact:
        Fn = P["kbn"] * (r2 - P["delta"]) + P["cbn"] * (dx2 * x2 / r2 + dy2 * y2 / r2)
    a1 = P["e"] * w**2 * math.cos(tau) - P["ip"] * w * dy1 - P["c1"] * dx1 - (x1 - P["alpha"] * x2)
    b1 = P["e"] * w**2 * math.sin(tau) + P["f0"] + P["ip"] * w * dx1 - P["c1"] * dy1 - (y1 - P["alpha"] * y2)
    ex, ey = (x2 / r2, y2 / r2) if Fn != 0.0 else (0.0, 0.0)  # r2 = 0 at rest
    a2 = (-P["c2"] * dx2 - P["ks2"] * (P["alpha"] * x2 - x1) - ex * Fn) / P["beta"]
    b2 = (-P["c2"] * dy2 - P["ks2"] * (P["alpha"] * y2 - y1) - ey * Fn) / P["beta"]
    return np.array([a1, b1, a2, b2])


# ---------------------------------------------------------------- equations (paper eq. 11)
def test_matrices_and_forcing_match_eq_11(rng):
    for _ in range(5):
        P = random_parameters(rng)
        model = build_model("bearing_rotor", P)
        assert model.param_names == NAMES and model.dof_names == ("x1", "y1", "x2", "y2")
        M, C, K = model.linear(model.parameter_vector())
        a, k2, ipw = P["alpha"], P["ks2"], P["ip"] * P["w"]
        np.testing.assert_allclose(M, np.diag([1, 1, P["beta"], P["beta"]]), rtol=1e-15)
        np.testing.assert_allclose(C, [[P["c1"], ipw, 0, 0], [-ipw, P["c1"], 0, 0], [0, 0, P["c2"], 0],
                                       [0, 0, 0, P["c2"]]], rtol=1e-15)
        np.testing.assert_allclose(K, [[1, 0, -a, 0], [0, 1, 0, -a], [-k2, 0, k2 * a, 0], [0, -k2, 0, k2 * a]],
                                   rtol=1e-15)
        tau = rng.uniform(0, 2 * np.pi, size=7)
        f = np.zeros((7, 4))
        for el in model.excitations:
            el.evaluate(tau, model.parameter_vector(), f)
        ew2 = P["e"] * P["w"] ** 2
        np.testing.assert_allclose(f, np.stack([ew2 * np.cos(tau), ew2 * np.sin(tau) + P["f0"], 0 * tau, 0 * tau], 1),
                                   rtol=1e-13, atol=1e-13)


def test_contact_force_and_compiled_right_hand_side_match_eq_11(rng):
    for _ in range(5):
        P = random_parameters(rng)
        model = build_model("bearing_rotor", P)
        p = model.parameter_vector()
        cm = compile_model(model)
        for inside in (False, True):
            ang = rng.uniform(0, 2 * np.pi)
            r = P["delta"] * (rng.uniform(0.3, 0.95) if inside else rng.uniform(1.0005, 1.01))
            x = np.array([rng.normal(), rng.normal(), r * math.cos(ang), r * math.sin(ang)])
            v = rng.normal(size=4)
            tau = rng.uniform(0, 2 * np.pi)
            f = np.zeros((1, 4))
            model.forces[0].evaluate(x[None], v[None], np.array([tau]), p, f, np.zeros((1, 4, 4)), np.zeros((1, 4, 4)))
            vn = v[2] * math.cos(ang) + v[3] * math.sin(ang)
            Fn = 0.0 if inside else P["kbn"] * (r - P["delta"]) + P["cbn"] * vn
            np.testing.assert_allclose(f[0], [0, 0, Fn * math.cos(ang), Fn * math.sin(ang)], rtol=1e-12, atol=1e-12)
            got = cm.rhs(np.concatenate([x, v]), tau, p)
            np.testing.assert_allclose(got[:4], v, rtol=1e-15)
            np.testing.assert_allclose(got[4:], paper_acceleration(P, x, v, tau), rtol=1e-11, atol=1e-11)


def test_effects_select_the_terms():
    full = build_model("bearing_rotor")
    assert len(full.forces) == 1 and type(full.forces[0]).__name__ == "RadialGapForce"
    free = build_model("bearing_rotor", effects=["gyroscopic", "unbalance", "static_force", "disc_damping",
                                                 "bearing_damping"])
    assert free.forces == []
    with pytest.raises(ValueError, match="contact_damping.*needs 'contact'"):
        build_model("bearing_rotor", effects=["unbalance", "contact_damping"])
    # without contact_damping the contact force does not depend on the velocity
    nodamp = build_model("bearing_rotor", effects=["unbalance", "contact"])
    p = nodamp.parameter_vector()
    x = np.array([[0.0, 0.0, 0.12, 0.0]])
    fa, fb = np.zeros((1, 4)), np.zeros((1, 4))
    for v, f in ((np.zeros((1, 4)), fa), (np.ones((1, 4)), fb)):
        nodamp.forces[0].evaluate(x, v, np.zeros(1), p, f, np.zeros((1, 4, 4)), np.zeros((1, 4, 4)))
    np.testing.assert_allclose(fa, fb)
    np.testing.assert_allclose(fa[0, 2], 12881.0 * 0.02, rtol=1e-12)
    M, C, K = nodamp.linear(p)
    assert np.all(C == 0)  # no gyroscopic, no disc or bearing damping
    assert len(nodamp.excitations) == 2  # unbalance only, no static force


# ---------------------------------------------------------------- contact Jacobian through the HB residual
def rotor_coefficients(hb, rng, margin=0.006):
    """Random HB coefficients whose bearing samples stay ``margin`` away from r2 = delta, in and out of contact."""
    n, H = hb.n, hb.H
    delta = hb.p0[hb.model.parameter_index("delta")]
    while True:
        U = np.zeros((2 * H + 1, n))
        U[:, :2] = rng.normal(scale=0.3, size=(2 * H + 1, 2)) / np.arange(1, 2 * H + 2)[:, None]
        U[0, 2:] = rng.normal(scale=0.04, size=2)
        U[1:, 2:] = rng.normal(scale=0.05, size=(2 * H, 2)) / np.arange(1, 2 * H + 1)[:, None]
        u = U.reshape(-1)
        x, _, _ = hb.samples_of(u, 2.0)
        r = np.hypot(x[:, 2], x[:, 3])
        if np.min(np.abs(r - delta)) > margin and np.any(r > delta) and np.any(r < delta):
            return u


def test_contact_jacobian_equals_finite_differences(rng):
    hb = HarmonicBalance(build_model("bearing_rotor"), "w", HBOptions(harmonics=3, samples=64))
    for _ in range(3):
        u = rotor_coefficients(hb, rng)
        lam = rng.uniform(1.7, 2.5)
        R, J, Jlam = hb.linearize(u, lam)
        eps = 1e-7
        Jfd = np.empty_like(J)
        for j in range(u.size):
            e = np.zeros_like(u)
            e[j] = eps
            Jfd[:, j] = (hb.residual(u + e, lam) - hb.residual(u - e, lam)) / (2 * eps)
        scale = np.abs(J).max()
        assert np.abs(J - Jfd).max() <= 1e-6 * scale
        dlam = (hb.residual(u, lam + eps) - hb.residual(u, lam - eps)) / (2 * eps)
        # the difference quotient's rounding is about 1e-16 |R| / eps
        assert np.abs(Jlam - dlam).max() <= 1e-6 * max(1.0, np.abs(Jlam).max()) + 1e-8 * np.abs(R).max()
        # the contact part is really exercised: the Jacobian differs from the linear operator
        assert np.abs(J - hb.linear_matrix(hb.params_at(lam))).max() > 100


# ---------------------------------------------------------------- dimensional helpers (eq. 4-9)
def test_contact_damping_and_restitution_are_inverse(rng):
    for _ in range(20):
        e = rng.uniform(0.05, 0.999)
        m2, kbn = 10 ** rng.uniform(-2, 1), 10 ** rng.uniform(3, 7)
        c = contact_damping(e, m2, kbn)
        assert c > 0
        assert restitution_coefficient(c, m2, kbn) == pytest.approx(e, rel=1e-12)
    assert contact_damping(1.0, 1.0, 1.0) == 0.0
    for bad in ((0.0, 1, 1), (1.2, 1, 1), (0.5, -1, 1), (0.5, 1, 0)):
        with pytest.raises(ValueError):
            contact_damping(*bad)
    # the paper's nondimensional values correspond to a restitution coefficient of about 0.95 (steel)
    assert 0.9 < restitution_coefficient(0.515, 0.019, 12881.0) < 0.99


def impact_rebound_ratio(m2, kbn, cbn, v0=1.0):
    """-v1/v0 of a mass hitting a spring-dashpot (contact from x = 0 until x = 0 again), by DOP853."""
    def rhs(t, z):
        return [z[1], -(kbn * z[0] + cbn * z[1]) / m2]

    leave = lambda t, z: z[0]  # noqa: E731
    leave.terminal, leave.direction = True, -1
    T = 2 * math.pi / math.sqrt(kbn / m2)
    sol = solve_ivp(rhs, (0, 2 * T), [0.0, v0], method="DOP853", rtol=1e-12, atol=1e-14, events=leave,
                    first_step=T * 1e-4)
    assert sol.status == 1
    return -sol.y_events[0][0][1] / v0


@pytest.mark.parametrize("e", [0.3, 0.7, 0.95])
def test_restitution_coefficient_matches_a_simulated_impact(e):
    m2, kbn = 0.37, 2.5e5
    cbn = contact_damping(e, m2, kbn)
    assert impact_rebound_ratio(m2, kbn, cbn) == pytest.approx(e, rel=1e-8)
    assert impact_rebound_ratio(m2, kbn, 0.8 * cbn) == pytest.approx(restitution_coefficient(0.8 * cbn, m2, kbn),
                                                                     rel=1e-8)


def hertz_closed_form(P, E1, nu1, E2, nu2, R1, R2, l):
    """kbn = 2 S / d^2 with the strain energy integrated analytically.

    d(P) = A P (L - ln(P)/2), A = 2 kk / (pi l), L = 1.8864 + ln(l/2) - ln(B)/2, B = 2 kk R1 R2 / (pi l (R2 - R1)),
    so int_0^P d = A (L P^2/2 - P^2 ln(P)/4 + P^2/8).
    """
    kk = (1 - nu1**2) / E1 + (1 - nu2**2) / E2
    A = 2 * kk / (math.pi * l)
    B = 2 * kk * R1 * R2 / (math.pi * l * (R2 - R1))
    L = 1.8864 + math.log(l / 2) - 0.5 * math.log(B)
    d = A * P * (L - 0.5 * math.log(P))
    integral = A * (L * P**2 / 2 - P**2 * math.log(P) / 4 + P**2 / 8)
    return 2 * (d * P - integral) / d**2, d


def test_hertz_stiffness_against_closed_form_and_limits():
    steel = (206e9, 0.3, 206e9, 0.3)
    for P, R1, R2, l in ((100.0, 0.020, 0.0201, 0.010), (2500.0, 0.035, 0.0352, 0.020), (10.0, 0.01, 0.0105, 0.005)):
        k = hertz_cylinder_stiffness(P, *steel, R1, R2, l)
        want, d = hertz_closed_form(P, *steel, R1, R2, l)
        assert k == pytest.approx(want, rel=1e-6)  # the model integrates d(P) by quadrature
        assert want < P / d  # a stiffening contact stores less energy than its secant spring
    ks = [hertz_cylinder_stiffness(P, *steel, 0.02, 0.0201, 0.01) for P in (1.0, 10.0, 100.0, 1e3, 1e4)]
    assert np.all(np.diff(ks) > 0)  # stiffer under a larger load
    kl = [hertz_cylinder_stiffness(100.0, *steel, 0.02, 0.0201, l) for l in (0.002, 0.005, 0.01, 0.02, 0.05)]
    assert np.all(np.diff(kl) > 0)  # stiffer over a longer contact
    soft = hertz_cylinder_stiffness(100.0, 70e9, 0.33, 70e9, 0.33, 0.02, 0.0201, 0.01)
    assert soft < ks[2]  # aluminium is softer than steel
    with pytest.raises(ValueError):
        hertz_cylinder_stiffness(100.0, *steel, 0.02, 0.02, 0.01)
    with pytest.raises(ValueError):
        hertz_cylinder_stiffness(-1.0, *steel, 0.02, 0.021, 0.01)


# ---------------------------------------------------------------- time simulation of the rotor
def rotor_reference(model, revolutions):
    """Event-driven DOP853 of eq. 11 (rtol 1e-12), restarted at every contact change; from rest."""
    p = model.parameter_vector()
    P = dict(zip(model.param_names, p))
    w = P["w"]
    t_end = revolutions * 2 * math.pi / w
    t, y, contact, last, short = 0.0, np.zeros(8), False, -1.0, False
    while t < t_end - 1e-12:
        def rhs(tt, z, on=contact):
            return np.concatenate([z[4:], paper_acceleration(P, z[:4], z[4:], w * tt, on)])

        g0 = math.hypot(y[2], y[3]) - P["delta"]
        # start the event function from zero, and after a very short flight require a clear separation,
        # so that the accumulation of ever shorter bounces (the bearing settling on the casing) ends
        off = min(g0, 0.0) - (1e-9 if short else 0.0) if contact else max(g0, 0.0)
        ev = (lambda tt, z: math.hypot(z[2], z[3]) - P["delta"] - off)
        ev.terminal, ev.direction = True, (-1 if contact else 1)
        sol = solve_ivp(rhs, (t, t_end), y, method="DOP853", rtol=1e-12, atol=1e-13, events=ev)
        assert sol.success
        t, y = sol.t[-1], sol.y[:, -1]
        if sol.status == 1:
            if not contact:
                short = t - last < 1e-7
            last, contact = t, not contact
    return y


def test_rotor_simulation_converges_to_the_event_driven_reference():
    model = build_model("bearing_rotor", {"w": 2.0, "f0": 0.5})
    ref = rotor_reference(model, 2)
    err = {S: np.abs(simulate(model, None, periods=2, steps_per_period=S).final_state - ref).max()
           for S in (4096, 8192)}
    plain = np.abs(simulate(model, None, periods=2, steps_per_period=8192, locate_events=False).final_state - ref).max()
    assert err[4096] < 1e-4 and err[8192] < 1e-5 and err[4096] > 8 * err[8192]
    assert plain > 10 * err[8192]


def test_rotor_entrainment_and_self_excited_whirl():
    # f0 = 0.5 (paper Fig. 4-5): entrained into the +w/2 forward whirl at w = 2.16; at w = 1.8 neither the
    # harmonic nor the subharmonic is stable and a self-excited forward whirl near p_f = 1.06 appears
    model = build_model("bearing_rotor", {"f0": 0.5})
    res, c = steady_state(model, {"w": 2.16}, transient=1500, record=40)
    assert c.label == "period-2"
    fw, bw = abs(c.whirl["+w/2"]), abs(c.whirl["-w/2"])
    assert fw > 0.3 and fw > 10 * bw  # a forward whirl
    assert res.unresolved_events == 0
    res, c = steady_state(model, {"w": 1.8}, transient=300, record=40)
    assert c.label == "not periodic"
    f_self = next(f for f, _ in c.lines if abs(f - round(f)) > 0.05)
    assert 0.55 < f_self < 0.63  # forward (positive), near p_f / w, not a multiple of w/2


def test_whirl_components_of_circular_orbits():
    """x + i y = r e^{+i k theta} is a forward whirl of radius r; r e^{-i k theta} a backward one."""
    from contin.hb.harmonics import index
    from contin.models.bearing_rotor import whirl_components

    n, H = 4, 4
    for nu, k_half, k_one in ((2, 1, 2), (1, None, 1)):
        u = np.zeros(n * (2 * H + 1))
        if k_half:
            u[index(0, k_half, "c", n)], u[index(1, k_half, "s", n)] = 0.3, 0.3  # disc: forward at w/2
        u[index(2, k_one, "c", n)], u[index(3, k_one, "s", n)] = 0.1, -0.1  # bearing: backward at w
        u[index(0, k_one, "c", n)], u[index(1, k_one, "c", n)] = 0.2, 0.0  # disc: a line = half fwd + half bwd
        wc = whirl_components(u, n, nu)
        assert wc["whirl_fwd_half_disc"] == pytest.approx(0.3 if k_half else 0.0)
        assert wc["whirl_bwd_half_disc"] == pytest.approx(0.0)
        assert wc["whirl_fwd_1_bearing"] == pytest.approx(0.0) and wc["whirl_bwd_1_bearing"] == pytest.approx(0.1)
        assert wc["whirl_fwd_1_disc"] == pytest.approx(0.1) and wc["whirl_bwd_1_disc"] == pytest.approx(0.1)
