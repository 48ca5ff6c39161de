"""Harmonic-balance residual: closed forms and Jacobians against finite differences."""

import numpy as np
import pytest
from conftest import fd_jacobian

from contin.model.catalog import build_model
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.hb.harmonics import index
from contin.models.polynomial import polynomial_model


def vdp_duffing():
    """Two dofs, cubic and velocity-dependent (x^2 x') coupling, forcing on both."""
    return polynomial_model(
        ["x", "y"],
        {"m": 1.0, "c": 0.05, "k": 1.0, "kc": 0.3, "g": 0.8, "mu": 0.2, "F": 0.4, "w": 1.3},
        mass=[["m", 0], [0, "2*m"]],
        damping=[["c", 0], [0, "c"]],
        stiffness=[["k", "-kc"], ["-kc", "k"]],
        nonlinear=[
            {"dof": "x", "coef": "g", "x": {"x": 3}},
            {"dof": "y", "coef": "mu", "x": {"y": 2}, "v": {"y": 1}},
            {"dof": "y", "coef": "0.5*g", "x": {"x": 1, "y": 2}},
        ],
        forcing=[{"dof": "x", "amplitude": "F", "order": 1}, {"dof": "y", "amplitude": "0.3*F*w**2", "order": 2}],
    )


@pytest.mark.parametrize("nu", [1, 2, 3])
@pytest.mark.parametrize("param", ["w", "F", "k", "g", "mu", "c", "m"])
def test_jacobians_match_finite_differences(nu, param, rng):
    model = vdp_duffing()
    hb = HarmonicBalance(model, param, HBOptions(harmonics=2 * nu + 1, subharmonic=nu))
    u = 0.4 * rng.normal(size=hb.size)
    lam = hb.p0[hb.k] * 1.1
    R, Ju, Jlam = hb.linearize(u, lam)
    np.testing.assert_allclose(R, hb.residual(u, lam), atol=1e-14)
    Jfd = fd_jacobian(lambda v: hb.residual(v, lam), u)
    assert np.abs(Ju - Jfd).max() <= 1e-6 * np.abs(Ju).max()
    Jlam_fd = fd_jacobian(lambda l: hb.residual(u, l[0]), np.array([lam]))[:, 0]
    assert np.abs(Jlam - Jlam_fd).max() <= 1e-6 * max(np.abs(Jlam).max(), 1e-300)


def test_linear_two_dof_equals_complex_frf():
    """With no nonlinear effect and H = 1, HB equals X = Z(w)^-1 F, Z = K - w^2 M + i w C."""
    M = np.array([[2.0, 0.0], [0.0, 1.0]])
    C = np.array([[0.3, -0.1], [-0.1, 0.2]])
    K = np.array([[5.0, -2.0], [-2.0, 3.0]])
    F = np.array([1.0, 0.5])
    model = polynomial_model(
        ["x1", "x2"],
        {"w": 1.0},
        mass=M.tolist(),
        damping=C.tolist(),
        stiffness=K.tolist(),
        forcing=[{"dof": "x1", "amplitude": F[0]}, {"dof": "x2", "amplitude": F[1]}],
    )
    hb = HarmonicBalance(model, "w", HBOptions(harmonics=1))
    for w in np.linspace(0.2, 3.0, 15):
        u = np.linalg.solve(hb.linearize(np.zeros(hb.size), w)[1], -hb.residual(np.zeros(hb.size), w))
        X = np.linalg.solve(K - w**2 * M + 1j * w * C, F)
        # x = Re(X e^{iwt}) = Re X cos - Im X sin
        a = u[[index(i, 1, "c", 2) for i in range(2)]]
        b = u[[index(i, 1, "s", 2) for i in range(2)]]
        np.testing.assert_allclose(a, X.real, atol=1e-12 * np.abs(X).max())
        np.testing.assert_allclose(b, -X.imag, atol=1e-12 * np.abs(X).max())
        np.testing.assert_allclose(u[:2], 0.0, atol=1e-15)


def test_duffing_h1_residual_is_the_amplitude_equation():
    """At a root of [(1 - w^2 + 3/4 A^2)^2 + (c w)^2] A^2 = F^2, the H = 1 residual vanishes."""
    from scipy.optimize import brentq

    model = build_model("duffing", {"F": 0.3})
    hb = HarmonicBalance(model, "w", HBOptions(harmonics=1))
    w, c, F = 0.7, 0.1, 0.3
    A = brentq(lambda A: ((1 - w**2 + 0.75 * A**2) ** 2 + (c * w) ** 2) * A**2 - F**2, 1e-6, 5)
    phi = np.arctan2(c * w, 1 - w**2 + 0.75 * A**2)  # x = A cos(wt - phi)
    u = np.array([0.0, A * np.cos(phi), A * np.sin(phi)])
    assert np.abs(hb.residual(u, w)).max() < 1e-14


def test_options_are_validated_with_field_names():
    with pytest.raises(ValueError, match="HBOptions.harmonics"):
        HBOptions(harmonics=-1)
    with pytest.raises(ValueError, match="HBOptions.samples"):
        HBOptions(harmonics=5, samples=10)
    with pytest.raises(ValueError, match="harmonic.*did you mean 'harmonics'"):
        HBOptions.from_dict({"harmonic": 3})
    with pytest.raises(ValueError, match="unknown parameter 'ww'.*did you mean 'w'"):
        HarmonicBalance(build_model("duffing"), "ww")


