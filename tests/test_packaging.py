"""Packaging: every subpackage is installed, and nothing generic lands at the top level."""

import configparser
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def listed_packages():
    cfg = configparser.ConfigParser()
    cfg.read(ROOT / "setup.cfg")
    return {p.strip() for p in cfg["options"]["packages"].split("\n") if p.strip()}


def test_every_subpackage_is_listed():
    found = {"contin." + ".".join(p.parent.relative_to(ROOT / "contin").parts) if p.parent != ROOT / "contin" else "contin"
             for p in (ROOT / "contin").rglob("__init__.py")}
    found.add("contin.models")
    assert found <= listed_packages(), f"missing in setup.cfg: {found - listed_packages()}"


def test_only_contin_is_installed_at_top_level():
    assert all(p == "contin" or p.startswith("contin.") for p in listed_packages())


def test_builtin_models_import_through_the_package():
    import contin.models
    from contin.model.catalog import MODELS

    assert contin.models.__name__ == "contin.models"
    assert {"duffing", "mathieu"} <= set(MODELS)
