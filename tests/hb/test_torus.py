"""The quasi-periodic harmonic balance: layout, 2-D AFT, closed forms and Jacobians against finite differences."""

import numpy as np
import pytest

from contin.api.system import System
from contin.hb import aft2d
from contin.hb.qp_basis import QPBasis
from contin.hb.torus import QuasiPeriodicBalance, TorusOptions, torus_measures
from van_der_pol_model import vdp_model


def vdp(F=0.15):
    return vdp_model(F, w=0.9)


def test_basis_layout_and_pair_lookup():
    b = QPBasis(2, 1)
    assert b.pairs.tolist() == [[0, 0], [0, 1], [1, -1], [1, 0], [1, 1], [2, -1], [2, 0], [2, 1]]
    assert (b.P, b.rows) == (8, 15)
    assert b.pair(1, -1) == (2, 1) and b.pair(-1, 1) == (2, -1) and b.pair(0, -1) == (1, -1)
    with pytest.raises(KeyError, match=r"\(3, 0\) is not in the truncation"):
        b.pair(3, 0)
    with pytest.raises(ValueError, match="H2 must be an integer >= 1"):
        QPBasis(2, 0)
    U = np.arange(10.0).reshape(5, 2)
    V = b.embed_periodic(U.ravel(), 2).reshape(-1, 2)
    assert np.array_equal(b.periodic_part(V), U)


def test_grid_synthesis_and_projection_are_the_series():
    b = QPBasis(3, 2)
    rng = np.random.default_rng(0)
    U = rng.normal(size=(b.rows, 2))
    N1, N2 = 8, 6
    x, x1, x2 = aft2d.synthesize2(U, b.pairs, N1, N2)
    th1 = np.tile(2 * np.pi * np.arange(N1) / N1, N2)
    th2 = np.repeat(2 * np.pi * np.arange(N2) / N2, N1)
    ph = np.outer(th1, b.pairs[1:, 0]) + np.outer(th2, b.pairs[1:, 1])
    c, s = np.cos(ph), np.sin(ph)
    np.testing.assert_allclose(x, U[0] + c @ U[1::2] + s @ U[2::2], atol=1e-13)
    for xk, k in ((x1, b.pairs[1:, 0]), (x2, b.pairs[1:, 1])):
        np.testing.assert_allclose(xk, (-s * k) @ U[1::2] + (c * k) @ U[2::2], atol=1e-13)
    np.testing.assert_allclose(aft2d.project2(x, b.pairs, N1, N2), U, atol=1e-14)


def test_linear_residual_is_the_dynamic_stiffness_of_each_pair():
    # m x'' + c x' + k x with a gyroscopic pair: each pair sees Z(f) = K - f^2 M + i f C at its own frequency
    lin = System(dofs=["x", "y"], parameters={"g": 0.3, "w": 1.3},
                 mass=[[1, 0], [0, 2]], damping=[[0.1, "g"], ["-g", 0.2]], stiffness=[[3, -1], [-1, 2]],
                 excitation=[{"dof": "x", "expr": "0*cos(tau)"}], frequency="w").model
    qp = QuasiPeriodicBalance(lin, "w", TorusOptions(2, 2))
    rng = np.random.default_rng(1)
    u = np.append(rng.normal(size=qp.size), 0.77)
    R = qp.residual(u, 1.3)[:-1].reshape(-1, 2)
    U = u[:-1].reshape(-1, 2)
    M, C, K = lin.linear(qp.params_at(1.3))
    for j, (k1, k2) in enumerate(qp.basis.pairs[1:], start=1):
        f = k1 * 1.3 + k2 * 0.77
        Z = K - f * f * M + 1j * f * C
        z = U[2 * j - 1] - 1j * U[2 * j]  # x = Re(z e^{i phi})
        r = Z @ z
        np.testing.assert_allclose([R[2 * j - 1], R[2 * j]], [r.real, -r.imag], atol=1e-12)
    np.testing.assert_allclose(R[0], K @ U[0], atol=1e-12)


def _fd(qp, u, lam, h):
    Ju = np.array([(qp.residual(u + h * e, lam) - qp.residual(u - h * e, lam)) / (2 * h) for e in np.eye(qp.m)]).T
    return Ju, (qp.residual(u, lam + h) - qp.residual(u, lam - h)) / (2 * h)


@pytest.mark.parametrize("parameter", ["w", "F"])
def test_jacobians_against_finite_differences_van_der_pol(parameter):
    qp = QuasiPeriodicBalance(vdp(), parameter, TorusOptions(3, 3))
    u = np.append(np.random.default_rng(0).normal(size=qp.size) * 0.3, 0.97)
    lam = 0.9 if parameter == "w" else 0.15
    R, Ju, Jlam = qp.linearize(u, lam)
    np.testing.assert_allclose(R, qp.residual(u, lam), atol=1e-14)
    Jfd, Jlfd = _fd(qp, u, lam, 1e-6)
    assert np.abs(Ju - Jfd).max() < 1e-8 * np.abs(Ju).max()
    assert np.abs(Jlam - Jlfd).max() < 1e-8 * max(np.abs(Jlam).max(), 1.0)


