"""Bracket narrowing (contin.engine.bracketing): a test with a corner at its zero, located by one-sided secants."""

import math
import types

import pytest

from contin.engine.bracketing import narrow

ROOT = 0.3141592653589793


def _kinked(slope_lo, slope_hi):
    # lam = sigma along the arc; the test is linear on each side of ROOT with different slopes (a grazing's turn)
    def value(info):
        d = info.lam - ROOT
        return slope_lo * d if d < 0 else slope_hi * d

    def point_at(s):
        return types.SimpleNamespace(lam=s, s=s), ""

    return value, point_at


@pytest.mark.parametrize("slopes", [(1.0, 30.0), (30.0, 1.0), (-2.0, -0.05)])
def test_a_corner_at_the_zero_is_located_by_one_sided_secants_in_a_few_points(slopes):
    value, point_at = _kinked(*slopes)
    a, b = point_at(0.0)[0], point_at(1.0)[0]
    runs = {}
    for kink in (False, True):
        loc = narrow(point_at, 0.0, 1.0, a, b, value(a), value(b), 1.0, side=lambda info, v: (v < 0) == (value(a) < 0),
                     value=value, tol=1e-12, kink=kink, value_decides=True)
        assert loc.located
        assert abs(loc.point.lam - ROOT) <= 2e-12
        runs[kink] = loc.iterations
    # regula falsi across the corner creeps (ITP's projection bounds it by bisection); the secant of one side is
    # exact on a linear side
    assert runs[True] <= 8 and runs[False] >= 40, runs


def test_a_count_a_hair_behind_the_zero_still_gives_secant_steps():
    """The side is a count that changes 1e-13 after the test's zero (as a switch resolved once its arc is long
    enough); values of the wrong sign within KINK_FLOOR of the bracket's scale count on their side."""
    value, point_at = _kinked(1.0, 10.0)
    lag = 1e-13
    a, b = point_at(0.0)[0], point_at(1.0)[0]
    its = {}
    for kink in (False, True):
        loc = narrow(point_at, 0.0, 1.0, a, b, value(a), value(b), 1.0, side=lambda info, v: info.lam < ROOT + lag,
                     value=value, tol=1e-12, kink=kink)
        assert loc.located and abs(loc.point.lam - ROOT) <= 1e-12 and math.isfinite(loc.value)  # within tol
        its[kink] = loc.iterations
    assert its[True] <= 14 and its[False] >= 40, its


@pytest.mark.parametrize("power", [1.5, 2.0])
def test_a_side_that_flattens_towards_the_change_still_closes_the_bracket_in_a_few_points(power):
    """A grazing's turn seen from the contact side falls off faster than linearly (a dip into the surface grows
    as a power of the distance past the grazing): the secant on that side converges only linearly and its
    points crowd at the zero; each next point reaches at least a tenth of the tolerance's half width towards
    the far end, which closes the bracket."""
    def value(info):
        d = info.lam - ROOT
        return -3.0 * d if d < 0 else -d ** power

    def point_at(s):
        return types.SimpleNamespace(lam=s, s=s), ""

    a, b = point_at(0.0)[0], point_at(1.0)[0]
    for tol in (1e-10, 1e-12):
        loc = narrow(point_at, 0.0, 1.0, a, b, value(a), value(b), 1.0, side=lambda info, v: info.lam < ROOT,
                     value=value, tol=tol, kink=True)
        assert loc.located and abs(loc.point.lam - ROOT) <= tol
        assert loc.iterations <= 26, loc.iterations  # 54 to 57 when the step past the zero was a hundredth alone


PEAK = 2.1437741


def _fold(corner: bool, slope: float):
    """A branch whose parameter peaks at sigma = ROOT: at a corner (lam = PEAK - slope |sigma - ROOT|, its
    tangent's parameter component jumping from +1 to -1 there) or smoothly (PEAK - slope (sigma - ROOT)^2)."""
    def point_at(s):
        d = s - ROOT
        lam = PEAK - slope * (abs(d) if corner else d * d)
        return types.SimpleNamespace(lam=lam, s=s, t=(-math.copysign(1.0, d) if corner else -2.0 * d)), ""

    def value(info):
        return info.t

    return value, point_at


@pytest.mark.parametrize("slope", [1e-9, 1e-4])
def test_a_fold_at_a_corner_is_located_once_the_parameter_cannot_move(slope):
    """The test jumps at the change: the bracket need not shrink to sqrt(tol) of the step, only until the
    steepest slope of the parameter across it is within the tolerance."""
    value, point_at = _fold(True, slope)
    a, b = point_at(0.0)[0], point_at(1.0)[0]
    tol = 1e-10
    loc = narrow(point_at, 0.0, 1.0, a, b, value(a), value(b), 1.0, side=lambda info, v: (v < 0) == (value(a) < 0),
                 value=value, tol=tol, value_decides=True)
    assert loc.located and "the test jumps there" in loc.message
    assert PEAK - loc.point.lam <= tol * PEAK
    lo, hi = loc.bracket
    assert PEAK - min(lo, hi) <= tol * PEAK
    # bisections to the jump test (1/64 of the step) or to the parameter's tolerance, whichever is later; the
    # arclength criterion would have taken 17 (sqrt(tol) of the step)
    needed = max(6, math.ceil(math.log2(2 * slope / (tol * PEAK))))
    assert loc.iterations <= needed + 4, (loc.iterations, needed)


def test_a_smooth_fold_is_no_jump():
    value, point_at = _fold(False, 0.5)
    a, b = point_at(0.0)[0], point_at(1.0)[0]
    loc = narrow(point_at, 0.0, 1.0, a, b, value(a), value(b), 1.0, side=lambda info, v: (v < 0) == (value(a) < 0),
                 value=value, tol=1e-10, value_decides=True)
    assert loc.located and "jumps" not in loc.message
    assert abs(loc.point.s - ROOT) <= 1e-5 and PEAK - loc.point.lam <= 1e-10 * PEAK
