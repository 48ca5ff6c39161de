"""Tests of contin.engine.step_control: a caller's step-size rule drives the steps, and resumes exactly."""

import copy
import math

import numpy as np
import pytest

from contin.engine.branch import BranchStatus
from contin.engine.continuation import ContinuationOptions, continuation
from contin.engine.step_control import AdaptiveStep, as_step_control


class Circle:
    """u^2 + lam^2 = 1."""

    def linearize(self, u, lam):
        return np.array([u[0] ** 2 + lam**2 - 1.0]), np.array([[2 * u[0]]]), np.array([2 * lam])


class NaNBeyond:
    """u = lam, with a NaN residual beyond lam = 0.5 (every step past it fails)."""

    def linearize(self, u, lam):
        R = np.array([u[0] - lam]) if lam <= 0.5 else np.array([np.nan])
        return R, np.array([[1.0]]), np.array([-1.0])


class FixedStep:
    """Every step ``ds``, failed or not."""

    def __init__(self, ds):
        self.ds = ds

    def first(self, options):
        return self.ds

    def accepted(self, ds, taken, iterations):
        return self.ds

    def rejected(self, ds, reason):
        return self.ds


class Cycle:
    """Steps cycling through STEPS with the stored points: the place in the cycle is the rule's own state."""

    STEPS = (0.03, 0.05, 0.08)

    def __init__(self):
        self.k = 0

    def first(self, options):
        self.k = 0
        return self.STEPS[0]

    def accepted(self, ds, taken, iterations):
        self.k += 1
        return self.STEPS[self.k % len(self.STEPS)]

    def rejected(self, ds, reason):
        return 0.5 * ds

    def state(self):
        return {"k": self.k}

    def restore(self, state):
        self.k = int(state["k"])


# a unit circle in the scaled coordinates (no scaling), without the events that shorten steps near folds
PLAIN = ContinuationOptions(ds=0.02, ds_max=0.2, scaling="none", detect_folds=False, detect_branch_points=False)


def test_a_fixed_step_rule_takes_every_step_at_its_length_on_the_closed_form_branch():
    br = continuation(Circle(), [1.0], 0.0, (-2.0, 2.0), PLAIN, step_control=FixedStep(0.1))
    assert br.status is BranchStatus.CLOSED_LOOP
    # the pseudo-arclength constraint makes each step's length the rule's, to rounding
    np.testing.assert_allclose(br.step_sizes[1:], 0.1, rtol=1e-12)
    np.testing.assert_allclose(br.unknowns[:, 0] ** 2 + br.parameter**2, 1.0, atol=1e-10)
    # once round the circle: 2 pi / 0.1 steps of 0.1 along its chords' projections
    assert abs(len(br) - 2 * math.pi / 0.1) < 3
    default = continuation(Circle(), [1.0], 0.0, (-2.0, 2.0), PLAIN.replace(max_points=12))
    assert np.ptp(default.step_sizes[1:]) > 0.05  # the default rule grows its steps: the rule above was used


def test_the_default_rule_given_explicitly_is_the_default():
    opts = ContinuationOptions(max_points=40)
    a = continuation(Circle(), [1.0], 0.0, (-2.0, 2.0), opts, step_control=AdaptiveStep())
    b = continuation(Circle(), [1.0], 0.0, (-2.0, 2.0), opts)
    np.testing.assert_array_equal(a.unknowns, b.unknowns)
    np.testing.assert_array_equal(a.step_sizes, b.step_sizes)
    assert a.info["n_rejected_steps"] == b.info["n_rejected_steps"]


def test_a_rule_that_does_not_shorten_a_failed_step_ends_the_branch_saying_so():
    br = continuation(NaNBeyond(), [0.0], 0.0, (0.0, 1.0), step_control=FixedStep(0.1))
    assert br.status is BranchStatus.STEP_TOO_SMALL
    assert "the step control (FixedStep) did not shorten it (it asked for 0.1)" in br.message
    assert 0.5 - 0.1 < br.parameter[-1] <= 0.5  # the last step of 0.1 before the NaN residual


class Missing:
    def first(self, options):
        return 0.1

    def accepted(self, ds, taken, iterations):
        return ds


@pytest.mark.parametrize("rule, match", [
    (Missing(), "step_control Missing has no method rejected"),
    (object(), "has no method first, accepted, rejected"),
    (FixedStep, "step_control must be an instance, got the class FixedStep"),
])
def test_a_rule_without_its_methods_is_refused_naming_them(rule, match):
    with pytest.raises(TypeError, match=match):
        continuation(Circle(), [1.0], 0.0, (-2.0, 2.0), step_control=rule)
    assert isinstance(as_step_control(None), AdaptiveStep)


class Returns(FixedStep):
    def accepted(self, ds, taken, iterations):
        return self.ds_next

    ds_next = math.nan


@pytest.mark.parametrize("value", [math.nan, -0.1, 0.0, math.inf, "0.1", None])
def test_a_rule_returning_no_step_is_refused_naming_the_method(value):
    rule = Returns(0.05)
    rule.ds_next = value
    with pytest.raises(ValueError, match=r"step_control.accepted returned .*; expected a positive finite step"):
        continuation(Circle(), [1.0], 0.0, (-2.0, 2.0), PLAIN, step_control=rule)


def test_the_steps_stay_within_ds_min_and_ds_max():
    br = continuation(Circle(), [1.0], 0.0, (-2.0, 2.0), PLAIN.replace(ds_max=0.05, max_points=10),
                      step_control=FixedStep(10.0))
    np.testing.assert_allclose(br.step_sizes[1:], 0.05, rtol=1e-12)


def test_a_resumed_run_with_a_stateful_rule_equals_the_uninterrupted_one():
    states = []

    def checkpoint(branch, state):
        if "points" in state:
            states.append((copy.deepcopy(branch), copy.deepcopy(state)))

    opts = PLAIN.replace(max_points=30)
    full = continuation(Circle(), [1.0], 0.0, (-2.0, 2.0), opts, step_control=Cycle(), checkpoint=checkpoint)
    np.testing.assert_allclose(full.step_sizes[1:4], Cycle.STEPS, rtol=1e-12)
    assert all(state["step_control"] == {"k": len(branch) - 1} for branch, state in states)
    for k in (1, len(states) // 2, len(states) - 1):
        branch, state = states[k]
        rest = continuation(Circle(), [1.0], 0.0, (-2.0, 2.0), opts, step_control=Cycle(),
                            restart=(branch, state))
        assert rest.status is full.status and rest.message == full.message
        np.testing.assert_array_equal(rest.unknowns, full.unknowns)
        np.testing.assert_array_equal(rest.step_sizes, full.step_sizes)
    branch, state = states[3]
    with pytest.raises(ValueError, match="the state holds the step control's state, but FixedStep has no restore"):
        continuation(Circle(), [1.0], 0.0, (-2.0, 2.0), opts, step_control=FixedStep(0.05), restart=(branch, state))


def test_the_default_rule_keeps_no_state_of_its_own():
    states = []
    continuation(Circle(), [1.0], 0.0, (-2.0, 2.0), ContinuationOptions(max_points=10),
                 checkpoint=lambda b, s: states.append(s))
    assert all(s["step_control"] is None for s in states[:-1])