@pytest.mark.parametrize("crossings", ["interval", "none"])
def test_jacobians_against_finite_differences_rotor_with_contact(crossings):
    # the bearing's orbit crosses the clearance circle on many grid lines: the crossings' places move with u,
    # w2 and w (through the velocity); the gyroscopic damping ip w moves with w
    rot = System.builtin("bearing_rotor", {"f0": 0.5}).model
    qp = QuasiPeriodicBalance(rot, "w", TorusOptions(3, 2, 32, 16, crossings=crossings))
    U = np.zeros((qp.basis.rows, 4))
    j = qp.basis.pair(1, 0)[0]
    U[2 * j - 1, [0, 2]] = 0.3, 0.1
    U[2 * j, [1, 3]] = 0.3, 0.1
    U[1, 2], U[2, 3] = 0.01, 0.01
    U += np.random.default_rng(3).normal(size=U.shape) * 1e-3
    u = np.append(U.ravel(), 1.07)
    R, Ju, Jlam = qp.linearize(u, 1.9)
    assert (sum(cr.t.size for _, _, cr in qp.crossings) > 10) == (crossings == "interval")
    Jfd, Jlfd = _fd(qp, u, 1.9, 1e-7)
    assert np.abs(Ju[:, :-1] - Jfd[:, :-1]).max() < 1e-8 * np.abs(Ju).max()
    assert np.abs(Ju[:, -1] - Jfd[:, -1]).max() < 1e-5 * np.abs(Ju[:, -1]).max()
    assert np.abs(Jlam - Jlfd).max() < 1e-6 * np.abs(Jlam).max()


def test_options_and_pin_are_checked():
    with pytest.raises(ValueError, match=r"TorusOptions.harmonics2 must be an integer >= 1"):
        TorusOptions(harmonics2=0)
    with pytest.raises(ValueError, match=r"TorusOptions.samples2 must be an integer >= 7"):
        TorusOptions(harmonics2=3, samples2=6)
    with pytest.raises(ValueError, match="crossings must be 'interval' or 'none'"):
        TorusOptions(crossings="exact")
    with pytest.raises(ValueError, match="pin must name a pair with k2 != 0"):
        QuasiPeriodicBalance(vdp(), "w", TorusOptions(2, 2), pin=(5, 0))  # pair 5 = (1, 0)


def test_measures_of_a_known_torus():
    qp = QuasiPeriodicBalance(vdp(), "w", TorusOptions(2, 2))
    U = np.zeros((qp.basis.rows, 1))
    U[2 * qp.basis.pair(1, 0)[0] - 1] = 0.6   # 0.6 cos(w t)
    U[2 * qp.basis.pair(0, 1)[0]] = 0.8        # 0.8 sin(w2 t)
    out = torus_measures(qp, np.append(U.ravel(), 1.01), 0.9, ["x"])
    assert out["frequency2"] == 1.01
    assert (out["forced_x"], out["free_x"], out["comb_x"]) == pytest.approx((0.6, 0.8, 0.0))
    assert out["rms_x"] == pytest.approx(np.sqrt((0.36 + 0.64) / 2))
    assert out["max_x"] == pytest.approx(1.4, rel=1e-3) and out["amp_x"] == pytest.approx(1.4, rel=1e-3)


def test_whirl_columns_of_a_known_torus():
    """The rotor's whirl columns of a torus z = x1 + i y1 = F e^{i theta1} + P e^{i theta2} + C e^{-i (theta1 -
    theta2)} + B e^{-i theta1} written into the coefficients: forward at +w and +w2, backward at -w and w2 - w."""
    rot = System.builtin("bearing_rotor", {"f0": 0.5}).model
    qp = QuasiPeriodicBalance(rot, "w", TorusOptions(2, 2))
    U = np.zeros((qp.basis.rows, 4))
    F, P, C, B = 0.8 * np.exp(0.3j), 0.37 * np.exp(-1.1j), 0.05 * np.exp(2.0j), 0.02 * np.exp(0.7j)
    for (m1, m2), A in (((1, 0), F), ((0, 1), P), ((-1, 1), C), ((-1, 0), B)):
        j, sg = qp.basis.pair(m1, m2)  # A e^{i phi}, phi = sg * (the stored pair's phase)
        U[2 * j - 1, 0] += A.real
        U[2 * j, 0] -= sg * A.imag
        U[2 * j - 1, 1] += A.imag
        U[2 * j, 1] += sg * A.real
    out = torus_measures(qp, np.append(U.ravel(), 0.9), 1.9, list(rot.dof_names), whirl_parts=rot.whirl_parts)
    assert out["whirl_fwd_1_disc"] == pytest.approx(abs(F), rel=1e-13)
    assert out["whirl_bwd_1_disc"] == pytest.approx(abs(B), rel=1e-13)
    assert out["whirl_fwd_free_disc"] == pytest.approx(abs(P), rel=1e-13)
    assert out["whirl_bwd_comb_disc"] == pytest.approx(abs(C), rel=1e-13)
    assert out["whirl_fwd_half_disc"] == out["whirl_bwd_half_disc"] == 0.0
    assert all(out[f"whirl_{c}_bearing"] == 0.0 for c in ("fwd_1", "bwd_1", "fwd_free", "bwd_comb"))
