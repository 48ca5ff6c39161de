"""Static equilibria (harmonic balance with H = 0), the static load and the linearisation about them, against closed
forms."""

import numpy as np
import pytest

from conftest import fd_jacobian
from contin.model.catalog import build_model
from contin.modal.equilibrium import (EquilibriumFailed, ModalError, solve_equilibrium, static_equilibrium,
                                      static_model, static_problem)
from contin.modal.static_path import equilibrium_path, linear_modes
from contin.models.polynomial import polynomial_model


def preloaded_duffing(P=2.0, g=0.5, k=1.0, c=0.1, cv=0.0):
    """m x'' + c x' + cv x^2 x' + k x + g x^3 = P + F cos(tau) (the forcing must not move the equilibrium)."""
    return polynomial_model(["x"], {"m": 1.0, "c": c, "k": k, "g": g, "cv": cv, "P": P, "F": 0.7, "w": 1.3},
                            mass=[["m"]], damping=[["c"]], stiffness=[["k"]],
                            nonlinear=[{"dof": "x", "coef": "g", "x": {"x": 3}},
                                       {"dof": "x", "coef": "cv", "x": {"x": 2}, "v": {"x": 1}}],
                            forcing=[{"dof": "x", "amplitude": "P", "order": 0},
                                     {"dof": "x", "amplitude": "F", "order": 1}])


def cubic_root(k, g, P):
    r = np.roots([g, 0.0, k, -P])
    return float(r[np.abs(r.imag) < 1e-12].real[0])


@pytest.mark.parametrize("P", [0.0, 0.3, 2.0, -5.0, 40.0])
def test_equilibrium_of_a_preloaded_duffing_is_the_cubic_root(P):
    model = preloaded_duffing(P, cv=0.4)
    hb = static_problem(model, "P")
    res = solve_equilibrium(hb, P)
    assert res.converged
    x = cubic_root(1.0, 0.5, P)  # k x + g x^3 = P
    assert abs(res.x[0] - x) <= 1e-10 * max(1.0, abs(x))
    eq = next(equilibrium_path(hb, [P]))
    # tangent stiffness k + 3 g x^2 and tangent damping c + cv x^2 (the velocity-dependent force)
    assert eq.K[0, 0] == pytest.approx(1.0 + 1.5 * x**2, rel=1e-10)
    assert eq.C[0, 0] == pytest.approx(0.1 + 0.4 * x**2, rel=1e-10)
    assert eq.M[0, 0] == 1.0


def test_static_load_is_the_period_mean_of_the_excitation():
    """The custom-scene form P + F cos(tau) in one expression: only P loads the equilibrium."""
    from contin.scene.custom_model import build_custom_model
    from contin.scene.parse import parse_scene

    scene = parse_scene("""
model:
  dofs: [x]
  parameters: {k: 2.0, g: 1.0, P: 3.0, F: 5.0, w: 1.0}
  mass: [[1]]
  stiffness: [[k]]
  forces: [{dof: x, expr: "g*x**3"}]
  excitation: [{dof: x, expr: "P + F*cos(tau) + 0.5*F*sin(2*tau)"}]
analysis: {type: modes}
""")
    model = build_custom_model(scene)
    hb = static_problem(model)
    res = solve_equilibrium(hb, 1.0)
    assert res.converged and res.x[0] == pytest.approx(cubic_root(2.0, 1.0, 3.0), rel=1e-12)


def test_the_static_load_of_each_kind_of_excitation():
    """A constant is its own mean (exactly), a harmonic forcing has none, any other form enters by its mean."""
    from contin.scene.custom_model import build_custom_model
    from contin.scene.parse import parse_scene

    scene = parse_scene("""
model:
  dofs: [x, y]
  parameters: {P: 0.3, F: 5.0, w: 1.0}
  mass: [[1, 0], [0, 1]]
  stiffness: [[1, 0], [0, 1]]
  excitation: [{dof: x, expr: "P"}, {dof: y, expr: "F*cos(tau)**2"}]
analysis: {type: modes}
""")
    hb = static_problem(build_custom_model(scene))
    f0, _ = hb.excitation(hb.p0)
    assert f0[0] == 0.3 and f0[1] == pytest.approx(2.5, rel=1e-14)
    duffing = preloaded_duffing(P=0.3)
    hb = static_problem(duffing)
    assert [el.order for el in hb.model.excitations] == [0.0]  # the forcing F cos(tau) is dropped
    assert hb.excitation(hb.p0)[0][0] == 0.3


