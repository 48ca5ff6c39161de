"""Tests of contin.engine.corrector: the bordered Newton step and the checks of a converged step."""

import math

import numpy as np
import pytest

from contin.engine.corrector import Corrector, StepFailed, cycles, secant_offset
from contin.engine.options import ContinuationOptions
from contin.engine.problem import ScaledProblem


class Circle:
    """u^2 + lam^2 = 1."""

    def linearize(self, u, lam):
        return np.array([u[0] ** 2 + lam ** 2 - 1.0]), np.array([[2 * u[0]]]), np.array([2 * lam])


def corrector(**options):
    c = Corrector(ContinuationOptions(**options), "lambda", 1)
    c.sp = ScaledProblem(Circle(), 1, np.ones(1), 1.0)
    return c


def test_a_step_lands_on_the_curve_ahead_with_its_tangent():
    c = corrector()
    x, t = np.array([1.0, 0.0]), np.array([0.0, 1.0])
    cand = c.step(x, t, 0.1)
    assert cand.x @ cand.x == pytest.approx(1.0, abs=1e-10)
    assert float(t @ (cand.x - x)) == pytest.approx(0.1, abs=1e-14)  # on the hyperplane of the prediction
    assert cand.h == pytest.approx(0.1, abs=1e-14) and cand.lam == cand.x[1]
    np.testing.assert_allclose(cand.tangent, [-cand.x[1], cand.x[0]], atol=1e-10)
    assert c.n_newton == cand.iterations > 0 and c.sp.calls > cand.iterations


def test_a_turn_beyond_max_angle_fails_with_the_candidate():
    c = corrector(max_angle_deg=5.0)
    x, t = np.array([1.0, 0.0]), np.array([0.0, 1.0])
    with pytest.raises(StepFailed) as info:
        c.step(x, t, 0.2)
    angle, ds, cand = info.value.turn
    assert angle > 5.0 and ds == 0.2 and cand.x @ cand.x == pytest.approx(1.0, abs=1e-10)
    assert "tangent turned by" in info.value.reason


def test_landing_on_a_fixed_parameter():
    c = corrector()
    x, t = np.array([1.0, 0.0]), np.array([0.0, 1.0])
    cand = c.land(x, t, 0.2, 0.2, np.array([1.0, 0.2]))
    assert cand.lam == 0.2 and cand.u[0] == pytest.approx(math.sqrt(0.96), abs=1e-10) and cand.landed
    with pytest.raises(StepFailed, match="Newton did not converge at the range end lambda=2"):
        c.land(x, t, 2.0, 2.0, np.array([1.0, 2.0]))


def test_a_chord_leaning_off_the_tangents_is_a_jump():
    x, t = np.zeros(2), np.array([1.0, 0.0])
    # both tangents along the first axis, the chord at 45 deg: a jump to a neighbouring sheet
    why = secant_offset(x, t, np.array([1.0, 1.0]), t, 0.0, "lambda")
    assert "the chord leans 45.00 deg off the tangents" in why
    # an arc of the unit circle (turn theta, chord along the bisector) passes
    theta = 0.1
    a, ta = np.array([1.0, 0.0]), np.array([0.0, 1.0])
    b, tb = np.array([math.cos(theta), math.sin(theta)]), np.array([-math.sin(theta), math.cos(theta)])
    assert secant_offset(a, ta, b, tb, theta, "lambda") is None
    # the parameter moved against both end tangents (which say it increases)
    t2 = np.array([0.5, 0.5]) / math.sqrt(0.5)
    why = secant_offset(np.zeros(2), t2, np.array([1.0, -1e-2]), t2, 0.0, "lambda")
    assert why is not None


def test_cycles_tells_a_cycle_from_slow_convergence():
    assert cycles([1.0, 0.5, 0.8, 0.4, 0.9])
    assert not cycles([1.0, 0.9, 0.8, 0.7, 0.6])
    assert not cycles([1.0, 2.0, 0.5])


class Cycling:
    """``u^3 - 2u + 2 = 0`` (any ``lam``): Newton from ``u = 0`` cycles between 0 and 1 (residuals 2, 1, 2, ...)."""

    def __init__(self, jacobian_cost):
        self.jacobian_cost = jacobian_cost

    def residual(self, u, lam):
        return np.array([u[0] ** 3 - 2.0 * u[0] + 2.0])

    def linearize(self, u, lam):
        return self.residual(u, lam), np.array([[3.0 * u[0] ** 2 - 2.0]]), np.zeros(1)


@pytest.mark.parametrize("cost, retried", [(1.0, 1), (10.0, 0)])
def test_a_cycling_corrector_is_retried_with_halving_unless_its_jacobian_is_lazy(cost, retried):
    c = Corrector(ContinuationOptions(), "lambda", 1)
    c.sp = ScaledProblem(Cycling(cost), 1, np.ones(1), 1.0)
    assert c.sp.lazy is (cost >= 3.0)
    first = c.fixed_solve(0.0, np.zeros(1))
    assert c.n_backtracked == retried
    if not retried:  # the plain solve's cycle is the result: the step is retried shorter by the engine
        assert not first.converged and cycles(first.residual_history)
