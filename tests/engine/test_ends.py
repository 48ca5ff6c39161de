"""Tests of how a branch ends (contin.engine.ends and the engine's caps): an end is as asked only where the
branch did what it was asked, never at a cap nobody set nor at the range end it started on."""

import math

import numpy as np
import pytest

from contin.engine.branch import BranchStatus
from contin.engine.continuation import continuation


class Line:
    """u - lam = 0: a straight branch, everywhere regular."""

    def linearize(self, u, lam):
        return np.array([u[0] - lam]), np.array([[1.0]]), np.array([-1.0])


class Parabola:
    """u^2 = lam - 1: a fold at (0, 1); no solution below lam = 1."""

    def linearize(self, u, lam):
        return np.array([u[0] ** 2 - (lam - 1.0)]), np.array([[2.0 * u[0]]]), np.array([-1.0])


def test_the_default_cap_reached_is_a_shortfall_that_says_to_raise_max_points(monkeypatch):
    from contin.engine import options

    # the cap as a smaller number, for speed (its value, 2000, is checked in test_options)
    monkeypatch.setattr(options, "DEFAULT_MAX_POINTS", 40, raising=False)
    br = continuation(Line(), [0.0], 0.0, (0.0, math.inf))
    assert len(br) == 40
    assert br.status is BranchStatus.DEFAULT_MAX_POINTS and not br.status.as_asked
    assert "default cap of 40 points (max_points was not set)" in br.message
    assert "raise max_points (continuation.max_points in a scene)" in br.message
    # what it left: from its last point (lam = u along the line) to the end it was going to
    assert br.info["uncovered"] == (pytest.approx(br.parameter[-1], rel=1e-12), math.inf)


def test_a_cap_the_caller_set_is_an_end_as_asked():
    br = continuation(Line(), [0.0], 0.0, (0.0, math.inf), {"max_points": 30})
    assert len(br) == 30
    assert br.status is BranchStatus.MAX_POINTS and br.status.as_asked
    assert br.message.startswith("stored max_points=30 points")


def test_a_branch_that_leaves_the_range_where_it_started_has_not_reached_its_end():
    """The fold of u^2 = lam - 1 lies on the range end lam = 1; asked towards 0.5, the branch can only
    go up and out: one point beside its start, nothing covered, so neither range_end nor turned_back."""
    br = continuation(Parabola(), [0.0], 1.0, (0.5, 1.0), {"direction": -1}, solve_start=False)
    assert np.all(br.parameter == 1.0)
    assert br.status is BranchStatus.ILL_CONDITIONED and not br.status.as_asked
    assert br.message.startswith("the branch left the parameter range at its start lambda=1 without covering any "
                                 "of it, though asked to go towards lambda=0.5")
    assert "set continuation.parameter_scale" in br.message
    assert br.info["uncovered"] == (0.5, 1.0)


def test_a_start_on_the_range_end_asked_outwards_still_ends_there_as_asked():
    """Asked to go beyond the end it starts on, the branch has reached it: range_end with its one point."""
    br = continuation(Line(), [1.0], 1.0, (0.0, 1.0), {"direction": 1})
    assert len(br) == 1 and br.status is BranchStatus.RANGE_END and br.status.as_asked
    # the same fold on the range end, asked the way the branch goes: into the range
    up = continuation(Parabola(), [0.0], 1.0, (1.0, 1.5), {"direction": 1}, solve_start=False)
    assert up.status is BranchStatus.RANGE_END and up.parameter[-1] == 1.5
    assert max(abs(u[0] ** 2 - (lam - 1.0)) for u, lam in zip(up.unknowns, up.parameter)) <= 1e-10


@pytest.mark.parametrize("width", [1e17, 1e50, 1e300])
def test_a_huge_range_is_followed_into_not_left_at_its_start(width):
    """The automatic parameter scale is the range's width: 1e17 and more make the start tangent's parameter
    component smaller than the rounding of its null vector; the direction asked is kept all the same."""
    A = np.array([[3.0, 1.0, 0.0], [1.0, 4.0, 1.0], [0.0, 1.0, 5.0]])
    b = np.array([1.0, -2.0, 0.5])

    class Linear:  # A u = b lam: u = A^-1 b lam
        def linearize(self, u, lam):
            return A @ u - b * lam, A, -b

    lam0 = 0.5
    for direction, lam_range in ((1, (lam0, width)), (-1, (-width, lam0))):
        br = continuation(Linear(), np.linalg.solve(A, b * lam0), lam0, lam_range,
                          {"max_points": 6, "direction": direction})
        assert br.status is BranchStatus.MAX_POINTS and len(br) == 6, br.message
        assert np.all(direction * np.diff(br.parameter) > 0)  # along the range, away from its start
        np.testing.assert_allclose(br.unknowns, np.outer(br.parameter, np.linalg.solve(A, b)), rtol=1e-9)


@pytest.mark.parametrize("k, status", [(1, BranchStatus.CLOSED_LOOP), (2, BranchStatus.CLOSED_LOOP),
                                       (7, BranchStatus.RETRACED)])
def test_passing_an_earlier_point_again_closes_a_loop_only_beside_the_start(monkeypatch, k, status):
    """A branch that passes again through one of its first points has gone round its loop (its start passed
    unseen between two points); through a later one it has retraced itself, which no smooth branch does: a
    jump, a shortfall with the interval it did not reach (the Duffing oscillator whose two sheets beside the
    backbone lie closer than a step retraces itself so: tests/hard/test_damping.py)."""
    import contin.engine.continuation as engine

    calls = []

    def revisited(branch, *a):
        calls.append(len(branch))
        return k if len(branch) == 12 else None

    monkeypatch.setattr(engine, "revisited", revisited)
    br = continuation(Line(), [0.0], 0.0, (0.0, 10.0))
    assert len(br) == 12 and br.status is status
    assert br.status.as_asked == (status is BranchStatus.CLOSED_LOOP)
    assert f"passed again through its point {k}" in br.message
    if status is BranchStatus.RETRACED:
        assert "retraces itself" in br.message and "lower ds_max" in br.message
        assert br.info["uncovered"] == (pytest.approx(br.parameter[-1], rel=1e-12), 10.0)
    else:
        assert "returned to its start" in br.message and "uncovered" not in br.info
