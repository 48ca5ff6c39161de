"""Tests of contin.engine.stepsize: the step control's rules and the scales of the variables."""

import math

import numpy as np
import pytest

from contin.engine.branch import BranchStatus
from contin.engine.corrector import Failure, StepFailed
from contin.engine.events import PointInfo
from contin.engine.options import ContinuationOptions
from contin.engine.stepsize import (
    EVENT_FLOOR,
    GROUP_SPREAD,
    ILL_RCOND,
    RESCALE_FACTOR,
    ScaleControl,
    StepKeeper,
    condition,
    rescaled_direction,
    rescaled_point,
)

OPTS = ContinuationOptions(ds=0.1, ds_min=1e-3, ds_max=0.4, grow=2.0, shrink=0.5, newton_easy=3, stall_points=3)


def no_diagnosis():
    return ""


def test_an_event_caps_the_step_but_not_below_its_floor():
    step = StepKeeper(OPTS)
    assert step.trial() == 0.1 and step.ds_free == 0.1
    step.event_cap = 0.03
    assert step.trial() == 0.03 and step.ds_free == 0.1
    step.event_cap = 1e-9
    assert step.trial() == max(OPTS.ds_min, EVENT_FLOOR * 0.1)


def test_steps_shrink_after_failures_grow_after_easy_steps_and_stay_within_bounds():
    step = StepKeeper(OPTS)
    failed = StepFailed("no convergence", rcond=1e-3)
    step.rejected(failed)
    step.shrink(0.1, failed, 1e-2, "lambda=0", no_diagnosis)
    assert step.ds == 0.05 and step.n_rejected == 1 and step.last_failure == "no convergence"
    step.ds = 1.5e-3
    step.shrink(1.5e-3, failed, 1e-2, "lambda=0", no_diagnosis)
    assert step.ds == OPTS.ds_min
    step.accepted(0.1, OPTS.newton_easy + 1)  # a hard step: no growth
    assert step.ds == OPTS.ds_min
    for _ in range(20):
        step.accepted(0.1, OPTS.newton_easy)
    assert step.ds == OPTS.ds_max


def test_a_failure_at_ds_min_or_on_an_ill_conditioned_point_ends_the_branch():
    step = StepKeeper(OPTS)
    failed = StepFailed("no convergence", rcond=1e-3)
    with pytest.raises(Failure) as info:
        step.shrink(OPTS.ds_min, failed, 1e-2, "lambda=0.5", lambda: "; condition estimate 1e+02")
    assert info.value.status is BranchStatus.STEP_TOO_SMALL
    assert info.value.message == ("step size fell below ds_min=0.001 at lambda=0.5; last failure: no convergence; "
                                  "condition estimate 1e+02")
    with pytest.raises(Failure) as info:
        step.shrink(OPTS.ds_min, StepFailed("singular", rcond=0.1 * ILL_RCOND), 1e-2, "lambda=0.5", no_diagnosis)
    assert info.value.status is BranchStatus.ILL_CONDITIONED and "near lambda=0.5" in info.value.message
    with pytest.raises(Failure) as info:
        step.shrink(0.1, failed, 0.1 * ILL_RCOND, "lambda=0.5", no_diagnosis)
    assert info.value.status is BranchStatus.ILL_CONDITIONED and "ill-conditioned at lambda=0.5" in info.value.message


def test_a_crawl_is_stall_points_steps_advancing_less_than_ds_max():
    step = StepKeeper(OPTS)
    step.ds = 0.1
    assert not step.crawled(0.1) and not step.crawled(0.1)
    assert step.crawled(0.1)  # 0.3 < ds_max = 0.4 over 3 points
    assert "the branch crawled: 3 points advanced 0.3" in step.crawl_message("lambda=1", "")
    step.ds = 0.2
    assert not step.crawled(0.01)  # cut short by an event: counted as the wanted step


