"""Building expressions: trivial zeros and ones simplified, numbers folded, substitution re-simplified."""

from contin.model import expressions as ex
from contin.model.expressions import parse


def test_simplification_of_zeros_and_ones():
    assert ex.diff(parse("x*y"), "z") == ex.ZERO
    assert ex.diff(parse("3*x"), "x") == ex.Num(3.0)
    assert ex.to_text(ex.diff(parse("x**2"), "x")) == "2*x"
    assert ex.to_text(ex.diff(parse("g*x**3"), "x")) == "3*g*x**2"
    assert ex.to_text(ex.diff(parse("abs(x)"), "x")) == "sign(x)"
    assert ex.diff(parse("sign(x)"), "x") == ex.ZERO
    assert ex.to_text(parse("0*x + 1*y + x**1 + y**0")) == "y + x + 1"
    assert ex.to_text(ex.diff(parse("x**y"), "y")) == "x**y*log(x)"
    assert ex.to_text(ex.diff(parse("min(x, y)"), "x")) == "select(x <= y: 1, 0)"


def test_substitute_inlines_and_simplifies():
    node = ex.substitute(parse("F*cos(tau) + k"), {"F": parse("0.1*w**2"), "k": ex.Num(2.0)})
    assert ex.to_text(node) == "0.1*w**2*cos(tau) + 2"
