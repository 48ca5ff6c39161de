"""Absorber designs whose ratios over- or underflow are refused naming the values (design_absorber in
contin/modal/absorber_design.py), never a ZeroDivisionError or OverflowError."""

import math

import pytest
from hypothesis import given, settings, strategies as st

from conftest import fuzz_examples
from contin.modal.absorber_design import design_absorber

MASS_RATIOS = (1e-3, 1e3)  # contin.modal.absorber_design.MASS_RATIOS, as documented in docs/reference/cli.md


def test_a_denormal_absorber_mass_is_refused_naming_it():
    with pytest.raises(ValueError, match=r"m2 = 1e-320 with m1 = 100.0 gives the mass ratio m2/m1 = 9.881e-323, "
                                         r"outside the 0.001 to 1000"):
        design_absorber(100.0, 5e5, 1e-320)


def test_values_whose_frequency_overflows_are_refused_naming_them():
    with pytest.raises(ValueError, match=r"m1 = 1e-300, k1 = 1e\+300, m2 = 1e-300: the design's c = inf, p = inf"):
        design_absorber(1e-300, 1e300, 1e-300)


@pytest.mark.parametrize("A, sizing, match", [
    (1e200, "fixed_points", r"max_amplification = 1e\+200 asks the mass ratio m2/m1 = 2/\(A\^2 - 1\) = 0"),
    (1.0000000001, "fixed_points", "asks the mass ratio m2/m1 = 2/\\(A\\^2 - 1\\) = 1e\\+10"),
    (1.0335, "peak", r"with sizing 'peak' asks the mass ratio m2/m1 = 1465"),
])
def test_amplifications_asking_a_ratio_out_of_range_are_refused(A, sizing, match):
    with pytest.raises(ValueError, match=match):
        design_absorber(100.0, 5e5, max_amplification=A, sizing=sizing)


def test_the_ends_of_the_ratio_range_are_designed():
    from contin.modal.absorber_design import MASS_RATIOS as ratios

    assert ratios == MASS_RATIOS
    for beta in MASS_RATIOS:
        d = design_absorber(1.0, 1.0, beta)
        assert d.fixed_point_height == pytest.approx(math.sqrt((2 + beta) / beta), rel=1e-12)
        assert 1.0 <= d.true_peak.amplification / d.fixed_point_height < 1.04


_exponents = st.integers(-320, 308)


@settings(max_examples=fuzz_examples(200), deadline=None)
@given(e1=_exponents, ek=_exponents, de=st.integers(-4, 3) | st.integers(-630, 630), f1=st.floats(1, 9.99),
       fk=st.floats(1, 9.99), f2=st.floats(1, 9.99))
def test_any_positive_values_give_a_design_or_a_message(e1, ek, de, f1, fk, f2):
    m1, k1, m2 = f1 * 10.0**e1, fk * 10.0**ek, f2 * 10.0 ** max(-320, min(308, e1 + de))
    if not all(v > 0 and math.isfinite(v) for v in (m1, k1, m2)):
        return  # beyond double precision before contin sees it
    try:
        d = design_absorber(m1, k1, m2)
    except ValueError as exc:
        assert "m2 = " in str(exc) and ("mass ratio" in str(exc) or "double precision" in str(exc))
        return
    beta = m2 / m1  # Den Hartog's closed forms (seed 000, sec. 7.4)
    assert MASS_RATIOS[0] <= beta <= MASS_RATIOS[1]
    assert d.k2 == pytest.approx(k1 * beta / (1 + beta) ** 2, rel=1e-12)
    assert d.c == pytest.approx(2 * m2 * math.sqrt(k1 / m1) * math.sqrt(3 * beta / (8 * (1 + beta) ** 3)), rel=1e-12)
    assert all(math.isfinite(v) and v > 0 for v in (d.k2, d.c, d.p, d.true_peak.amplification))
