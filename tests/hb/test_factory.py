"""The one factory of harmonic-balance problems: defaults, condensation choices and refusals.

Truth from outside the factory: the closed-form receptance of a 2-DOF chain
(Cramer's rule on the 2x2 impedance), the unknown count ``n (2H+1)`` and the
dofs a cubic spring acts on, read off the model's definition.
"""

import functools

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from conftest import fuzz_examples
from contin.engine.continuation import ContinuationOptions
from contin.engine.newton import solve_at_parameter
from contin.hb import harmonic_balance
from contin.hb.condensation import CondensedHarmonicBalance
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.model.catalog import build_model
from contin.models.polynomial import polynomial_model

CHAIN = {"m1": 1.0, "m2": 2.0, "k1": 1.0, "k2": 0.5, "k3": 2.0, "c1": 0.02, "c2": 0.05, "c3": 0.01, "F1": 0.7,
         "w": 0.9}


@functools.lru_cache(maxsize=None)
def two_dof_cubic(c=0.05):
    """Two masses in a chain, a cubic spring on the second one (dof 1), the force on the first."""
    return polynomial_model(
        ["x1", "x2"], {"k": 1.0, "c": c, "g": 2.0, "F": 1.0, "w": 1.2}, mass=[[1, 0], [0, 2]],
        damping=[["2*c", "-c"], ["-c", "c"]], stiffness=[["2*k", "-k"], ["-k", "k"]],
        nonlinear=[{"dof": "x2", "coef": "g", "x": {"x2": 3}}], forcing=[{"dof": "x1", "amplitude": "F"}])


def test_the_continuation_parameter_defaults_to_the_frequency():
    model = build_model("duffing")
    hb = harmonic_balance(model, options={"harmonics": 3})
    assert isinstance(hb, HarmonicBalance)
    assert hb.parameter == hb.frequency == model.frequency and hb.frequency_moves
    assert (hb.H, hb.size) == (3, model.n_dof * 7)
    other = harmonic_balance(two_dof_cubic(), frequency="k")  # a frequency other than the model's declared one
    assert other.parameter == other.frequency == "k"
    named = harmonic_balance(model, "F", HBOptions(harmonics=2), {"F": 0.3})
    assert named.parameter == "F" and not named.frequency_moves and named.params_at(0.5)[named.k] == 0.5


@pytest.mark.parametrize("condense", [[0], (1,), np.array([0])])
def test_condensed_onto_given_dofs_gives_the_closed_form_receptance(condense):
    w = 1.3
    ch = harmonic_balance(build_model("linear_chain", CHAIN), "w", {"harmonics": 2}, condense=condense)
    assert isinstance(ch, CondensedHarmonicBalance) and list(ch.dofs) == list(np.asarray(condense))
    res = solve_at_parameter(ch, np.zeros(ch.size), w, ContinuationOptions(newton_tol=1e-12))
    assert res.converged, res.message
    u = ch.expand(res.x, w).reshape(-1, 2)
    # x = Re(X e^{iwt}) with Z X = (F1, 0), Z the 2x2 impedance (Cramer's rule)
    p = CHAIN
    z11 = p["k1"] + p["k2"] - p["m1"] * w**2 + 1j * w * (p["c1"] + p["c2"])
    z22 = p["k2"] + p["k3"] - p["m2"] * w**2 + 1j * w * (p["c2"] + p["c3"])
    z12 = -p["k2"] - 1j * w * p["c2"]
    X = np.array([z22, -z12]) * p["F1"] / (z11 * z22 - z12 * z12)
    np.testing.assert_allclose(u[1], X.real, atol=1e-12)
    np.testing.assert_allclose(u[2], -X.imag, atol=1e-12)


def test_auto_condenses_only_where_the_eliminated_blocks_are_surely_regular():
    damped = harmonic_balance(two_dof_cubic(), options={"harmonics": 3}, condense="auto")
    assert isinstance(damped, CondensedHarmonicBalance) and list(damped.dofs) == [1]  # the cubic spring's dof
    assert damped.full.size == 2 * 7 and damped.size == 7
    undamped = two_dof_cubic(c=0.0)  # x1 alone resonates at sqrt(2k/m1): auto keeps it
    assert isinstance(harmonic_balance(undamped, condense="auto"), HarmonicBalance)
    assert isinstance(harmonic_balance(undamped, condense=True), CondensedHarmonicBalance)
    assert isinstance(harmonic_balance(undamped, condense=False), HarmonicBalance)
    assert isinstance(harmonic_balance(undamped, condense=np.True_), CondensedHarmonicBalance)


@pytest.mark.parametrize("kwargs, match", [
    ({"condense": "yes"}, r"condense must be False, 'auto', True or a sequence of dof indices, got 'yes'"),
    ({"condense": 1}, r"condense must be .* got 1"),
    ({"condense": None}, r"condense must be .* got None"),
    ({"condense": [0.5]}, r"condense must be .* got \[0\.5\]"),
    ({"condense": [True]}, r"condense must be .* got \[True\]"),
    ({"condense": {"x2": 1}}, r"condense must be .*"),
    ({"condense": [0]}, r"dofs \['x2'\] carry nonlinear forces and must be kept"),
    ({"condense": [5]}, r"non-empty proper subset of 0\.\.1"),
    ({"options": 5}, r"options must be HBOptions or a mapping of its fields, got int"),
    ({"options": {"harmonic": 3}}, r"unknown option 'harmonic'"),
    ({"options": {"harmonics": -1}}, r"HBOptions\.harmonics must be an integer >= 0"),
    ({"parameter": "kk"}, r"kk"),
    ({"frequency": "ww"}, r"ww"),
])
def test_hostile_arguments_are_refused_by_name(kwargs, match):
    with pytest.raises(ValueError, match=match):
        harmonic_balance(two_dof_cubic(), **kwargs)


def test_no_dof_to_condense_out_is_refused_when_required():
    with pytest.raises(ValueError, match="no dof can be condensed out: the model has no nonlinear force"):
        harmonic_balance(build_model("linear_chain", CHAIN), condense=True)
    with pytest.raises(ValueError, match="model must be a Model, got str"):
        harmonic_balance("duffing")


@settings(max_examples=fuzz_examples(40), deadline=None)
@given(st.one_of(st.text(max_size=6), st.integers(), st.floats(), st.lists(st.floats(), max_size=3)))
def test_any_other_condense_value_is_refused_with_its_name(value):
    if isinstance(value, str) and value == "auto":
        return
    with pytest.raises(ValueError, match="condense"):
        harmonic_balance(two_dof_cubic(), options={"harmonics": 1}, condense=value)