def test_the_diagnosis_names_the_jacobians_growth_and_condition():
    step = StepKeeper(OPTS)
    step.jac_norm_start = 1.0
    info = PointInfo(u=np.zeros(1), lam=0.0, tangent=np.ones(2), Ju=np.array([[1e4]]), Jlam=np.zeros(1), det_sign=1,
                     rcond=1e-6)
    text = step.diagnosis(info, np.ones(1))
    assert "grew 1.0e+04-fold" in text and "condition estimate 1.0e+06" in text
    assert step.diagnosis(None, np.ones(1)) == ""
    assert condition(0.0) == math.inf and math.isnan(condition(math.nan)) and condition(0.5) == 2.0


class Scaled:
    def __init__(self, scale=None, groups=None):
        self.scale, self.groups = scale, groups

    def unknown_scale(self):
        return self.scale

    def unknown_groups(self):
        return self.groups


def test_initial_scales():
    auto = ContinuationOptions()
    su, sl = ScaleControl(Scaled(), auto, 2).initial(np.array([0.0, -3.0]), 0.5, 0.0, 4.0)
    np.testing.assert_array_equal(su, [3.0, 3.0])
    assert sl == 4.0  # the range
    _, sl = ScaleControl(Scaled(), auto, 2).initial(np.array([0.0, -3.0]), -5.0, -math.inf, 4.0)
    assert sl == 5.0  # |lam0| for an infinite range
    scales = ScaleControl(Scaled(scale=[2.0, 0.0]), auto, 2)
    su, _ = scales.initial(np.array([1.0, 1.0]), 0.0, 0.0, 1.0)
    np.testing.assert_array_equal(su, [2.0, 2.0])  # non-positive components replaced by the largest
    assert not scales.adaptive_scale
    su, sl = ScaleControl(Scaled(), ContinuationOptions(scaling="none"), 2).initial(np.array([5.0, 5.0]), 3.0, 0.0, 9.0)
    np.testing.assert_array_equal(su, [1.0, 1.0])
    assert sl == 1.0
    with pytest.raises(ValueError):
        ScaleControl(Scaled(), ContinuationOptions(unknown_scale=[1.0, 1.0, 1.0]), 2).initial(np.ones(2), 0.0, 0.0, 1.0)


def test_groups_far_apart_get_their_own_scale_and_the_scale_grows_with_the_unknowns():
    far = 10 * GROUP_SPREAD
    scales = ScaleControl(Scaled(groups=["a", "a", "b"]), ContinuationOptions(), 3)
    su, _ = scales.initial(np.array([1.0, -far, 0.5]), 0.0, 0.0, 1.0)
    np.testing.assert_array_equal(su, [far, far, 0.5])
    np.testing.assert_array_equal(scales.groups, [0, 0, 1])
    assert scales.adaptive_scale
    assert scales.grow(su, np.array([1.0, far, 0.5 * RESCALE_FACTOR]), 0.3) is None  # not beyond the factor
    f = scales.grow(su, np.array([1.0, far, 0.6 * RESCALE_FACTOR]), 0.4)
    np.testing.assert_allclose(f, [1.0, 1.0, 0.6 * RESCALE_FACTOR / 0.5])
    np.testing.assert_array_equal(su, [far, far, 0.6 * RESCALE_FACTOR])
    assert scales.rescalings == [(0.4, far, far)]
    x = np.array([1.0, 2.0, 3.0, 4.0])
    np.testing.assert_allclose(rescaled_point(x, f), [1.0, 2.0, 3.0 / f[2], 4.0])
    t = rescaled_direction(x / np.linalg.norm(x), f)
    assert np.linalg.norm(t) == pytest.approx(1.0) and np.all(np.sign(t) == np.sign(x))


def test_close_groups_share_one_scale():
    scales = ScaleControl(Scaled(groups=[0, 1]), ContinuationOptions(), 2)
    su, _ = scales.initial(np.array([1.0, 2.0]), 0.0, 0.0, 1.0)
    np.testing.assert_array_equal(su, [2.0, 2.0])
    np.testing.assert_array_equal(scales.groups, [0, 0])