def test_tangent_stiffness_matches_finite_differences(rng):
    model = polynomial_model(["x", "y"], {"k": 2.0, "kc": 0.5, "g": 0.7, "P": 0.3, "w": 1.0},
                             mass=[[1, 0], [0, 1]], stiffness=[["k", "-kc"], ["-kc", "k"]],
                             nonlinear=[{"dof": "x", "coef": "g", "x": {"x": 3}},
                                        {"dof": "y", "coef": "g", "x": {"x": 1, "y": 2}}],
                             forcing=[{"dof": "y", "amplitude": "P", "order": 0}])
    hb = static_problem(model, "P")
    x = rng.normal(size=2)
    _, Ju, Jlam = hb.linearize(x, 0.3)
    np.testing.assert_allclose(Ju, fd_jacobian(lambda v: hb.residual(v, 0.3), x), rtol=1e-7, atol=1e-9)
    np.testing.assert_allclose(Jlam, (hb.residual(x, 0.3 + 1e-6) - hb.residual(x, 0.3 - 1e-6)) / 2e-6, atol=1e-8)


def test_path_follows_the_equilibrium_and_stops_at_a_fold():
    # softening spring k x - g x^3 = P: the equilibrium folds at P = 2/(3 sqrt 3) sqrt(k^3/g)
    model = preloaded_duffing(0.0, g=-1.0)
    hb = static_problem(model, "P")
    fold = 2 / (3 * np.sqrt(3))
    values = [0.0, 0.9 * fold, 0.999 * fold]
    xs = [e.x[0] for e in equilibrium_path(hb, values)]
    for P, x in zip(values, xs):
        assert x - x**3 == pytest.approx(P, abs=1e-12) and x < 1 / np.sqrt(3)
    with pytest.raises(EquilibriumFailed, match=r"between P = 0 and 0.46\d* the static equilibrium folds at P = 0.3849001"):
        list(equilibrium_path(hb, [0.0, 1.2 * fold]))


def test_time_varying_forces_have_no_static_equilibrium():
    model = build_model("mathieu", {"eps": 0.3})
    with pytest.raises(ValueError, match="forces that vary in time have no static equilibrium"):
        static_model(model)
    assert static_model(build_model("mathieu", effects=["cubic"])).excitations == []
    with pytest.raises(ModalError, match="varies explicitly in time"):
        static_model(build_model("mathieu", {}))


def test_static_equilibrium_and_modes_about_it():
    model = build_model("timing_belt", {"p_s": 5.0}, ["rotor_mass", "stretching", "magnet", "static_load",
                                                       "periodic_load"])
    x0 = static_equilibrium(model)
    auto = static_model(model)
    assert len(auto.excitations) < len(model.excitations)  # the periodic load is gone, the constant loads stay
    omega, phi, _ = linear_modes(model, None, x0)
    M = model.linear(model.parameter_vector())[0]
    np.testing.assert_allclose(phi.T @ M @ phi, np.eye(5), atol=1e-12)
    assert np.all(np.diff(omega) > 0) and omega[0] > 0


def test_no_static_equilibrium_names_the_model():
    # a magnet pulling harder than the belt can resist, with no stretching to stop it: no equilibrium
    runaway = build_model("timing_belt", {"gamma0": 500.0, "gamma3": 0.0}, ["magnet"])
    with pytest.raises(EquilibriumFailed, match="no static equilibrium of 'timing_belt' found"):
        static_equilibrium(runaway)
