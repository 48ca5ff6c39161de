"""The built-in linear chain: its matrices are seed 002's, and harmonic balance with H = 1
reproduces the impedance FRF and the closed forms of seeds 000 and 002 to rounding."""

import math

import numpy as np
import pytest

from contin.model.catalog import build_model
from contin.engine.continuation import ContinuationOptions, continuation
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.modal.modes import chain_matrices, frf
from contin.engine.newton import solve_at_parameter
from conftest import fd_jacobian

M1, K1, M2 = 100.0, 5e5, 10.0
BETA = M2 / M1
K2 = K1 * BETA / (1 + BETA) ** 2
C2 = 2 * M2 * math.sqrt(K1 / M1) * math.sqrt(3 * BETA / (8 * (1 + BETA) ** 3))


def absorber_model(c=C2, F=1.0):
    """Seed 000's absorber as the chain: k3 = 0, the damper c between the masses."""
    return build_model("linear_chain", {"m1": M1, "m2": M2, "k1": K1, "k2": K2, "k3": 0.0, "c2": c, "F1": F})


def seed000_X(w, c=C2, F=1.0):
    """Complex X1, X2 of seed 000, sec. 7.3 (the dimensional form before normalising)."""
    D = (K1 - M1 * w**2) * (K2 - M2 * w**2) - K2 * M2 * w**2 + 1j * w * c * (K1 - (M1 + M2) * w**2)
    return F * (K2 - M2 * w**2 + 1j * w * c) / D, F * (K2 + 1j * w * c) / D


def test_matrices_are_the_seed_chain():
    m = build_model("linear_chain", {"m1": 1, "m2": 2, "k1": 3, "k2": 5, "k3": 7, "c1": 0.1, "c2": 0.2, "c3": 0.3})
    M, C, K = m.linear(m.parameter_vector())
    np.testing.assert_array_equal(M, np.diag([1, 2]))
    np.testing.assert_array_equal(K, [[3 + 5, -5], [-5, 5 + 7]])  # k11 = k1 + k2, k12 = -k2, k22 = k2 + k3
    np.testing.assert_allclose(C, [[0.1 + 0.2, -0.2], [-0.2, 0.2 + 0.3]])
    m3 = build_model("linear_chain", {"m3": 4.0, "k4": 0.0}, n=3)
    assert m3.dof_names == ("x1", "x2", "x3")
    Mr, Cr, Kr = chain_matrices([1, 1, 4], [1, 1, 1, 0])
    np.testing.assert_array_equal(m3.linear(m3.parameter_vector())[2], Kr)
    assert not np.any(build_model("linear_chain", {"c1": 5.0}, effects=["forcing"]).linear(
        build_model("linear_chain").parameter_vector())[1])  # no damping effect, no C


@pytest.mark.parametrize("c", [0.0, 50.0, C2, 1e4])
def test_harmonic_balance_h1_is_the_impedance_frf_and_seed000s_closed_form(c):
    hb = HarmonicBalance(absorber_model(c), "w", HBOptions(harmonics=1))
    M, C, K = hb.model.linear(hb.p0)
    for w in (30.0, 59.6, 64.28, 71.0, 74.9, 120.0):
        res = solve_at_parameter(hb, np.zeros(hb.size), w)
        assert res.converged
        a1, b1 = res.x[2:4], res.x[4:6]
        X = a1 - 1j * b1  # x = a cos + b sin = Re((a - i b) e^{i w t})
        Z = frf(M, C, K, [w], [1.0, 0.0])[0]
        ref = np.array(seed000_X(w, c))
        scale = np.max(np.abs(ref))
        assert np.max(np.abs(X - Z)) <= 1e-12 * scale
        assert np.max(np.abs(X - ref)) <= 1e-12 * scale
        assert np.max(np.abs(res.x[:2])) <= 1e-12 * scale  # no mean response


def test_continuation_with_h1_traces_seed002s_frf():
    """Seed 002, sec. 4.3 (m = k = 1, k3 = 2k), damped so the branch crosses the resonances: every
    stored point equals the impedance solve and seed 002's scalar formula (sec. 4.2)
    X1 = (Z22 F1 - Z12 F2)/(Z11 Z22 - Z12^2), X2 = (-Z21 F1 + Z11 F2)/(Z11 Z22 - Z12^2)."""
    c1, c3, F1, F2 = 0.03, 0.01, 1.0, 0.4
    model = build_model("linear_chain", {"m1": 1, "m2": 2, "k1": 1, "k2": 1, "k3": 2, "c1": c1, "c3": c3,
                                         "F1": F1, "F2": F2})
    hb = HarmonicBalance(model, "w", HBOptions(harmonics=1))
    # unknowns scaled by the resonant amplitude (the start amplitude would make the peaks take thousands of steps)
    opts = ContinuationOptions(ds_max=0.02, unknown_scale=20.0, max_points=5000)
    br = continuation(hb, hb.linear_solution(0.2), 0.2, (0.2, 2.5), opts)
    assert br.status.value == "range_end" and br.parameter[-1] == 2.5
    M, C, K = model.linear(hb.p0)
    w = np.asarray(br.parameter)
    U = np.asarray(br.unknowns)
    X = U[:, 2:4] - 1j * U[:, 4:6]
    np.testing.assert_allclose(X, frf(M, C, K, w, [F1, F2]), rtol=1e-9)
    Z11 = 2 - w**2 + 1j * w * c1
    Z22 = 3 - 2 * w**2 + 1j * w * c3
    Z12 = -1.0
    det = Z11 * Z22 - Z12**2
    np.testing.assert_allclose(X[:, 0], (Z22 * F1 - Z12 * F2) / det, rtol=1e-9)
    np.testing.assert_allclose(X[:, 1], (-Z12 * F1 + Z11 * F2) / det, rtol=1e-9)
    assert np.max(np.abs(X[:, 0])) > 10  # it went over the resonances


@pytest.mark.parametrize("param", ["w", "k2", "c2", "m1", "F1"])
def test_jacobian_in_each_parameter_matches_finite_differences(param, rng):
    model = build_model("linear_chain", {"m1": 1.3, "m2": 0.7, "k1": 2.0, "k2": 0.9, "k3": 0.4, "c1": 0.05,
                                         "c2": 0.2, "c3": 0.1, "F1": 0.8, "F2": 0.3, "w": 1.1})
    hb = HarmonicBalance(model, param, HBOptions(harmonics=3))
    u = rng.normal(size=hb.size)
    lam = float(hb.p0[hb.k])
    _, Ju, Jlam = hb.linearize(u, lam)
    np.testing.assert_allclose(Ju, fd_jacobian(lambda v: hb.residual(v, lam), u), rtol=1e-6, atol=1e-8)
    fd = (hb.residual(u, lam + 1e-6) - hb.residual(u, lam - 1e-6)) / 2e-6
    np.testing.assert_allclose(Jlam, fd, rtol=1e-6, atol=1e-8)


def test_options_and_parameters_are_checked():
    with pytest.raises(ValueError, match="model.options.n: expected the number of masses"):
        build_model("linear_chain", n=0)
    with pytest.raises(ValueError, match="model.options.n"):
        build_model("linear_chain", n="3")
    with pytest.raises(ValueError, match="model.options.masses: unknown option"):
        build_model("linear_chain", masses=3)
    with pytest.raises(ValueError, match="model.parameters.m3: unknown parameter"):
        build_model("linear_chain", {"m3": 1.0})
    with pytest.raises(ValueError, match="unknown effect 'dampin'.*did you mean 'damping'"):
        build_model("linear_chain", effects=["dampin"])
