"""How expressions depend on the state and on tau: polynomial degree, tau orders, harmonic bound; tree measures."""

from contin.model import expressions as ex
from contin.model.expressions import parse


def test_analysis_helpers():
    st_names = ["x", "y", "x_dot", "y_dot"]
    assert ex.polynomial_degree(parse("g*x**3 + x*y*y_dot + sin(w)*x"), st_names) == 3
    assert ex.polynomial_degree(parse("x/(1 + y)"), st_names) is None
    assert ex.polynomial_degree(parse("abs(x)*x"), st_names) is None
    assert ex.polynomial_degree(parse("x**1000"), st_names) is None
    assert ex.polynomial_degree(parse("F*cos(tau)"), st_names) == 0
    assert ex.tau_orders(parse("e*cos(2*tau)*x + sin(tau + 0.5)")) == (1.0, 2.0)
    assert ex.tau_orders(parse("exp(tau)")) is None
    assert ex.tau_orders(parse("cos(w*tau)")) is None
    assert ex.harmonic_bound(parse("F*cos(tau)**3 + sin(2*tau)")) == 3.0
    assert ex.harmonic_bound(parse("exp(cos(tau))")) is None
    assert ex.measure(parse("a + b*c")) == (3, 5)
