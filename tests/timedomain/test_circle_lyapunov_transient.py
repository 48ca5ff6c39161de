"""The Lyapunov exponents of an invariant circle average after a transient (contin.timedomain.invariant_circle).

A forced linear oscillator beside an uncoupled self-excited one, ``y'' - mu (a + y^2 - y^4) y' + om^2 y = 0``
with ``om = 0.25``: at ``a = -0.002`` its small limit cycle, born at the Hopf point ``a = 0`` on the side where
``y = 0`` is stable, is unstable, and the torus it makes with the forced orbit too. Its section is a thin
ellipse (axes 1 : om in ``(y, y')``), the case where the first normal basis, the complement of the tangent, is
far from the normal bundle's splitting. The cycle's transverse exponent comes from scipy alone: its period by
root finding on the return map (``solve_ivp``), its nontrivial multiplier ``exp(mu int (a + y^2 - y^4) dt)``
(the trace of the linearisation, for the other multiplier is 1), per forcing period ``log m T / T_c``.
"""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from contin.api.system import System
from contin.timedomain.invariant_circle import (TRANSIENT, CircleOptions, InvariantCircleProblem, circle_lyapunov,
                                               point_jacobians)

MU, W, F, OM, A = 0.2, 1.3, 0.5, 0.25, -0.002


def _rhs(t, z):
    y, v = z[:2]
    return [v, -OM ** 2 * y + MU * (A + y * y - y ** 4) * v]


def _return(Y):
    """From the maximum ``y = Y``: the next maximum and the time to it (scipy)."""
    def top(t, z):
        return z[1]
    top.direction = -1
    sol = solve_ivp(_rhs, (0.0, 6 * math.pi / OM), [Y, 0.0], events=top, rtol=1e-12, atol=1e-14)
    k = int(np.argmax(sol.t_events[0] > 1.0))
    return float(sol.y_events[0][k][0]), float(sol.t_events[0][k])


@pytest.fixture(scope="module")
def torus():
    """The circle of 15 points (256 RK4 steps a forcing period), solved by Newton from scipy's cycle, and the
    cycle's transverse exponent per forcing period (scipy)."""
    Y = brentq(lambda Y: _return(Y)[0] - Y, 0.05, 0.2, xtol=1e-15)
    Tc = _return(Y)[1]
    sol = solve_ivp(lambda t, z: [*_rhs(t, z), MU * (A + z[0] ** 2 - z[0] ** 4)], (0.0, Tc), [Y, 0.0, 0.0],
                    rtol=1e-12, atol=1e-14, dense_output=True)
    T = 2 * math.pi / W
    exact = float(sol.y[2, -1]) * T / Tc
    model = System(dofs=["x", "y"], parameters={"a": A, "mu": MU, "F": F, "w": W, "om2": OM ** 2},
                   mass=[[1, 0], [0, 1]], damping=[[0.1, 0], [0, 0]], stiffness=[[1, 0], [0, "om2"]],
                   forces=[{"dof": "y", "expr": "-mu*(a + y**2 - y**4)*y_dot"}],
                   excitation=[{"dof": "x", "expr": "F*cos(tau)"}], frequency="w").model
    N = 15
    Yp = sol.sol(Tc * np.arange(N) / N).T[:, :2]
    X = F / (1 - W ** 2 + 0.1j * W)  # the forced orbit at t = 0
    U0 = np.column_stack([np.full(N, X.real), Yp[:, 0], np.full(N, -W * X.imag), Yp[:, 1]])
    prob = InvariantCircleProblem(model, "a", options=CircleOptions(points=N, steps_per_period=256))
    prob.set_anchor(U0)
    x = prob.solve(prob.unknowns(U0, (T / Tc) % 1.0), A, tol=1e-11, max_iter=10)
    return prob, x, point_jacobians(prob, x, A, midpoints=True), exact


def test_after_the_transient_the_unstable_torus_reads_unstable_at_scipys_exponent(torus):
    prob, x, jac, exact = torus
    assert exact == pytest.approx(1.93e-3, rel=0.01)  # small and positive: near the Hopf point, unstable
    ly = circle_lyapunov(prob, x, A, iterations=4000, jacobians=jac)
    # measured: 2.18e-3, the tangential exponent -2.5e-4 (the averages' error, 1 / iterations)
    assert ly.stable is False and ly.largest_normal == pytest.approx(exact, abs=4e-4)
    # the forced oscillator's pair: -0.05 per unit time
    assert sorted(ly.exponents)[:2] == pytest.approx([-0.05 * 2 * math.pi / W] * 2, abs=4e-4)
    longer = circle_lyapunov(prob, x, A, iterations=4000, jacobians=jac, transient=3 * TRANSIENT)
    assert longer.largest_normal == pytest.approx(exact, abs=2e-4)


def test_without_the_transient_the_first_basis_reads_it_stable(torus):
    """The averages from the tangent's complement: the turn of the basis onto the thin ellipse's normal
    splitting enters them (-7.7e-3, measured), and the unstable torus reads stable."""
    prob, x, jac, exact = torus
    ly = circle_lyapunov(prob, x, A, iterations=4000, jacobians=jac, transient=0)
    assert ly.stable is True and ly.largest_normal < -exact


@pytest.mark.parametrize("bad", [-1, 1.5, True])
def test_a_transient_that_is_no_count_is_refused(torus, bad):
    prob, x, jac, _ = torus
    with pytest.raises(ValueError, match="transient: expected a non-negative integer"):
        circle_lyapunov(prob, x, A, iterations=10, jacobians=jac, transient=bad)

