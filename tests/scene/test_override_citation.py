"""A value given by --set is cited as the --set that gave it, not as the scene's line it replaced."""

import re

import pytest
from hypothesis import given, settings, strategies as st

from contin.scene.parse import SceneError, parse_scene

SCENE = """
model:
  builtin: duffing
  parameters: {F: 0.5}
analysis:
  type: frequency_response
  range: [0.5, 3.0]
  stability: both
  continuation: {ds: 0.05}
"""


def test_a_bad_set_value_is_cited_as_typed():
    # before: "analysis.stability (line 8): ...", the line of the value the --set replaced
    with pytest.raises(SceneError, match=re.escape(
            "analysis.stability (--set analysis.stability=yes): expected one of 'hill', 'floquet', 'both', 'none', "
            "found True")):
        parse_scene(SCENE, "scene.yaml", ["analysis.stability=yes"])


def test_keys_inside_a_set_mapping_cite_it_and_the_file_keeps_its_lines():
    with pytest.raises(SceneError, match=re.escape("output.measure (--set output={measure: 3}): expected a string")):
        parse_scene(SCENE + "output:\n  measure: amp_x\n", "scene.yaml", ["output={measure: 3}"])
    with pytest.raises(SceneError, match=r"^analysis\.harmonics \(line 10\): "):  # not overridden: its line
        parse_scene(SCENE + "  harmonics: many\n", "scene.yaml", ["analysis.stability=hill"])
    # the last --set of a key is the one cited
    with pytest.raises(SceneError, match=re.escape("(--set analysis.stability=maybe)")):
        parse_scene(SCENE, "scene.yaml", ["analysis.stability=hill", "analysis.stability=maybe"])


@settings(max_examples=30, deadline=None)
@given(st.text(alphabet=st.characters(min_codepoint=33, max_codepoint=126, blacklist_characters="[]{},:#&*!|>'\"%@`"),
               min_size=1, max_size=12))
def test_any_refused_stability_value_names_its_set_never_a_line(text):
    if text in ("hill", "floquet", "both", "none") or text in ("~", "null", "Null", "NULL"):
        return  # the valid values, and YAML's null: the key's default, as in a scene file
    try:
        parse_scene(SCENE, "scene.yaml", [f"analysis.stability={text}"])
    except SceneError as exc:
        message = str(exc)
    else:
        raise AssertionError(f"analysis.stability={text} was accepted")
    assert message.startswith(f"analysis.stability (--set analysis.stability={text}): ") or \
        message.startswith("--set analysis.stability"), message  # a value YAML cannot parse
    assert not re.search(r"line \d", message.split(":")[0]), message  # (the value itself may be 'line')
