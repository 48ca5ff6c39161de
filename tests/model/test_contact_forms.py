"""The contact elements' compiled Jacobian and gradient lines against central differences of their compiled
right-hand side and switching functions, state by state, in every mode and on both branches of a clipped law."""

import numpy as np
import pytest

from contin.model.catalog import build_model
from contin.model.elements import GapForce
from contin.model.base import Monomial
from contin.models.polynomial import polynomial_model
from contin.timedomain.variational import VariationalFlow

H = 1e-7  # central differences: error ~1e-14 / H + H^2 * (third derivative)


def lines_at(flow, y, mode):
    """``B`` (n, 2n), the lower rows of the state matrix, and ``G`` (NS, 2n), the switching functions'
    gradients, as the generated module's ``jac`` and ``switch_grad`` give them at the state ``y``."""
    model, mod = flow.model, flow.module
    n, ns = model.n_dof, flow.n_switch
    p = model.parameter_vector()
    Minv, C, K, cst = flow.compiled.arguments(p)
    X, V, TAU, F = np.zeros((1, n)), np.zeros((1, n)), np.zeros(1), np.zeros((1, n))
    B, G = np.zeros((n, 2 * n)), np.zeros((ns, 2 * n))
    mod.jac(y, 0.3, p, Minv, C, K, cst, np.asarray(mode, dtype=np.int64), X, V, TAU, F, np.zeros((1, n, n)),
            np.zeros((1, n, n)), B)
    mod.switch_grad(y, p, cst, X, V, G)
    return B, G


def differences(flow, y, mode):
    """The same by central differences of the compiled right-hand side (in the frozen ``mode``) and of the
    switching functions."""
    model = flow.model
    n, p = model.n_dof, model.parameter_vector()
    B, G = np.empty((n, 2 * n)), np.empty((flow.n_switch, 2 * n))
    for j in range(2 * n):
        e = np.zeros(2 * n)
        e[j] = H
        B[:, j] = (flow.compiled.rhs(y + e, 0.3, p, mode)[n:] - flow.compiled.rhs(y - e, 0.3, p, mode)[n:]) / (2 * H)
        G[:, j] = (flow.compiled.switching(y + e, p) - flow.compiled.switching(y - e, p)) / (2 * H)
    return B, G


def check(flow, y, mode):
    B, G = lines_at(flow, y, mode)
    Bd, Gd = differences(flow, y, mode)
    np.testing.assert_allclose(B, Bd, rtol=1e-6, atol=1e-6 * np.max(np.abs(Bd)))
    np.testing.assert_allclose(G, Gd, rtol=1e-6, atol=1e-7)


@pytest.mark.parametrize("clip", [False, True])
def test_the_gaps_jacobian_and_gradient_lines_are_the_derivatives(clip):
    model = polynomial_model(["x"], {"c": 0.05, "F": 0.2, "w": 0.9}, mass=[[1.0]], damping=[["c"]],
                             stiffness=[[1.0]], forcing=[{"dof": "x", "amplitude": "F"}])
    model.forces.append(GapForce(0, Monomial(1.0), Monomial(20.0), Monomial(0.4), sides="both", clip=clip))
    flow = VariationalFlow(model, steps_per_period=64)
    # inside the clearance; in the upper stop, moving in and (with clip: the force's branch of the min) out
    # fast; in the lower stop
    for y, mode in (([0.3, 0.1], [0, 0]), ([1.2, 0.5], [1, 0]), ([1.2, -30.0], [1, 0]), ([-1.1, 0.2], [0, 1])):
        check(flow, np.array(y), mode)


@pytest.mark.slow  # the rotor's own module (~20 s to compile without the kernel cache)
@pytest.mark.parametrize("clip", [False, True])
def test_the_radial_gaps_jacobian_and_gradient_lines_are_the_derivatives(clip):
    model = build_model("bearing_rotor", {"f0": 0.5, "w": 2.16}, clip=clip)
    flow = VariationalFlow(model, steps_per_period=64)
    rng = np.random.default_rng(7)
    delta = float(model.parameter_vector()[list(model.param_names).index("delta")])
    for mode, radius, speed in (([0], 0.5, 0.3), ([1], 1.2, 0.3), ([1], 1.2, -40.0)):
        y = rng.normal(size=2 * model.n_dof)
        angle = rng.uniform(0.0, 2.0 * np.pi)
        # the bearing (dofs 2, 3) at radius * delta, moving radially at speed (into the casing or out of it fast)
        y[2:4] = radius * delta * np.array([np.cos(angle), np.sin(angle)])
        y[6:8] = speed * np.array([np.cos(angle), np.sin(angle)]) + 0.1 * rng.normal(size=2)
        check(flow, y, mode)
