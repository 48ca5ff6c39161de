"""Tests of the continuation engine on problems with closed-form solutions."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from contin.engine.branch import Branch, BranchStatus, SpecialKind
from contin.engine.continuation import ContinuationOptions, Problem, Scaling, continuation
from contin.engine.events import FunctionEvent

FOLD_LAM = 2.0 / (3.0 * math.sqrt(3.0))
PLASTIC = 1.324717957244746  # real root of x^3 - x - 1


# --------------------------------------------------------------------------
# analytic problems
# --------------------------------------------------------------------------
class Circle:
    """u^2 + lam^2 = r^2."""

    def __init__(self, r=1.0):
        self.r = r

    def residual(self, u, lam):
        return np.array([u[0] ** 2 + lam**2 - self.r**2])

    def linearize(self, u, lam):
        return self.residual(u, lam), np.array([[2 * u[0]]]), np.array([2 * lam])


class Cubic:
    """x^3 - x - lam = 0: an S-curve with folds at lam = +-2/(3 sqrt 3)."""

    def residual(self, u, lam):
        return np.array([u[0] ** 3 - u[0] - lam])

    def linearize(self, u, lam):
        return self.residual(u, lam), np.array([[3 * u[0] ** 2 - 1]]), np.array([-1.0])


class Transcritical:
    """u (lam - u) = 0: branches u = 0 and u = lam cross at (0, 0)."""

    def residual(self, u, lam):
        return np.array([u[0] * (lam - u[0])])

    def linearize(self, u, lam):
        return self.residual(u, lam), np.array([[lam - 2 * u[0]]]), np.array([u[0]])


class Pitchfork2:
    """[a (lam - a^2 - b^2), b - a^2]: pitchfork from a = b = 0 at lam = 0."""

    def residual(self, u, lam):
        a, b = u
        return np.array([a * (lam - a * a - b * b), b - a * a])

    def linearize(self, u, lam):
        a, b = u
        Ju = np.array([[lam - 3 * a * a - b * b, -2 * a * b], [-2 * a, 1.0]])
        return self.residual(u, lam), Ju, np.array([a, 0.0])


class SmallCubic:
    """The S-curve squeezed to unknowns of size 1e-3 around lam = 2.

    v^3 - v = (lam - 2) / 0.1 with v = u0 / 1e-3, and u1 = 1e-3 sin(v).
    Folds at lam = 2 -+ 0.1 * 2 / (3 sqrt 3).
    """

    def __init__(self, give_scale=False):
        self.give_scale = give_scale

    def residual(self, u, lam):
        v = u[0] / 1e-3
        return np.array([v**3 - v - (lam - 2.0) / 0.1, u[1] - 1e-3 * np.sin(v)])

    def linearize(self, u, lam):
        v = u[0] / 1e-3
        Ju = np.array([[(3 * v * v - 1) / 1e-3, 0.0], [-np.cos(v), 1.0]])
        return self.residual(u, lam), Ju, np.array([-10.0, 0.0])

    def unknown_scale(self):
        return np.array([1e-3, 1e-3]) if self.give_scale else None


class NaNBeyond:
    """u = lam, but the residual is NaN for lam > 0.5."""

    def residual(self, u, lam):
        return np.array([u[0] - lam]) if lam <= 0.5 else np.array([np.nan])

    def linearize(self, u, lam):
        return self.residual(u, lam), np.array([[1.0]]), np.array([-1.0])


class RaisesBeyond(NaNBeyond):
    def linearize(self, u, lam):
        if lam > 0.5:
            raise ZeroDivisionError("pole")
        return super().linearize(u, lam)


class NoRealRoot:
    def residual(self, u, lam):
        return np.array([u[0] ** 2 + 1.0])

    def linearize(self, u, lam):
        return self.residual(u, lam), np.array([[2 * u[0]]]), np.array([0.0])


def lowest_cubic_root(lam):
    roots = np.roots([1.0, 0.0, -1.0, -lam])
    return float(np.min(roots[np.abs(roots.imag) < 1e-9].real))


def assert_all_finite(branch):
    for arr in (branch.parameter, branch.unknowns, branch.tangents, branch.arclength,
                branch.step_sizes, branch.residual_norms):
        assert np.all(np.isfinite(arr))
    for arr in branch.point_data.values():
        assert np.all(np.isfinite(arr))


def max_residual(problem, branch):
    return max(float(np.max(np.abs(problem.residual(u, lam)))) for u, lam in zip(branch.unknowns, branch.parameter))


# --------------------------------------------------------------------------
# folds, loops, range ends
# --------------------------------------------------------------------------
def test_circle_closed_loop_with_two_folds():
    prob = Circle()
    br = continuation(prob, [1.0], 0.0, (-2.0, 2.0))
    assert br.status is BranchStatus.CLOSED_LOOP, br.message
    assert max_residual(prob, br) <= 1e-10
    folds = br.points_of_kind(SpecialKind.FOLD)
    assert len(folds) == 2
    assert folds[0].parameter == pytest.approx(1.0, abs=1e-10)
    assert folds[1].parameter == pytest.approx(-1.0, abs=1e-10)
    for f in folds:
        assert f.located
        assert abs(f.unknowns[0]) < 1e-4  # u = 0 at the folds
        assert prob.residual(f.unknowns, f.parameter)[0] == pytest.approx(0.0, abs=1e-10)
        # a fold is an extremum of lam: beyond both bracketing points
        assert f.interval == (br.parameter[f.index], br.parameter[f.index + 1])
        assert abs(f.parameter) >= max(abs(v) for v in f.interval)
        assert br.arclength[f.index] < f.s < br.arclength[f.index + 1]
        assert f.test_values[0] * f.test_values[1] < 0
    assert br.points_of_kind("bp") == []
    # went all the way round: both halves visited, angle covers 2 pi
    angles = np.unwrap(np.arctan2(br.unknowns[:, 0], br.parameter))
    assert abs(angles[-1] - angles[0]) >= 2 * np.pi - 0.5
    np.testing.assert_allclose(np.linalg.norm(br.tangents, axis=1), 1.0, atol=1e-12)
    assert np.all(np.diff(br.arclength) > 0)
    assert br.info["parameter_scale"] == 4.0
    assert_all_finite(br)


@pytest.mark.parametrize("direction", [1, -1])
def test_s_curve_through_both_folds(direction):
    prob = Cubic()
    lam0, lam_end = (-1.0, 1.0) if direction == 1 else (1.0, -1.0)
    u0 = [-1.3] if direction == 1 else [1.3]
    opts = ContinuationOptions(direction=direction)
    br = continuation(prob, u0, lam0, (-1.0, 1.0), opts)
    assert br.status is BranchStatus.RANGE_END, br.message
    assert br.parameter[0] == lam0
    assert br.parameter[-1] == lam_end  # bit for bit
    assert br.unknowns[-1, 0] == pytest.approx(-direction * -PLASTIC, abs=1e-10)
    assert br.unknowns[0, 0] == pytest.approx(-direction * PLASTIC, abs=1e-10)
    assert max_residual(prob, br) <= 1e-10
    folds = br.points_of_kind(SpecialKind.FOLD)
    assert [round(f.parameter / FOLD_LAM) for f in folds] == [direction, -direction]
    for f in folds:
        assert f.located
        assert abs(abs(f.parameter) - FOLD_LAM) <= 1e-10 * max(1.0, FOLD_LAM)
        assert abs(f.unknowns[0]) == pytest.approx(1 / math.sqrt(3), abs=1e-8)
    assert br.points_of_kind(SpecialKind.BP) == []
    (end,) = br.points_of_kind(SpecialKind.END)
    assert end.parameter == lam_end and end.index == len(br) - 1
    # the S-curve was traversed: u is monotonic along the branch
    assert np.all(np.diff(br.unknowns[:, 0]) * direction > 0)
    assert_all_finite(br)


def test_start_exactly_at_range_end_moving_out():
    br = continuation(Cubic(), [1.3], 1.0, (-1.0, 1.0))
    assert br.status is BranchStatus.RANGE_END
    assert len(br) == 1
    assert br.points_of_kind("end")[0].parameter == 1.0


def test_infinite_range_stops_at_max_points():
    br = continuation(Cubic(), [-1.3], -1.0, (-math.inf, math.inf), ContinuationOptions(max_points=15))
    assert br.status is BranchStatus.MAX_POINTS
    assert len(br) == 15
    assert br.info["parameter_scale"] == 1.0


def test_circle_start_at_fold_without_start_solve():
    # fixed-lam Newton is singular at a fold; solve_start=False corrects on the
    # hyperplane instead, and the given tangent fixes the orientation
    prob = Circle()
    for sign in (1.0, -1.0):
        br = continuation(prob, [0.0], 1.0, (-2.0, 2.0), ContinuationOptions(max_points=4),
                          tangent=[sign, 0.0], solve_start=False)
        assert len(br) == 4
        assert np.all(np.diff(br.unknowns[:, 0]) * sign > 0)
        assert br.parameter[0] == 1.0
        assert max_residual(prob, br) <= 1e-10


def test_solve_start_false_corrects_an_inexact_start():
    br = continuation(Circle(), [0.9], 0.0, (-2.0, 2.0), ContinuationOptions(max_points=3), solve_start=False)
    assert br.unknowns[0, 0] ** 2 + br.parameter[0] ** 2 == pytest.approx(1.0, abs=1e-10)


def test_resume_from_a_stored_point():
    prob = Cubic()
    first = continuation(prob, [-1.3], -1.0, (-1.0, 1.0), ContinuationOptions(max_points=14))
    assert first.status is BranchStatus.MAX_POINTS
    args = first.resume_arguments(-1)
    rest = continuation(prob, lam_range=(-1.0, 1.0), **args)
    # it set out towards -1 (on the middle part of the S), turned at the lower fold and ended at +1
    assert rest.status is BranchStatus.TURNED_BACK
    assert rest.info["uncovered"] == pytest.approx((-1.0, -FOLD_LAM), abs=1e-9)
    assert rest.parameter[-1] == 1.0
    assert rest.unknowns[-1, 0] == pytest.approx(PLASTIC, abs=1e-10)
    n_folds = len(first.points_of_kind("fold")) + len(rest.points_of_kind("fold"))
    assert n_folds == 2


# --------------------------------------------------------------------------
# branch points
# --------------------------------------------------------------------------
@pytest.mark.parametrize("ds", [0.02, 0.2])
@pytest.mark.parametrize("on_diagonal", [True, False])
def test_transcritical_branch_point(ds, on_diagonal):
    prob = Transcritical()
    u0 = [-1.0] if on_diagonal else [0.0]
    br = continuation(prob, u0, -1.0, (-1.0, 1.0), ContinuationOptions(ds=ds, ds_max=max(ds, 0.2)))
    assert br.status is BranchStatus.RANGE_END, br.message
    (bp,) = br.points_of_kind(SpecialKind.BP)
    assert bp.located
    assert abs(bp.parameter) <= 1e-9
    assert bp.interval[0] < 0 < bp.interval[1] or 0 in bp.interval
    # never jumped onto the other branch
    expected = br.parameter if on_diagonal else np.zeros(len(br))
    np.testing.assert_allclose(br.unknowns[:, 0], expected, atol=1e-10)
    assert br.points_of_kind(SpecialKind.FOLD) == []


def test_pitchfork_branch_point_two_unknowns():
    prob = Pitchfork2()
    br = continuation(prob, [0.0, 0.0], -1.0, (-1.0, 1.0))
    assert br.status is BranchStatus.RANGE_END
    (bp,) = br.points_of_kind("bp")
    assert bp.parameter == pytest.approx(0.0, abs=1e-9)
    assert np.all(br.unknowns == 0.0)


def test_branch_point_detection_can_be_disabled():
    opts = ContinuationOptions(detect_branch_points=False, detect_folds=False)
    br = continuation(Transcritical(), [0.0], -1.0, (-1.0, 1.0), opts)
    assert [p.kind for p in br.special_points] == [SpecialKind.START, SpecialKind.END]


# --------------------------------------------------------------------------
# scaling
# --------------------------------------------------------------------------
def small_cubic_start():
    v = lowest_cubic_root((1.8 - 2.0) / 0.1)
    return np.array([1e-3 * v, 1e-3 * math.sin(v)])


@pytest.mark.parametrize("give_scale", [False, True])
def test_scaling_small_unknowns(give_scale):
    prob = SmallCubic(give_scale)
    br = continuation(prob, small_cubic_start(), 1.8, (1.8, 2.2))
    assert br.status is BranchStatus.RANGE_END, br.message
    assert br.parameter[-1] == 2.2
    folds = br.points_of_kind("fold")
    assert [f.parameter for f in folds] == pytest.approx([2.0 + 0.1 * FOLD_LAM, 2.0 - 0.1 * FOLD_LAM], abs=1e-10)
    assert len(br) <= 60
    assert br.info["n_rejected_steps"] <= 10
    assert max_residual(prob, br) <= 1e-10
    su = br.info["unknown_scale"]
    if give_scale:
        np.testing.assert_array_equal(su, [1e-3, 1e-3])
    else:  # one scalar from the start point
        assert su[0] == su[1] == pytest.approx(np.max(np.abs(br.unknowns[0])))
    assert br.info["parameter_scale"] == pytest.approx(0.4)


def test_without_scaling_the_small_problem_is_much_harder():
    prob = SmallCubic()
    auto = continuation(prob, small_cubic_start(), 1.8, (1.8, 2.2))
    none = continuation(prob, small_cubic_start(), 1.8, (1.8, 2.2), ContinuationOptions(scaling=Scaling.NONE))
    assert none.info["parameter_scale"] == 1.0 and np.all(none.info["unknown_scale"] == 1.0)
    traced = none.status is BranchStatus.RANGE_END and len(none.points_of_kind("fold")) == 2 and none.parameter[-1] == 2.2
    # unscaled, the curve is either not traced correctly or needs far more work
    assert not traced or none.info["n_linearizations"] >= 2 * auto.info["n_linearizations"]


def test_explicit_scales_override():
    opts = ContinuationOptions(parameter_scale=3.0, unknown_scale=[2.0])
    br = continuation(Cubic(), [-1.3], -1.0, (-1.0, 1.0), opts)
    assert br.info["parameter_scale"] == 3.0
    np.testing.assert_array_equal(br.info["unknown_scale"], [2.0])
    assert br.status is BranchStatus.RANGE_END


# --------------------------------------------------------------------------
# failure paths
# --------------------------------------------------------------------------
def test_start_failure_is_a_status_not_an_exception():
    br = continuation(NoRealRoot(), [1.0], 0.0, (0.0, 1.0))
    assert br.status is BranchStatus.START_FAILED
    assert len(br) == 0
    assert br.unknowns.shape == (0, 1)
    assert "start parameter lambda=0" in br.message
    assert "Newton did not converge" in br.message


@pytest.mark.parametrize("problem", [NaNBeyond(), RaisesBeyond()])
def test_problem_that_becomes_impossible(problem):
    br = continuation(problem, [0.0], 0.0, (0.0, 1.0))
    assert br.status in (BranchStatus.STEP_TOO_SMALL, BranchStatus.NEWTON_FAILED)
    assert len(br) > 3
    assert br.parameter[-1] == pytest.approx(0.5, abs=1e-6)
    assert "lambda=0.4999" in br.message or "lambda=0.5" in br.message
    assert "ds_min" in br.message
    np.testing.assert_allclose(br.unknowns[:, 0], br.parameter, atol=1e-12)
    assert_all_finite(br)


def test_non_finite_monitor_ends_with_newton_failed():
    def monitor(u, lam, Ju, Jlam):
        return {"m": np.nan if lam > 0.3 else lam}

    br = continuation(Cubic(), [-1.3], -1.0, (-1.0, 1.0), monitors=[monitor])
    assert br.status is BranchStatus.NEWTON_FAILED
    assert "not stored" in br.message and "lambda=" in br.message
    assert np.all(br.parameter <= 0.3)
    assert len(br) == len(br.point_data["m"]) > 3
    assert_all_finite(br)


def test_programming_errors_propagate_with_the_partial_branch():
    class Buggy(Cubic):
        def linearize(self, u, lam):
            if lam > 0.0:
                raise KeyError("bug")
            return super().linearize(u, lam)

    with pytest.raises(KeyError) as info:
        continuation(Buggy(), [-1.3], -1.0, (-1.0, 1.0))
    partial = info.value.partial_branch
    assert isinstance(partial, Branch) and len(partial) > 2


def test_wrong_shapes_are_rejected():
    class Bad(Cubic):
        def linearize(self, u, lam):
            R, Ju, Jlam = super().linearize(u, lam)
            return R, Ju, np.array([1.0, 2.0])

    with pytest.raises(ValueError, match="shapes"):
        continuation(Bad(), [-1.3], -1.0, (-1.0, 1.0))


def test_invalid_arguments():
    with pytest.raises(ValueError, match="outside lam_range"):
        continuation(Cubic(), [0.0], 2.0, (-1.0, 1.0))
    with pytest.raises(ValueError, match="lo < hi"):
        continuation(Cubic(), [0.0], 0.0, (1.0, -1.0))
    with pytest.raises(ValueError, match="tangent"):
        continuation(Cubic(), [0.0], 0.0, (-1.0, 1.0), tangent=[1.0])


def test_options_may_be_a_mapping():
    br = continuation(Cubic(), [-1.3], -1.0, (-1.0, 1.0), {"max_points": 5})
    assert len(br) == 5
    with pytest.raises(TypeError, match="options must be ContinuationOptions or a mapping"):
        continuation(Cubic(), [-1.3], -1.0, (-1.0, 1.0), 5)


# --------------------------------------------------------------------------
# events, monitors, callbacks
# --------------------------------------------------------------------------
def test_user_event_located_on_every_crossing():
    ev = FunctionEvent(lambda p: p.lam - 0.3, name="lam=0.3", describe=lambda p: {"u": float(p.u[0])})
    br = continuation(Cubic(), [-1.3], -1.0, (-1.0, 1.0), events=[ev])
    users = br.points_of_kind(SpecialKind.USER)
    assert len(users) == 3  # the S-curve crosses lam = 0.3 three times
    roots = np.sort(np.roots([1.0, 0.0, -1.0, -0.3]).real)
    for p, root in zip(users, roots):
        assert p.located
        assert p.parameter == pytest.approx(0.3, abs=1e-10)
        assert p.unknowns[0] == pytest.approx(root, abs=1e-8)
        assert p.data["u"] == p.unknowns[0]
        assert p.event == "lam=0.3"
        assert br.parameter[p.index] <= 0.3 <= br.parameter[p.index + 1] or br.parameter[p.index] >= 0.3 >= br.parameter[p.index + 1]
    # special points are ordered along the branch
    s = [p.s for p in br.special_points]
    assert s == sorted(s)


def test_monitors_and_integer_stability_event():
    def monitor(u, lam, Ju, Jlam):
        return {"eig": Ju[0, 0], "pair": np.array([lam, 2 * lam])}

    unstable = FunctionEvent(lambda p: float(p.data["eig"] > 0), integer_valued=True, kind="stability", name="stab")
    prob = Cubic()
    br = continuation(prob, [-1.3], -1.0, (-1.0, 1.0), monitors=[monitor], events=[unstable])
    pd = br.point_data
    assert pd["eig"].shape == (len(br),) and pd["pair"].shape == (len(br), 2)
    np.testing.assert_allclose(pd["eig"], 3 * br.unknowns[:, 0] ** 2 - 1)
    np.testing.assert_allclose(pd["pair"][:, 1], 2 * br.parameter)
    changes = br.points_of_kind(SpecialKind.STABILITY)
    assert len(changes) == 2  # at the two folds
    for c, sign in zip(changes, (1, -1)):
        assert c.located
        assert c.parameter == pytest.approx(sign * FOLD_LAM, abs=1e-10)
        assert set(c.point_data) == {"eig", "pair"}


def test_callback_can_stop_and_sees_the_points():
    seen = []

    def callback(branch, index):
        seen.append((index, len(branch), float(branch.parameter[index])))
        return index < 5

    br = continuation(Cubic(), [-1.3], -1.0, (-1.0, 1.0), callback=callback)
    assert br.status is BranchStatus.INTERRUPTED
    assert len(br) == 6
    assert [s[0] for s in seen] == list(range(6))
    assert all(n == i + 1 for i, n, _ in seen)
    assert "callback" in br.message


def test_keyboard_interrupt_ends_cleanly():
    def callback(branch, index):
        if index == 3:
            raise KeyboardInterrupt

    br = continuation(Cubic(), [-1.3], -1.0, (-1.0, 1.0), callback=callback)
    assert br.status is BranchStatus.INTERRUPTED
    assert len(br) == 4
    assert "KeyboardInterrupt" in br.message


# --------------------------------------------------------------------------
# result object
# --------------------------------------------------------------------------
def test_branch_arrays_are_read_only_and_round_trip():
    br = continuation(Cubic(), [-1.3], -1.0, (-1.0, 1.0), monitors=[lambda u, lam, Ju, Jlam: {"x": u[0]}])
    with pytest.raises(ValueError):
        br.parameter[0] = 3.0
    assert br.newton_iterations.dtype.kind == "i"
    d = br.to_dict()
    assert d["status"] == "range_end"
    again = Branch.from_dict(d)
    assert len(again) == len(br)
    np.testing.assert_array_equal(again.unknowns, br.unknowns)
    np.testing.assert_array_equal(again.point_data["x"], br.point_data["x"])
    assert [p.kind for p in again.special_points] == [p.kind for p in br.special_points]
    assert again.status is BranchStatus.RANGE_END
    assert "fold" in br.summary()
    assert BranchStatus.RANGE_END.value == "range_end"
    assert SpecialKind.FOLD.value == "fold"


def test_problem_protocol():
    assert isinstance(Cubic(), Problem)
    assert not isinstance(object(), Problem)


# --------------------------------------------------------------------------
# property: the S-curve is traversed for any reasonable step settings
# --------------------------------------------------------------------------
@settings(max_examples=25, deadline=None)
@given(
    ds=st.floats(1e-3, 0.2),
    ds_max=st.floats(0.2, 0.5),
    max_angle=st.floats(5.0, 45.0),
    scaling=st.sampled_from(["auto", "none"]),
)
def test_s_curve_property(ds, ds_max, max_angle, scaling):
    opts = ContinuationOptions(ds=ds, ds_max=ds_max, max_angle_deg=max_angle, scaling=scaling)
    prob = Cubic()
    br = continuation(prob, [-1.3], -1.0, (-1.0, 1.0), opts)
    assert br.status is BranchStatus.RANGE_END, br.message
    assert br.parameter[-1] == 1.0
    assert br.unknowns[-1, 0] == pytest.approx(PLASTIC, abs=1e-10)
    assert len(br.points_of_kind("fold")) == 2
    assert np.all(np.diff(br.unknowns[:, 0]) > 0)


class Corner:
    """u - |lam - 1| (two unknowns, the second u2 = u): a corner of the branch at lam = 1."""

    def residual(self, u, lam):
        return np.array([u[0] - abs(lam - 1.0), u[1] - u[0]])

    def linearize(self, u, lam):
        return self.residual(u, lam), np.array([[1.0, 0.0], [-1.0, 1.0]]), np.array([-math.copysign(1.0, lam - 1.0), 0.0])


def test_a_corner_is_passed_and_recorded_as_a_kink():
    br = continuation(Corner(), [1.0, 1.0], 0.0, (0.0, 2.0), ContinuationOptions(ds=0.05, ds_max=0.1, scaling="none"))
    assert br.status is BranchStatus.RANGE_END and br.parameter[-1] == 2.0
    np.testing.assert_allclose(br.unknowns[:, 0], np.abs(br.parameter - 1.0), atol=1e-12)
    kinks = [sp for sp in br.special_points if sp.kind is SpecialKind.KINK]
    assert len(kinks) == 1
    k = kinks[0]
    # the tangent turns by 2*atan(1/sqrt(2)) in (lam, u1, u2): persistent as the step shrinks
    assert k.interval[0] <= 1.0 <= k.interval[1] + 1e-12 and k.interval[1] - k.interval[0] < 0.05
    assert k.data["angle_deg"] > 20 and "corner" in k.message


def test_corners_can_be_refused():
    br = continuation(Corner(), [1.0, 1.0], 0.0, (0.0, 2.0),
                      ContinuationOptions(ds=0.05, ds_max=0.1, scaling="none", corners=False))
    assert br.status is BranchStatus.STEP_TOO_SMALL and "last failure" in br.message
    assert abs(br.parameter[-1] - 1.0) < 1e-6 and np.all(br.parameter <= 1.0)
    assert not any(sp.kind is SpecialKind.KINK for sp in br.special_points)


def test_a_tight_smooth_turn_is_not_a_corner():
    """A small circle (radius 1e-3) turns fast but smoothly: folds, no kink."""
    br = continuation(Circle(1e-3), [0.0], -1e-3, (-1.0, 1.0),
                      ContinuationOptions(ds=5e-4, ds_max=5e-4, scaling="none", max_points=200))
    kinds = [sp.kind for sp in br.special_points]
    assert SpecialKind.KINK not in kinds and kinds.count(SpecialKind.FOLD) >= 1


class Line:
    """R = u - lam: every step converges at once."""

    def residual(self, u, lam):
        return u - lam

    def linearize(self, u, lam):
        return u - lam, np.eye(1), -np.ones(1)


def test_a_crawling_branch_stops_with_its_points_kept():
    """Steps that never grow again (here: growth disabled) and cover less than ds_max over stall_points points."""
    opts = ContinuationOptions(ds=1e-3, ds_max=1.0, grow=1.0, stall_points=5, scaling="none")
    br = continuation(Line(), [0.0], 0.0, (0.0, 10.0), opts)
    assert br.status is BranchStatus.STEP_TOO_SMALL
    assert "crawled: 5 points advanced" in br.message
    assert len(br) == 6 and np.all(np.isfinite(br.unknowns))
    np.testing.assert_allclose(br.unknowns[:, 0], br.parameter, atol=1e-12)
    with pytest.raises(ValueError, match="stall_points must be an integer >= 2"):
        ContinuationOptions(stall_points=1)


# --------------------------------------------------------------------------
# events that predict their change (step caps) and barriers
# --------------------------------------------------------------------------
def test_a_pair_of_close_changes_is_not_stepped_over_when_the_event_predicts_it():
    """A test out of [0.5, 0.52] and back: one long step would see the same sign at both ends.

    The distance (a smooth function through both zeros) lets the engine keep its steps near
    the predicted zero, so both changes are located, to 1e-10.
    """
    g = lambda p: (p.lam - 0.5) * (p.lam - 0.52)
    blind = FunctionEvent(g, name="window")
    seeing = FunctionEvent(g, name="window", distance=g)
    opts = ContinuationOptions(ds=0.05, ds_max=0.5)
    missed = continuation(Line(), [0.0], 0.0, (0.0, 1.0), opts, events=[blind])
    assert not missed.points_of_kind(SpecialKind.USER)  # the steps jump over the window
    found = continuation(Line(), [0.0], 0.0, (0.0, 1.0), opts, events=[seeing]).points_of_kind(SpecialKind.USER)
    assert [p.parameter for p in found] == pytest.approx([0.5, 0.52], abs=1e-10)


class Ends:
    """u - lam = 0 up to lam = 0.7, no solution beyond (a boundary of the problem's domain)."""

    def __init__(self):
        self.calls = 0

    def residual(self, u, lam):
        return np.array([u[0] - lam])

    def linearize(self, u, lam):
        self.calls += 1
        if lam > 0.7:
            raise ArithmeticError("outside the domain")
        return self.residual(u, lam), np.array([[1.0]]), np.array([-1.0])


def test_a_barrier_is_located_from_the_near_side_and_ends_the_branch():
    prob = Ends()
    edge = FunctionEvent(lambda p: float(p.lam > 0.7), integer_valued=True, kind="grazing", name="edge",
                         distance=lambda p: 0.7 - p.lam, barrier=True)
    br = continuation(prob, [0.0], 0.0, (0.0, 1.0), ContinuationOptions(ds=0.05, ds_max=0.2), events=[edge])
    assert br.status is BranchStatus.BOUNDARY
    assert "cannot pass the grazing point at lambda=0.7" in br.message
    (p,) = br.points_of_kind(SpecialKind.GRAZING)
    assert p.located and p.parameter == pytest.approx(0.7, abs=1e-10)
    assert br.parameter[-1] == pytest.approx(0.7, abs=1e-10)  # the last stored point is the barrier's
    assert prob.calls < 80  # a few solves, no crawl to ds_min


def test_without_a_barrier_the_same_problem_ends_as_a_failure():
    br = continuation(Ends(), [0.0], 0.0, (0.0, 1.0), ContinuationOptions(ds=0.05, ds_max=0.2))
    assert br.status is BranchStatus.STEP_TOO_SMALL
    assert br.parameter[-1] <= 0.7


def test_a_barrier_the_branch_passes_is_recorded_and_passed():
    edge = FunctionEvent(lambda p: float(p.lam > 0.7), integer_valued=True, kind="grazing", name="edge",
                         distance=lambda p: 0.7 - p.lam, barrier=True)
    br = continuation(Line(), [0.0], 0.0, (0.0, 1.0), ContinuationOptions(ds=0.05, ds_max=0.2), events=[edge])
    assert br.status is BranchStatus.RANGE_END
    (p,) = br.points_of_kind(SpecialKind.GRAZING)
    assert p.parameter == pytest.approx(0.7, abs=1e-10)


# --------------------------------------------------------------------------
# truthful ends and exact restarts
# --------------------------------------------------------------------------
def test_a_branch_that_turns_back_says_so_and_reports_what_it_did_not_cover():
    # the upper half of the unit circle from lam = -0.5 towards 2: it folds at lam = 1 and comes
    # back to -0.5 on the lower half; before, it ended `range_end` as if [1, 2] had been covered
    br = continuation(Circle(), [math.sqrt(0.75)], -0.5, (-0.5, 2.0))
    assert br.status is BranchStatus.TURNED_BACK and br.status.as_asked
    assert br.parameter[-1] == -0.5 and br.unknowns[-1, 0] < 0
    assert br.info["uncovered"] == pytest.approx((1.0, 2.0), abs=1e-10)
    assert "turned back" in br.message and "[1, 2] is not covered" in br.message


def test_a_branch_whose_numerics_gave_up_reports_the_interval_it_left():
    br = continuation(NaNBeyond(), [0.0], 0.0, (0.0, 1.0))
    assert not br.status.as_asked
    assert br.info["uncovered"][1] == 1.0 and br.info["uncovered"][0] == pytest.approx(0.5, abs=1e-6)
    assert continuation(NoRealRoot(), [1.0], 0.0, (0.0, 1.0)).info["uncovered"] == (0.0, 1.0)


@pytest.mark.parametrize("problem, u0, lam0, lam_range", [
    (Circle(), [1.0], 0.0, (-2.0, 2.0)),  # folds and a closed loop (uses the branch's history)
    (Corner(), [1.0, 1.0], 0.0, (0.0, 2.0)),  # a kink recorded after the point's callback
])
def test_a_restart_from_any_checkpoint_gives_the_uninterrupted_branch_bit_for_bit(problem, u0, lam0, lam_range):
    import copy

    states = []

    def checkpoint(branch, state):
        if "points" in state:  # what a killed run leaves: the branch so far and the engine's state
            states.append((copy.deepcopy(branch), copy.deepcopy(state)))

    opts = ContinuationOptions(ds=0.05, ds_max=0.3)
    full = continuation(problem, u0, lam0, lam_range, opts, checkpoint=checkpoint)
    assert len(states) >= 10
    for k in sorted({1, len(states) // 2, len(states) - 1}):
        branch, state = states[k]
        rest = continuation(problem, u0, lam0, lam_range, opts, restart=(branch, state))
        assert rest.status is full.status and rest.message == full.message
        np.testing.assert_array_equal(rest.unknowns, full.unknowns)
        np.testing.assert_array_equal(rest.parameter, full.parameter)
        assert [(p.kind, p.parameter, p.index) for p in rest.special_points] == \
            [(p.kind, p.parameter, p.index) for p in full.special_points]
        assert rest.info["n_newton_iterations"] == full.info["n_newton_iterations"]


def test_a_restart_refuses_a_state_of_another_length():
    states = []
    continuation(Circle(), [1.0], 0.0, (-2.0, 2.0), checkpoint=lambda b, s: states.append((len(b), s)))
    n, state = states[3]
    short = continuation(Circle(), [1.0], 0.0, (-2.0, 2.0), ContinuationOptions(max_points=n - 1))
    with pytest.raises(ValueError, match="the state belongs to"):
        continuation(Circle(), [1.0], 0.0, (-2.0, 2.0), restart=(short, state))


class CostlySCurve:
    """``x^3 - x = lam``, ``y = x^2``, ``z = sin x - y / 5``: the S-curve of :class:`Cubic` in three unknowns,
    declared with a linearisation costing ten residuals (as shooting's variational flow); calls counted."""

    jacobian_cost = 10.0

    def __init__(self):
        self.residuals = self.linearisations = 0

    def _r(self, u, lam):
        x, y, z = u
        return np.array([x**3 - x - lam, y - x * x, z - math.sin(x) + 0.2 * y])

    def residual(self, u, lam):
        self.residuals += 1
        return self._r(u, lam)

    def linearize(self, u, lam):
        self.linearisations += 1
        x = u[0]
        Ju = np.array([[3 * x * x - 1, 0, 0], [-2 * x, 1, 0], [-math.cos(x), 0.2, 1]])
        return self._r(u, lam), Ju, np.array([-1.0, 0.0, 0.0])


def test_a_costly_jacobian_is_evaluated_lazily_with_the_same_branch():
    """Newton's iterates by the residual alone, the Jacobian where a factorisation needs it: the folds at
    their closed form as with eager Jacobians, at fewer linearisations than residuals."""
    u0 = [-PLASTIC, PLASTIC**2, math.sin(-PLASTIC) - 0.2 * PLASTIC**2]
    lazy = CostlySCurve()
    eager = CostlySCurve()
    eager.jacobian_cost = 1.0
    branches = [continuation(p, u0, 1.0, (-1.0, 1.0), ContinuationOptions(direction=-1)) for p in (lazy, eager)]
    for br, prob in zip(branches, (lazy, eager)):
        assert br.status is BranchStatus.RANGE_END, br.message
        assert max(np.abs(prob._r(u, lam)).max() for u, lam in zip(br.unknowns, br.parameter)) <= 1e-10
        folds = br.points_of_kind(SpecialKind.FOLD)
        assert len(folds) == 2
        for f in folds:
            assert abs(abs(f.parameter) - FOLD_LAM) <= 1e-10
            assert abs(f.unknowns[0]) == pytest.approx(1 / math.sqrt(3), abs=1e-8)
    assert eager.residuals == 0
    assert lazy.linearisations < 0.7 * eager.linearisations
    assert lazy.residuals > lazy.linearisations