def test_zero_harmonics_is_the_static_residual(rng):
    """H = 0: R(x) = K x + f_nl(x, 0) - f_const, and Ju the tangent stiffness (closed form)."""
    model = polynomial_model(["x", "y"], {"k": 2.0, "kc": 0.5, "g": 0.7, "P": 0.3, "w": 1.0}, mass=[[1, 0], [0, 1]],
                             stiffness=[["k", "-kc"], ["-kc", "k"]],
                             nonlinear=[{"dof": "x", "coef": "g", "x": {"x": 3}},
                                        {"dof": "y", "coef": "g", "x": {"x": 1, "y": 1}}],
                             forcing=[{"dof": "y", "amplitude": "P", "order": 0}])
    hb = HarmonicBalance(model, "P", HBOptions(harmonics=0))
    x, y = rng.normal(size=2)
    R, Ju, Jlam = hb.linearize(np.array([x, y]), 0.3)
    np.testing.assert_allclose(R, [2 * x - 0.5 * y + 0.7 * x**3, -0.5 * x + 2 * y + 0.7 * x * y - 0.3], atol=1e-13)
    np.testing.assert_allclose(Ju, [[2 + 2.1 * x**2, -0.5], [-0.5 + 0.7 * y, 2 + 0.7 * x]], atol=1e-13)
    np.testing.assert_allclose(Jlam, [0, -1], atol=1e-14)


def test_excitation_must_be_representable():
    model = vdp_duffing()  # has a 2w forcing term
    with pytest.raises(ValueError, match="harmonics=1"):
        HarmonicBalance(model, "w", HBOptions(harmonics=1))
    HarmonicBalance(model, "w", HBOptions(harmonics=4, subharmonic=2))


def test_default_samples_follow_the_model_degree():
    hb = HarmonicBalance(build_model("duffing"), "w", HBOptions(harmonics=9))
    assert hb.N == 37
    lin = HarmonicBalance(build_model("duffing", effects=["damping", "forcing"]), "w", HBOptions(harmonics=9))
    assert lin.N == 19 and lin.model.forces == []


def test_model_errors_name_the_key():
    with pytest.raises(ValueError, match=r"model.stiffness\[0\]\[1\]: unknown parameter 'kk'.*did you mean 'k'"):
        polynomial_model(["x", "y"], {"k": 1.0, "w": 1.0}, mass=[[1, 0], [0, 1]], stiffness=[[1, "kk"], [0, 1]])
    with pytest.raises(ValueError, match="model.mass: expected a 2x2 matrix"):
        polynomial_model(["x", "y"], {"w": 1.0}, mass=[[1]])
    with pytest.raises(ValueError, match="unknown effect 'cubik'.*did you mean 'cubic'"):
        build_model("duffing", effects=["cubik"])


@pytest.mark.parametrize("param", ["w", "ip", "alpha", "e"])
def test_blockwise_linear_part_equals_the_dense_operator(param, rng):
    # no contact at these small amplitudes: the Jacobian is the linear operator A(Omega, p) itself
    hb = HarmonicBalance(build_model("bearing_rotor", {"f0": 0.0}), param, HBOptions(harmonics=4, subharmonic=2))
    u = 1e-3 * rng.normal(size=hb.size)
    lam = hb.p0[hb.k] * 1.05
    p = hb.params_at(lam)
    A = hb.linear_matrix(p)
    R, Ju, _ = hb.linearize(u, lam)
    np.testing.assert_allclose(Ju, A, rtol=0, atol=1e-13 * np.abs(A).max())
    fext, _ = hb.excitation(p)
    np.testing.assert_allclose(R, A @ u - fext, rtol=0, atol=1e-13 * np.abs(fext).max())


def test_the_frequency_is_chosen_once_and_the_model_is_left_alone(rng):
    """A problem whose frequency is another parameter W: Omega = W/nu and the period come from the problem,
    equal to those of a model that declares W itself; the model keeps its own frequency."""
    params = {"m": 1.0, "c": 0.1, "k": 1.0, "g": 0.5, "F": 0.3, "w": 1.0, "W": 1.7}
    common = dict(mass=[["m"]], damping=[["c"]], stiffness=[["k"]],
                  nonlinear=[{"dof": "x", "coef": "g", "x": {"x": 3}}],
                  forcing=[{"dof": "x", "amplitude": "F", "order": 1}])
    model = polynomial_model(["x"], params, **common)
    declared = polynomial_model(["x"], params, frequency="W", **common)
    opts = HBOptions(harmonics=3, subharmonic=2)
    hb = HarmonicBalance(model, "W", opts, frequency="W")
    ref = HarmonicBalance(declared, "W", opts)
    assert model.frequency == "w" and hb.frequency == "W" and hb.frequency_moves
    p = hb.params_at(2.2)
    assert hb.excitation_frequency(p) == 2.2 and hb.base_frequency(p) == 1.1
    assert hb.period(p) == pytest.approx(2 * np.pi * 2 / 2.2, rel=1e-15)
    u = rng.normal(size=hb.size)
    for a, b in zip(hb.linearize(u, 2.2), ref.linearize(u, 2.2)):
        np.testing.assert_array_equal(a, b)
    # continued in another parameter, the frequency stays W at its value
    hk = hb.with_options(harmonics=2)
    assert hk.frequency == "W"
    hF = HarmonicBalance(model, "F", opts, frequency="W")
    assert not hF.frequency_moves and hF.base_frequency(hF.params_at(0.5)) == 1.7 / 2
    with pytest.raises(ValueError, match="unknown parameter 'V'"):
        HarmonicBalance(model, "F", opts, frequency="V")
