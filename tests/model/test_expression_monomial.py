"""Coefficients read as a constant times integer powers of parameters, through the expression parser."""

import doctest
import math

import pytest

from contin.model import expressions as ex
from contin.model.expressions import ExpressionError, monomial, parse_monomial

NAMES = ["k", "kc", "w", "m", "e"]


@pytest.mark.parametrize("text,want", [
    (3, (3.0, ())),
    (2.5, (2.5, ())),
    ("3", (3.0, ())),
    ("k", (1.0, ((0, 1),))),
    ("-kc", (-1.0, ((1, 1),))),
    ("-0.5*k*w**2", (-0.5, ((0, 1), (2, 2)))),
    ("e*w**2", (1.0, ((2, 2), (4, 1)))),
    ("k**-1", (1.0, ((0, -1),))),
    ("k/m", (1.0, ((0, 1), (3, -1)))),
    ("-k*-w", (1.0, ((0, 1), (2, 1)))),
    ("(2*k*w)**2/k", (4.0, ((0, 1), (2, 2)))),
    ("k*k*k**-2*w", (1.0, ((2, 1),))),  # a power that cancels is dropped
    ("2*pi*w", (2 * math.pi, ((2, 1),))),  # pi is the constant
    ("0*k", (0.0, ())),
])
def test_products_of_parameter_powers(text, want):
    assert parse_monomial(text, NAMES, "c") == want


def test_pi_is_a_parameter_when_one_is_named_so():
    assert parse_monomial("2*pi*w", ["w", "pi"]) == (2.0, ((0, 1), (1, 1)))


@pytest.mark.parametrize("text", ["-0.5*k*w**2", "k/m/w**3", "(k*w)**-2*3e-4", "-(kc*2)**3", "e*w**2/(2*m)"])
def test_the_value_is_the_expression_value(text, rng):
    p = rng.uniform(0.5, 2.0, len(NAMES))
    const, powers = parse_monomial(text, NAMES)
    value = const * math.prod(p[j] ** e for j, e in powers)
    assert value == pytest.approx(float(ex.evaluate(ex.parse(text), dict(zip(NAMES, p)))), rel=1e-14)


@pytest.mark.parametrize("text,fragment", [
    ("kk", r"model.stiffness\[0\]\[1\]: unknown parameter 'kk' in 'kk' \(did you mean 'k'\?\)"),
    ("k + 1", r"in 'k \+ 1', found a sum: 'k \+ 1'"),
    ("2*sin(w)", r"found a call of sin\(\): 'sin\(w\)'"),
    ("k**0.5", r"power of 'k' must be an integer in 'k\*\*0.5'"),
    ("(k*w)**m", r"power of 'k\*w' must be an integer"),
    ("k/0", "division by zero in 'k/0'"),
    ("k/(0*w)", "division by zero"),
    ("k*1e308*10", "the constant factor of 'k\\*1e308\\*10' is not finite"),
    ("e*w^2", r"operator '\^' is not allowed"),
    ("k.real", "attribute access"),
    (True, "expected an expression"),
    (float("inf"), "not finite"),
])
def test_refusals_name_the_key_and_the_part(text, fragment):
    with pytest.raises(ExpressionError, match=fragment) as info:
        parse_monomial(text, NAMES, "model.stiffness[0][1]")
    assert isinstance(info.value, ValueError)
    assert str(info.value).startswith("model.stiffness[0][1]: ")


def test_long_text_is_shortened_in_messages():
    text = "k*" * 100 + "kk"
    with pytest.raises(ExpressionError) as info:
        parse_monomial(text, NAMES)
    assert len(str(info.value)) < len(text)


def test_the_documented_examples_run():
    failed, attempted = doctest.testmod(monomial)
    assert attempted and not failed

