"""Plain steps of an invariant circle in the parameter (contin.bifurcation.circle_steps): the forced van der Pol
oscillator's circle stepped down to the arclength branch's end, and stopped where it collapses at the
Neimark-Sacker point."""

import numpy as np
import pytest

from contin.bifurcation.circle_steps import COLLAPSED, step_circle
from van_der_pol_model import W_NS, vdp_circle_branch

@pytest.fixture(scope="module")
def circle():
    """A circle of 21 points at w = 0.94, 1.1e-2 below the Neimark-Sacker point, and the arclength branch from
    the point down to 0.92."""
    prob, br = vdp_circle_branch(0.92)
    i = int(np.argmin(np.abs(br.parameter - 0.94)))
    return prob, prob.solve(br.unknowns[i], 0.94, tol=1e-11, max_iter=8), br


def test_steps_down_reach_the_end_on_the_arclength_branchs_circle(circle):
    prob, u, br = circle
    seen = []
    steps = step_circle(prob, u, 0.94, -0.005, 0.92, measure=lambda x, lam: {"rho": float(x[-1])},
                        callback=lambda lam, x, its, row: seen.append(lam))
    assert steps.reached and steps.message == "reached w=0.92"
    assert steps.parameter[0] == 0.94 and steps.parameter[-1] == pytest.approx(0.92, abs=1e-14)
    assert np.all(np.diff(steps.parameter) < 0) and np.all(np.diff(steps.parameter) >= -0.005 - 1e-14)
    assert seen == list(steps.parameter[1:]) and len(steps.rows) == len(steps.parameter)
    for lam, x, row in zip(steps.parameter, steps.unknowns, steps.rows):
        assert np.abs(prob.residual(x, lam)).max() < 1e-8  # every circle solves the invariance equation
        assert row["rho"] == x[-1]
    # the same discrete circle (same anchor) as the engine's branch at its end
    assert br.parameter[-1] == pytest.approx(0.92)
    np.testing.assert_allclose(steps.unknowns[-1], br.unknowns[-1], atol=1e-7)


def test_steps_up_stop_where_the_circle_collapses_at_the_neimark_sacker_point(circle):
    prob, u, _ = circle
    steps = step_circle(prob, u, 0.94, 0.004, 0.96, min_step=1e-5)
    # Newton beyond the point lands on the periodic orbit (every point on it solves the equations): not kept
    assert not steps.reached
    assert W_NS - 1e-4 < steps.parameter[-1] < W_NS and "collapses onto a periodic orbit" in steps.message
    spread = [np.ptp(prob.blocks(x)[0], axis=0).max() for x in steps.unknowns]
    assert np.all(np.diff(spread) < 0) and spread[-1] > COLLAPSED * spread[0]  # shrinking onto the orbit


def test_a_step_away_from_the_end_is_refused(circle):
    prob, u, _ = circle
    with pytest.raises(ValueError, match="must point from 0.94 towards 0.92"):
        step_circle(prob, u, 0.94, 0.01, 0.92)
    with pytest.raises(ValueError, match="min_step must be positive"):
        step_circle(prob, u, 0.94, -0.01, 0.92, min_step=0.0)
