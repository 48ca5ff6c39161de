"""Tests of contin.engine.events: triggering rules and location on synthetic arcs."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from conftest import fuzz_examples

from contin.engine.branch import SpecialKind
from contin.engine.events import (
    BranchPointEvent,
    Event,
    FoldEvent,
    FunctionEvent,
    PointInfo,
    changed_components,
    evaluate_test,
    locate,
    narrow,
    predicted_zero,
)


def info(lam, tangent=(0.0, 1.0), det_sign=1, u=0.0, s=0.0, data=None):
    return PointInfo(
        u=np.array([u]),
        lam=float(lam),
        tangent=np.array(tangent, dtype=float),
        Ju=np.eye(1),
        Jlam=np.zeros(1),
        det_sign=det_sign,
        data={} if data is None else data,
        s=s,
    )


def arc_point_at(lam_of_sigma, u_of_sigma=lambda s: 0.0, calls=None):
    """point_at for a synthetic arc; records the sigmas asked for."""

    def point_at(sigma):
        if calls is not None:
            calls.append(sigma)
        return info(lam_of_sigma(sigma), u=u_of_sigma(sigma), s=sigma), ""

    return point_at


def test_default_trigger_rules():
    ev = FunctionEvent(lambda p: p.lam)
    a, b = info(-1), info(1)
    g = np.array([-1.0, 1.0, 2.0, 0.0, -3.0])
    h = np.array([1.0, -1.0, 3.0, 1.0, 0.0])
    assert changed_components(ev, g, h, a, b) == [0, 1, 4]  # a zero at b counts, at a not
    ev_int = FunctionEvent(lambda p: p.lam, integer_valued=True)
    assert changed_components(ev_int, np.array([1.0, 2.0]), np.array([1.0, 4.0]), a, b) == [1]
    # shapes that differ, and non-finite values, never trigger
    assert changed_components(ev, np.array([1.0]), np.array([-1.0, 2.0]), a, b) == []
    assert changed_components(ev, np.array([np.nan]), np.array([-1.0]), a, b) == []


def test_fold_and_branch_point_tests():
    fold, bp = FoldEvent(), BranchPointEvent()
    assert fold.kind is SpecialKind.FOLD and bp.kind is SpecialKind.BP
    assert bp.integer_valued and not fold.integer_valued
    a = info(0.0, tangent=(0.6, 0.8), det_sign=1)
    b = info(0.1, tangent=(0.8, 0.6), det_sign=-1)
    c = info(0.1, tangent=(0.8, -0.6), det_sign=-1)
    assert evaluate_test(fold, a)[0] == pytest.approx(0.8)
    assert changed_components(bp, evaluate_test(bp, a), evaluate_test(bp, b), a, b) == [0]
    # a determinant sign change together with a fold is not a branch point
    assert changed_components(bp, evaluate_test(bp, a), evaluate_test(bp, c), a, c) == []
    assert changed_components(fold, evaluate_test(fold, a), evaluate_test(fold, c), a, c) == [0]


def test_event_is_abstract():
    with pytest.raises(TypeError):
        Event()


def test_locate_continuous_illinois_is_fast_and_accurate():
    # lam(sigma) = sigma^2 + sigma on [0, 1]; event lam = 0.7
    lam_of = lambda s: s * s + s
    root = (-1 + math.sqrt(1 + 4 * 0.7)) / 2
    ev = FunctionEvent(lambda p: p.lam - 0.7)
    calls = []
    a, b = info(lam_of(0.0)), info(lam_of(1.0), s=1.0)
    (loc,) = locate(ev, 0, arc_point_at(lam_of, calls=calls), 1.0, a, b, -0.7, 1.3, tol=1e-12)
    assert loc.located
    assert loc.point.lam == pytest.approx(0.7, abs=1e-12)
    assert loc.sigma == pytest.approx(root, abs=1e-9)
    assert len(calls) == loc.iterations <= 15
    assert all(0 < s < 1 for s in calls)


def test_locate_fold_like_test_locates_the_arclength_too():
    # lam stationary at sigma* = 0.3: a tolerance on lam alone is not enough
    sig_star = 0.3
    lam_of = lambda s: 1.0 - (s - sig_star) ** 2

    class TangentLike(Event):
        name = "slope"

        def test(self, p):
            return -2 * (p.s - sig_star)

    a, b = info(lam_of(0.0)), info(lam_of(1.0), s=1.0)
    (loc,) = locate(TangentLike(), 0, arc_point_at(lam_of), 1.0, a, b, 0.6, -1.4, tol=1e-10)
    assert loc.located
    assert loc.sigma == pytest.approx(sig_star, abs=1e-9)
    assert loc.point.lam == pytest.approx(1.0, abs=1e-12)


def test_locate_integer_valued_by_bisection():
    lam_of = lambda s: 2.0 * s
    ev = FunctionEvent(lambda p: float(p.lam > 0.77), integer_valued=True)
    a, b = info(0.0), info(2.0, s=1.0)
    (loc,) = locate(ev, 0, arc_point_at(lam_of), 1.0, a, b, 0.0, 1.0, tol=1e-10)
    assert loc.located
    assert loc.value == 1.0  # the first point after the change
    assert loc.point.lam == pytest.approx(0.77, abs=2e-10)
    assert loc.bracket[0] <= 0.77 <= loc.bracket[1]


def test_locate_integer_test_that_jumps_twice():
    lam_of = lambda s: s
    ev = FunctionEvent(lambda p: float((p.lam > 0.2) + (p.lam > 0.6)), integer_valued=True)
    a, b = info(0.0), info(1.0, s=1.0)
    locs = locate(ev, 0, arc_point_at(lam_of), 1.0, a, b, 0.0, 2.0, tol=1e-10)
    assert [l.value for l in locs] == [1.0, 2.0]
    assert [l.point.lam for l in locs] == pytest.approx([0.2, 0.6], abs=1e-9)


def test_locate_reports_failure_with_best_estimate():
    ev = FunctionEvent(lambda p: p.lam - 0.5)
    a, b = info(0.0), info(1.0, s=1.0)

    def failing(sigma):
        return None, "Newton did not converge"

    (loc,) = locate(ev, 0, failing, 1.0, a, b, -0.5, 0.5)
    assert not loc.located
    assert "Newton did not converge" in loc.message
    assert loc.point in (a, b)


def test_locate_respects_max_iter():
    ev = FunctionEvent(lambda p: float(p.lam > 0.3), integer_valued=True)
    a, b = info(0.0), info(1.0, s=1.0)
    (loc,) = locate(ev, 0, arc_point_at(lambda s: s), 1.0, a, b, 0.0, 1.0, max_iter=3)
    assert not loc.located
    assert loc.iterations == 3
    assert "did not converge" in loc.message


def test_exact_zero_at_stored_point():
    ev = FunctionEvent(lambda p: p.lam)
    a, b = info(-1.0), info(0.0, s=1.0)
    (loc,) = locate(ev, 0, arc_point_at(lambda s: s - 1.0), 1.0, a, b, -1.0, 0.0)
    assert loc.located and loc.point is b and loc.iterations == 0


def test_describe_and_vector_tests():
    ev = FunctionEvent(
        lambda p: np.array([p.lam - 0.25, p.lam - 0.5]),
        describe=lambda p: {"where": p.lam},
        kind="stability",
        name="two thresholds",
    )
    assert ev.kind is SpecialKind.STABILITY
    a, b = info(0.0), info(1.0)
    ga, gb = evaluate_test(ev, a), evaluate_test(ev, b)
    assert changed_components(ev, ga, gb, a, b) == [0, 1]
    (loc,) = locate(ev, 1, arc_point_at(lambda s: s), 1.0, a, b, ga[1], gb[1])
    assert loc.point.lam == pytest.approx(0.5, abs=1e-10)
    assert ev.describe(loc.point) == {"where": loc.point.lam}


def test_narrow_uses_the_continuous_test_and_keeps_the_bracket_by_the_side():
    calls = []
    point_at = arc_point_at(lambda s: s, calls=calls)
    a, b = info(0.0), info(1.0, s=1.0)
    side = lambda p, v: p.lam <= 0.37
    loc = narrow(point_at, 0.0, 1.0, a, b, -0.37, 0.63, 1.0, side=side, value=lambda p: p.lam - 0.37, tol=1e-12)
    assert loc.located and loc.point.lam == pytest.approx(0.37, abs=1e-12)
    assert len(calls) <= 10  # ITP on a linear test (its first steps nudged towards the midpoint); bisection: 40
    # a continuous test that disagrees with the side (its zero is elsewhere) cannot move the bracket off
    calls.clear()
    loc = narrow(point_at, 0.0, 1.0, a, b, -0.2, 0.8, 1.0, side=side, value=lambda p: p.lam - 0.2, tol=1e-12)
    assert loc.located and abs(loc.point.lam - 0.37) <= 1e-12
    assert len(calls) <= 60


def test_narrow_counts_failed_solves_beyond_the_change():
    """No solution past 0.37 + 1e-4 (a grazing): located on the near side, where the test is smooth."""

    def point_at(s):
        return (None, "no solution") if s > 0.3701 else (info(s, s=s), "")

    a, b = info(0.0), info(0.5, s=0.5)
    loc = narrow(point_at, 0.0, 0.5, a, b, 0.37, -0.13, 0.5, side=lambda p, v: p.lam < 0.37,
                 value=lambda p: 0.37 - p.lam, tol=1e-10, vtol=1e-9, failed_beyond=True)
    assert loc.located and loc.point.lam <= 0.37
    assert loc.point.lam == pytest.approx(0.37, abs=1e-9)


def test_predicted_zero():
    assert predicted_zero(1.0, 0.5, 0.1) == pytest.approx(0.1)
    assert predicted_zero(-1.0, -0.5, 1.0) == pytest.approx(1.0)
    assert predicted_zero(0.5, 1.0, 1.0) == math.inf  # moving away
    assert predicted_zero(float("nan"), 1.0, 1.0) == math.inf


# -- tests that are only piecewise smooth: a contact orbit's multipliers ------------------------------------
# At a period doubling of the rotor's contact orbit near w = 1.765 (H = 10) the pd test jumps from -5.9e-6 to
# +3.8e-5 where its multiplier crosses -1 (a contact changes there); the old regula falsi took 26 of its 60
# iterations. Jumps and corners more lopsided than that made it creep from one end until the iterations ran out
# ("location did not converge in 60 iterations"), its estimate still 1e-8 off.

def _lopsided(left: float, right: float, slope: float, root: float):
    """A test of the arclength: ``slope (s - root)`` plus a jump from ``-left`` to ``+right`` at ``root``."""
    return lambda s: slope * (s - root) + (right if s >= root else -left)


@pytest.mark.parametrize("left, right, slope", [
    (1e-8, 1e-3, 0.0),  # a jump, steep on one side only
    (1e-3, 1e-8, 0.05),
    (1e-6, 1e-2, 1.0),
    (0.0, 0.0, None),  # a corner: slope 1 before the root, 1e-3 after
])
def test_a_lopsided_jump_or_corner_is_located_within_the_iterations(left, right, slope):
    h, lam0, rate, root = 1.28e-3, 1.76, 0.25, 2.1e-4
    g = _lopsided(left, right, slope, root) if slope is not None else (
        lambda s: (s - root) if s < root else 1e-3 * (s - root))
    ev = FunctionEvent(lambda p: g(p.s))
    calls = []
    point_at = arc_point_at(lambda s: lam0 + rate * s, calls=calls)
    a, b = info(lam0, s=0.0), info(lam0 + rate * h, s=h)
    (loc,) = locate(ev, 0, point_at, h, a, b, g(0.0), g(h), tol=1e-10, max_iter=60)
    assert loc.located, loc.message
    assert len(calls) <= 59
    # |dlam| <= tol * lam at the change: the arclength to within tol * lam / rate
    assert abs(loc.point.s - root) <= 1e-10 * lam0 / rate
    assert loc.message.startswith("located in")


def test_a_count_with_a_lopsided_continuous_test_is_located_as_a_stability_event_narrows_it():
    """The stability events' form: the count keeps the bracket, the continuous test (the product over the
    multipliers) proposes the points; a jump of the test at the change is located within the iterations."""
    root, h = 0.3, 1.0
    g = _lopsided(1e-9, 1e-2, 0.0, root)
    calls = []
    point_at = arc_point_at(lambda s: s, calls=calls)
    a, b = info(0.0), info(1.0, s=1.0)
    loc = narrow(point_at, 0.0, h, a, b, g(0.0), g(h), h, side=lambda p, v: p.lam < root, value=lambda p: g(p.lam),
                 tol=1e-10, max_iter=60)
    assert loc.located and abs(loc.point.lam - root) <= 1e-10
    assert len(calls) <= 59


@settings(max_examples=fuzz_examples(60), deadline=None)
@given(root=st.floats(0.01, 0.99), left=st.floats(-9.0, -1.0), right=st.floats(-9.0, -1.0),
       slope=st.sampled_from([0.0, 1e-3, 1.0, 30.0]))
def test_jumps_of_any_size_at_any_place_are_located(root, left, right, slope):
    g = _lopsided(10.0 ** left, 10.0 ** right, slope, root)
    ev = FunctionEvent(lambda p: g(p.s))
    a, b = info(2.0, s=0.0), info(3.0, s=1.0)
    (loc,) = locate(ev, 0, arc_point_at(lambda s: 2.0 + s), 1.0, a, b, g(0.0), g(1.0), tol=1e-10, max_iter=60)
    assert loc.located, loc.message
    assert loc.iterations <= 59
    assert abs(loc.point.s - root) <= 1e-10 * 3.0


def test_a_smooth_test_is_located_by_the_same_points_as_before():
    """The safeguard moves no point of a location that converges without it: regula falsi's own sequence
    on lam(sigma) = sigma^2 + sigma, event lam = 0.7 (Illinois, as before)."""
    calls = []
    ev = FunctionEvent(lambda p: p.lam - 0.7)
    a, b = info(0.0), info(2.0, s=1.0)
    (loc,) = locate(ev, 0, arc_point_at(lambda s: s * s + s, calls=calls), 1.0, a, b, -0.7, 1.3)
    # the first two points are plain regula falsi on the end values, then on the new bracket [s1, 1]
    s1 = 0.7 / 2.0
    assert calls[0] == pytest.approx(s1, abs=1e-15)
    g1 = s1 * s1 + s1 - 0.7
    assert calls[1] == pytest.approx((s1 * 1.3 - 1.0 * g1) / (1.3 - g1), abs=1e-15)
    assert loc.located and loc.point.lam == pytest.approx(0.7, abs=1e-10) and len(calls) <= 12
