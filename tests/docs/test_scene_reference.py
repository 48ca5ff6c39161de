"""docs/reference/scenes.md is what scripts/docs/scene_reference.py writes from the scene schemas today."""

import runpy
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
GENERATOR = ROOT / "scripts" / "docs" / "scene_reference.py"


def test_the_committed_scene_reference_is_current():
    render = runpy.run_path(str(GENERATOR))["render"]
    page = ROOT / "docs" / "reference" / "scenes.md"
    assert page.read_text(encoding="utf-8") == render(), (
        "docs/reference/scenes.md differs from the scene schemas: run `python scripts/docs/scene_reference.py`")


def test_the_reference_lists_every_analysis_and_every_key():
    from contin.scene.parse import analysis_schemas

    text = (ROOT / "docs" / "reference" / "scenes.md").read_text(encoding="utf-8")
    for atype, schema in analysis_schemas().items():
        section = text.split(f"### type: {atype}\n", 1)[1].split("\n### ", 1)[0]
        for key in schema:
            assert f"| `{key}` |" in section, (atype, key)
