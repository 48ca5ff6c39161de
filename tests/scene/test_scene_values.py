"""Values and names a scene may hold: physically meaningless values and Unicode look-alike names are refused
with the key named, before any model is run (the command-line side is tests/cli/test_check_parity.py)."""

import pytest

from contin.scene.registry import check_scene
from contin.model.catalog import MODELS, _load, build_model, rule_violation
from contin.scene.build import build_model as build_scene_model
from contin.scene.parse import SceneError, parse_scene

DUFFING = """
model:
  builtin: duffing
  parameters: {m: 1, c: 0.1, k: 1, g: 1, F: 0.5}
analysis: {type: frequency_response, parameter: w, range: [0.5, 3.0], harmonics: 3}
"""

CUSTOM = """
model:
  dofs: [x]
  parameters: {m: 1, c: 0.05, k: 1, kc: 20, g: 1, F: 0.2, w: 0.5}
  mass: [[m]]
  damping: [[c]]
  stiffness: [[k]]
  forces: [{type: gap, dof: x, clearance: g, stiffness: kc, damping: 0}]
  excitation: [{dof: x, amplitude: F}]
analysis: {type: frequency_response, parameter: w, range: [0.5, 3.0], harmonics: 3, stability: none}
"""


def checked(text, overrides=()):
    """The scene through every check a run makes before writing (returns the check's plan)."""
    scene = parse_scene(text, "<test>", overrides)
    return check_scene(scene, build_scene_model(scene))


# ---------------------------------------------------------------- built-in models
def test_every_built_in_default_obeys_its_constraints():
    _load()
    for name, spec in MODELS.items():
        rules = spec.parameter_constraints(spec.options)
        assert rules, name
        assert set(rules) <= set(spec.parameters), name
        assert spec.frequency in rules, name
        for k, rule in rules.items():
            assert rule_violation(rule, spec.parameters[k]) is None, (name, k)


@pytest.mark.parametrize("model,params,options,match", [
    ("duffing", {"m": 0.0}, {}, r"model\.parameters\.m: expected a number > 0 \(a mass\), found 0\.0"),
    ("duffing", {"c": -0.1}, {}, r"model\.parameters\.c: expected a number >= 0 \(a viscous damping\)"),
    ("mathieu", {"w": -1.0}, {}, r"model\.parameters\.w: expected a number >= 0 \(the excitation frequency\)"),
    ("linear_chain", {"m3": -4.0}, {"n": 3}, r"model\.parameters\.m3: expected a number > 0 \(the mass of mass 3\)"),
    ("linear_chain", {"c4": -1.0}, {"n": 3}, r"model\.parameters\.c4: expected a number >= 0"),
    ("bearing_rotor", {"delta": -0.1}, {}, r"model\.parameters\.delta: .*>= 0 \(the radial clearance\)"),
    ("bearing_rotor", {"cbn": -0.5}, {}, r"model\.parameters\.cbn: .*\(the contact damping\)"),
    ("timing_belt", {"zeta": -0.01}, {}, r"model\.parameters\.zeta: .*\(the modal damping ratio\)"),
    ("timing_belt", {"xi_obs": 1.5}, {}, r"model\.parameters\.xi_obs: expected a position strictly between 0 and 1"),
])
def test_built_in_constraints_hold_in_the_python_api(model, params, options, match):
    with pytest.raises(ValueError, match=match):
        build_model(model, params, **options)


@pytest.mark.parametrize("override", [
    "model.parameters.k=-1",      # a double well
    "model.parameters.g=-0.05",   # a softening spring
    "model.parameters.F=-0.5",    # a force of the opposite phase
    "model.parameters.c=0",       # no damping
])
def test_meaningful_negative_and_zero_values_stay_accepted(override):
    checked(DUFFING, [override])


def test_a_scene_names_the_parameter_and_its_line():
    with pytest.raises(SceneError, match=r"^model\.parameters\.m \(line 4\): expected a number > 0 \(a mass\), "
                                         r"found -2") as exc:
        parse_scene(DUFFING.replace("m: 1,", "m: -2,"))
    assert exc.value.key == "model.parameters.m"


