"""Scene loading: every class of bad input names the key (SPEC 5)."""

import pytest

from contin.scene.parse import SceneError, apply_override, parse_scene

GOOD = """
model:
  builtin: duffing
  parameters: {F: 0.5}
analysis:
  type: frequency_response
  range: [0.5, 3.0]
"""


def test_defaults_are_filled_in():
    s = parse_scene(GOOD)
    a = s.analysis
    assert a["harmonics"] == 5 and a["subharmonic"] == 1 and a["stability"] == "both" and a["switch"] == []
    assert s.output["plots"] is True and s.output["harmonic_columns"] == 5


def test_malformed_yaml_gives_the_line():
    with pytest.raises(SceneError, match=r"line 4.*valid YAML.*YAML parser says"):
        parse_scene("model:\n  builtin: duffing\n  parameters: {F: 0.5\nanalysis: {}\n")


def test_unknown_key_with_suggestion_and_line():
    text = GOOD + "  harmonix: 3\n"
    with pytest.raises(SceneError, match=r"analysis.harmonix \(line 8\).*did you mean 'harmonics'"):
        parse_scene(text)
    with pytest.raises(SceneError, match=r"analysys.*did you mean 'analysis'"):
        parse_scene(GOOD + "analysys: {}\n")


@pytest.mark.parametrize("override,pattern", [
    ("analysis.harmonics=ten", r"analysis.harmonics.*integer from 1 to 2000.*found 'ten'"),
    ("analysis.harmonics=2.5", r"analysis.harmonics.*integer"),
    ("analysis.range=[1]", r"analysis.range.*two different numbers.*found \[1\]"),
    ("analysis.range=[2, 2]", r"analysis.range.*two different numbers"),
    ("analysis.range=[0, .inf]", r"analysis.range"),
    ("analysis.stability=maybe", r"analysis.stability.*'hill', 'floquet', 'both', 'none'"),
    ("analysis.switch=[hopf]", r"analysis.switch.*'pd', 'bp', 'ns'"),
    ("analysis.torus={harmonics2: 0}", r"analysis.torus.*harmonics, harmonics2.*found \{'harmonics2': 0\}"),
    ("analysis.torus={stability: hill}", r"analysis.torus.*stability \('simulation' or 'none'\)"),
    ("analysis.torus={harmonic2: 3}", r"analysis.torus.*keys among harmonics, harmonics2"),
    ("analysis.type=frequency", r"analysis.type.*did you mean 'frequency_response'"),
    ("output.plots=yes please", r"output.plots.*true or false"),
    ("model.effects=cubic", r"model.effects.*list of effect names"),
])
def test_wrong_types_and_impossible_values(override, pattern):
    with pytest.raises(SceneError, match=pattern):
        parse_scene(GOOD, overrides=[override])


def test_missing_sections_and_required_keys():
    with pytest.raises(SceneError, match=r"analysis: expected a mapping \(required section\)"):
        parse_scene("model: {builtin: duffing}\n")
    with pytest.raises(SceneError, match=r"analysis.range.*expected .*\(required\)"):
        parse_scene("model: {builtin: duffing}\nanalysis: {type: frequency_response}\n")
    with pytest.raises(SceneError, match=r"top level.*mapping"):
        parse_scene("- 1\n- 2\n")


def test_set_overrides_parse_yaml_values():
    d = {"analysis": {"range": [0, 1]}}
    apply_override(d, "analysis.range=[0, 10]")
    apply_override(d, "model.parameters.f0=0.2")
    assert d["analysis"]["range"] == [0, 10] and d["model"]["parameters"]["f0"] == 0.2
    with pytest.raises(SceneError, match=r"--set.*dotted.key=value"):
        apply_override(d, "analysis.range")
    with pytest.raises(SceneError, match=r"--set analysis.range.x.*'analysis.range' to be a mapping"):
        apply_override(d, "analysis.range.x=1")


def test_start_outside_range_is_refused(tmp_path):
    from contin.app.runner import run_scene

    s = parse_scene(GOOD, overrides=["analysis.start=5", "analysis.stability=none"])
    with pytest.raises(SceneError, match=r"analysis.start.*inside range \[0.5, 3\]"):
        run_scene(s, tmp_path, progress=False)


def test_exponent_without_a_dot_is_a_number():
    """PyYAML (YAML 1.1) reads 1e-6 as a string; scenes read it as YAML 1.2 does."""
    scene = parse_scene("model: {builtin: duffing, parameters: {F: 2e-1}}\n"
                        "analysis: {type: frequency_response, range: [0.5, 2], continuation: {newton_tol: 1e-9}}\n",
                        overrides=["analysis.continuation.ds=5E-3"])
    assert scene.model["parameters"]["F"] == 0.2
    assert scene.analysis["continuation"] == {"newton_tol": 1e-9, "ds": 5e-3}


def test_further_starts_are_checked_with_the_scene():
    base = "model: {builtin: duffing}\nanalysis: {type: frequency_response, range: [0.5, 2], starts: %s}\n"
    scene = parse_scene(base % "[{start: 1.2, subharmonic: 2, harmonics: 6}]")
    assert scene.analysis["starts"] == [{"start": 1.2, "subharmonic": 2, "harmonics": 6}]
    with pytest.raises(SceneError, match=r"analysis.starts\[0\].strat.*did you mean 'start'"):
        parse_scene(base % "[{strat: 1.2}]")
    with pytest.raises(SceneError, match=r"analysis.starts\[1\].subharmonic.*expected an integer from 1 to 64, found 0"):
        parse_scene(base % "[{start: 1.0}, {subharmonic: 0}]")
    with pytest.raises(SceneError, match=r"analysis.starts.*expected a list of mappings"):
        parse_scene(base % "[1.2]")


def test_torus_settings_are_checked_against_their_harmonics(tmp_path):
    """A grid too small for the torus' harmonics, and ns switching without stability, are refused before
    anything is written."""
    from contin.app.runner import run_scene

    text = GOOD + "  switch: [ns]\n"
    for extra, pattern in (({"analysis.torus": "{harmonics2: 4, samples2: 5}"}, r"analysis.torus.*samples2"),
                           ({"analysis.stability": "none"}, r"analysis.switch.*Neimark-Sacker")):
        scene = parse_scene(text, overrides=[f"{k}={v}" for k, v in extra.items()])
        out = tmp_path / "out"
        with pytest.raises(SceneError, match=pattern):
            run_scene(scene, out, progress=False)
        assert not (out / "branches.csv").exists()
