"""Axis labels: symbols for parameters and dofs, words for measures; never a raw column name."""

import re

import pytest

from contin.model.catalog import get_spec
from contin.output.labels import axis_label, math, quantity, symbol

BELT = {"parameter:w": r"\Omega", "w": r"$w$ at $\xi = 0.6$"}


def _words(label: str) -> str:
    """The label without its mathtext."""
    return re.sub(r"\$[^$]*\$", "", label)


@pytest.mark.parametrize("name,expected", [
    ("eps", r"\varepsilon"), ("delta", r"\delta"), ("x1", "x_{1}"), ("gamma0", r"\gamma_{0}"),
    ("x_dot", r"\dot{x}"), ("p_d", "p_{d}"), ("xi_obs", r"\xi_{\mathrm{obs}}"), ("x", "x"),
])
def test_names_become_symbols(name, expected):
    assert symbol(name) == expected


def test_measures_read_as_words_around_the_dofs_symbol():
    assert quantity("amp_x") == "amplitude of $x$"
    assert quantity("rms_x1") == "RMS of $x_{1}$"
    assert quantity("h0_x") == "mean of $x$" and quantity("h3_x") == "harmonic 3 of $x$"
    assert quantity("amp_x_dot") == r"amplitude of $\dot{x}$"
    assert "multiplier" in quantity("max_multiplier")


def test_scene_labels_win_over_model_symbols_which_win_over_the_rules():
    assert axis_label("w") == "$w$"
    assert axis_label("w", symbols={"w": r"\Omega"}) == r"$\Omega$"
    assert axis_label("w", labels={"w": "speed"}, symbols={"w": r"\Omega"}) == "speed"
    assert axis_label("w", units={"w": "rad/s"}, symbols={"w": r"\Omega"}) == r"$\Omega$ [rad/s]"


def test_a_parameter_and_an_observable_of_one_name_read_apart():
    # the belt's frequency w and its displacement w at the observation point
    assert axis_label("w", symbols=BELT, role="parameter") == r"$\Omega$"
    assert axis_label("w", symbols=BELT) == r"$w$ at $\xi = 0.6$"
    assert axis_label("rms_w", symbols=BELT) == r"RMS of $w$ at $\xi = 0.6$"
    assert axis_label("w_rms", symbols=BELT) == r"RMS of $w$ at $\xi = 0.6$"
    assert math("w", BELT, "parameter") == r"$\Omega$"


def test_a_declared_phrase_names_a_models_own_column():
    s = {"whirl_fwd_half_disc": r"forward whirl of the disc at $\Omega/2$"}
    assert axis_label("whirl_fwd_half_disc", symbols=s) == s["whirl_fwd_half_disc"]


@pytest.mark.parametrize("model", ["duffing", "mathieu", "bearing_rotor", "timing_belt", "linear_chain"])
def test_no_raw_name_reaches_an_axis_of_a_builtin_model(model):
    from contin.analyses.frequency_response import row_measures  # the columns a diagram can plot

    m = get_spec(model).build()
    columns = row_measures(m.dof_names, 5, 3, m) + ["max_multiplier", "n_unstable"]
    for name in list(m.parameters):
        label = axis_label(name, symbols=m.symbols, role="parameter")
        assert "_" not in _words(label) and name not in _words(label).split(), (name, label)
    for name in columns:
        label = axis_label(name, symbols=m.symbols)
        assert "_" not in _words(label) and name not in _words(label), (name, label)
    assert axis_label(m.frequency, symbols=m.symbols, role="parameter") == r"$\Omega$"


def test_the_excitation_frequency_reads_omega_unless_the_model_names_it():
    from types import SimpleNamespace

    from contin.output.labels import model_symbols

    custom = SimpleNamespace(frequency="W", symbols={})
    assert axis_label("W", symbols=model_symbols(custom), role="parameter") == r"$\Omega$"
    assert axis_label("amp_W", symbols=model_symbols(custom)) == "amplitude of $W$"  # a dof W is not the frequency
    named = SimpleNamespace(frequency="w", symbols={"w": r"\nu"})
    assert axis_label("w", symbols=model_symbols(named), role="parameter") == r"$\nu$"