def test_the_continued_parameter_is_held_to_its_constraint():
    with pytest.raises(SceneError, match=r"^analysis\.range .*values of c, each a number >= 0 \(a viscous damping\)"):
        parse_scene(DUFFING, overrides=["analysis.parameter=c", "analysis.range=[-0.1, 0.1]"])


def test_a_further_start_outside_the_frequencies_is_named():
    # the value came from --set, and the message cites it as such
    with pytest.raises(SceneError, match=r"^analysis\.starts\[0\]\.start \(--set analysis\.starts=\[\{start: -1\}\]\): "
                                         r"expected values of w"):
        parse_scene(DUFFING, overrides=["analysis.range=[3.0, 0.0]", "analysis.starts=[{start: -1}]"])


# ---------------------------------------------------------------- custom models
def test_the_frequency_named_by_the_analysis_is_the_one_held_to_be_non_negative():
    text = CUSTOM.replace("w: 0.5}", "w: 0.5, W: 1.0}")
    checked(text, ["analysis.range=[-1, 1]", "analysis.parameter=k"])  # k is no frequency here
    with pytest.raises(SceneError, match=r"^analysis\.range .*values of W, each a number >= 0"):
        parse_scene(text, overrides=["analysis.frequency=W", "analysis.parameter=W", "analysis.range=[-1, 1]"])


def test_a_negative_scalar_mass_names_the_mass():
    with pytest.raises(SceneError, match=r"^model\.mass .*a positive mass on the diagonal \(the inertia of dof x"):
        checked(CUSTOM.replace("mass: [[m]]", "mass: -1"))


def test_a_mass_matrix_that_loses_definiteness_at_a_value_of_the_modes_parameter_is_refused():
    text = CUSTOM.replace("analysis: {type: frequency_response, parameter: w, range: [0.5, 3.0], harmonics: 3, "
                          "stability: none}", "analysis: {type: modes, parameter: m, values: [1, -1]}")
    text = text.replace("  forces: [{type: gap, dof: x, clearance: g, stiffness: kc, damping: 0}]\n", "")
    with pytest.raises(SceneError, match=r"^model\.mass: expected a symmetric positive definite mass matrix at "
                                         r"m = -1"):
        checked(text)


@pytest.mark.parametrize("value", ["0", "0.0*kc"])
def test_a_stop_touching_at_rest_or_without_stiffness_is_allowed(value):
    checked(CUSTOM.replace("clearance: g", f"clearance: {value}"))
    checked(CUSTOM.replace("stiffness: kc", f"stiffness: {value}"))


def test_a_contact_coefficient_is_checked_at_the_default_parameters():
    with pytest.raises(SceneError, match=r"^model\.forces\[0\]\.stiffness .*it is -20"):
        checked(CUSTOM.replace("stiffness: kc", 'stiffness: "-kc"'))


# ---------------------------------------------------------------- names
def test_names_that_nfkc_would_merge_are_refused():
    # 'ﬁ' (U+FB01) is read as 'fi' by Python's parser: both would be one parameter in the expressions
    text = CUSTOM.replace("w: 0.5}", "w: 0.5, fi: 1, ﬁ: 2}")
    with pytest.raises(SceneError, match=r"^model\.parameters\.ﬁ .*'ﬁ' \(U\+FB01\) reads as 'fi'.*write 'fi'"):
        parse_scene(text)


def test_a_fullwidth_name_in_an_expression_is_refused_with_its_key():
    text = CUSTOM.replace("amplitude: F}", "amplitude: Ｆ}")
    with pytest.raises(SceneError, match=r"^model\.excitation\[0\]\.amplitude .*'Ｆ' \(U\+FF26\) reads as 'F'"):
        parse_scene(text)


def test_free_text_may_use_any_characters():
    text = CUSTOM + 'output: {title: "ﬁt of x in µm", units: {w: "rad/s²"}, labels: {amp_x: "ｘ amplitude"}}\n'
    checked(text)
