"""Tests of contin.engine.predictor: tangents, their orientation, the Hermite arc."""

import math

import numpy as np
import pytest

from contin.engine.linalg import factorize
from contin.engine import predictor
from contin.engine.predictor import (
    HermiteArc,
    initial_tangent,
    last_unit_vector,
    orient_along_secant,
    predict,
    unit_tangent,
)


def circle_point(phi):
    """A point of the unit circle (u, lam) = (cos phi, sin phi) and its unit tangent (counter-clockwise)."""
    return np.array([math.cos(phi), math.sin(phi)]), np.array([-math.sin(phi), math.cos(phi)])


def test_the_hermite_arc_lies_on_the_hyperplanes_and_is_fourth_order_close_to_the_curve():
    """On the unit circle the Hermite arc's distance to the curve falls 16-fold when the step is halved
    (fourth order), the chord's 4-fold (second order)."""
    xa, ta = circle_point(0.0)
    off_arc, off_chord = [], []
    for L in (0.4, 0.2, 0.1):
        xb, tb = circle_point(L)
        arc = HermiteArc(xa, ta, xb, tb, float(ta @ (xb - xa)))
        np.testing.assert_allclose(arc.at(0.0), xa, atol=1e-15)
        np.testing.assert_allclose(arc.at(arc.h), xb, atol=1e-12)
        sigma = 0.5 * arc.h
        p = arc.at(sigma)
        assert float(ta @ (p - xa)) == pytest.approx(sigma, abs=1e-13)  # on the hyperplane asked
        off_arc.append(abs(np.linalg.norm(p) - 1.0))
        off_chord.append(abs(np.linalg.norm(xa + 0.5 * (xb - xa)) - 1.0))
    for k in (1, 2):
        assert 12 < off_arc[k - 1] / off_arc[k] < 20
        assert 3.5 < off_chord[k - 1] / off_chord[k] < 4.5
    assert off_arc[0] < 0.02 * off_chord[0]


def test_the_start_tangent_follows_the_direction_asked_or_the_given_tangent():
    # R = u - 2 lam: the tangent is +-(2, 1)/sqrt(5)
    Jh = np.array([[1.0, -2.0]])
    up = initial_tangent(Jh, None, +1)
    down = initial_tangent(Jh, None, -1)
    np.testing.assert_allclose(up, np.array([2.0, 1.0]) / math.sqrt(5.0), atol=1e-15)
    np.testing.assert_allclose(down, -up, atol=0)
    np.testing.assert_allclose(initial_tangent(Jh, np.array([-1.0, 0.0]), +1), down, atol=1e-15)


@pytest.mark.parametrize("sl", [1e17, 1e50, 1e300])
def test_a_parameter_component_below_the_rounding_of_the_null_vector_keeps_the_direction_asked(sl):
    """``[A, -b sl]`` with a huge ``sl`` (the width of a range [0.5, 1e17]): the tangent is
    ``(A^-1 b sl, 1)`` normalised, its parameter component ``~1/sl``, far below the SVD's rounding of it."""
    A = np.array([[3.0, 1.0, 0.0, 0.2], [1.0, 4.0, 1.0, 0.0], [0.0, 1.0, 5.0, 1.0], [0.3, 0.0, 1.0, 2.0]])
    b = np.array([1.0, -2.0, 0.5, 0.7])
    Jh = np.column_stack([A, -b * sl])
    exact = np.append(np.linalg.solve(A, b), 1.0 / sl)  # (u', 1/sl) up to the norm, with u' = A^-1 b
    exact /= np.linalg.norm(exact)
    for direction in (+1, -1):
        t = initial_tangent(Jh, None, direction)
        assert np.sign(t[-1]) == direction
        np.testing.assert_allclose(t, direction * exact, rtol=1e-12, atol=1e-300)
    # at a fold (Ju singular) there is no graph over the parameter: no direction to keep
    assert predictor.graph_tangent(np.array([[0.0, -1.0]])) is None


def test_at_a_branch_point_the_given_tangent_picks_its_branch():
    # a zero Jacobian row: every direction of (u, lam) is in the null space
    Jh = np.zeros((1, 2))
    given = np.array([3.0, 4.0])
    np.testing.assert_allclose(initial_tangent(Jh, given, +1), given / 5.0, atol=1e-15)


def test_unit_tangent_solves_the_bordered_system():
    # [[Ju su, Jlam sl], [t_old]] z = e_last for R = u - 2 lam
    t_old = np.array([1.0, 0.0])
    lu = factorize(np.array([[1.0, -2.0], t_old]))
    t = unit_tangent(lu, last_unit_vector(1))
    np.testing.assert_allclose(t, np.array([2.0, 1.0]) / math.sqrt(5.0), atol=1e-15)
    assert float(t @ t_old) > 0  # the orientation of the bordering row is kept


def test_predict_and_orientation_along_the_secant():
    x, t = np.array([0.0, 1.0]), np.array([1.0, 0.0])
    np.testing.assert_array_equal(predict(x, t, 0.5), [0.5, 1.0])

    class Cand:
        x = np.array([-1.0, 1.0])
        tangent = np.array([1.0, 0.0])

    c = orient_along_secant(Cand(), x)
    np.testing.assert_array_equal(c.tangent, [-1.0, 0.0])
