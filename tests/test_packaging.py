"""Packaging: every subpackage is installed, nothing generic lands at the top level, the dependencies and their
lower bounds are the documented ones, and Dask is optional."""

import configparser
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

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


def requirements(text):
    """``{name: lower bound}`` of requirement lines ``name[extras]>=version``."""
    out = {}
    for line in text.split("\n"):
        line = line.strip()
        if line and not line.startswith("#"):
            m = re.fullmatch(r"([A-Za-z0-9_.-]+)(\[[^\]]*\])?>=([0-9][0-9.]*)", line)
            assert m, f"a requirement without a lower bound: {line!r}"
            out[m.group(1).lower()] = m.group(3)
    return out


def setup_cfg():
    cfg = configparser.ConfigParser()
    cfg.read(ROOT / "setup.cfg")
    return cfg


def test_dask_is_the_sweep_extra_not_a_dependency():
    cfg = setup_cfg()
    install = requirements(cfg["options"]["install_requires"])
    assert "dask" not in install and "distributed" not in install
    assert requirements(cfg["options.extras_require"]["sweep"]) == {"dask": "2024.1"}
    assert "dask[distributed]>=2024.1" in cfg["options.extras_require"]["sweep"]


def test_ross_is_an_extra_and_its_absence_is_told(monkeypatch):
    """ROSS (1.2 GB) is the `ross` extra, never a dependency; the bridge imports without it and says what to
    install when it is asked for."""
    cfg = setup_cfg()
    assert "ross-rotordynamics" not in requirements(cfg["options"]["install_requires"])
    extra = cfg["options.extras_require"]["ross"].split()
    assert extra == ["ross-rotordynamics>=2.3", "plotly<6"]
    from contin.model.fem.ross_bridge import import_ross

    monkeypatch.setitem(sys.modules, "ross", None)
    with pytest.raises(ImportError, match=r"pip install 'contin\[ross\]'"):
        import_ross()


def test_lower_bounds_are_the_documented_ones():
    install = requirements(setup_cfg()["options"]["install_requires"])
    table = (ROOT / "docs/reference/dependencies.md").read_text().split("## ")[0]
    documented = {m.group(1).lower(): m.group(2)
                  for m in re.finditer(r"^\| ([A-Za-z0-9_.-]+) \| ([0-9][0-9.]*) \|", table, re.MULTILINE)}
    assert documented == install
    # what the installed rocket-fft requires of numba and numpy is within the bounds
    from importlib.metadata import requires, version

    for req in requires("rocket-fft") or []:
        m = re.fullmatch(r"(numba|numpy)\s*>=\s*([0-9.]+)", req.split(";")[0].strip())
        if m:
            assert _version(install[m.group(1)]) >= _version(m.group(2)), req
    for name, low in install.items():  # and the environment the tests run in satisfies them
        assert _version(version(name)) >= _version(low), name


def _version(text):
    from packaging.version import Version  # installed with matplotlib

    return Version(text)


def test_contin_and_contin_run_never_import_dask():
    """Every module but the sweep's imports without Dask; `contin check` runs the path of `contin run` up to
    the numerics (build and every check)."""
    code = """
import importlib, pkgutil, sys
import contin
for m in pkgutil.walk_packages(contin.__path__, "contin."):
    if not m.name.startswith("contin.app.sweep"):
        importlib.import_module(m.name)
from contin.app.cli import main
assert main(["check", sys.argv[1]]) == 0
assert main(["models"]) == 0
loaded = sorted(m for m in sys.modules if m.split(".")[0] in ("dask", "distributed"))
assert not loaded, loaded
"""
    env = dict(os.environ, MPLBACKEND="Agg")
    proc = subprocess.run([sys.executable, "-c", code, str(ROOT / "scenes/duffing.yaml")], capture_output=True,
                          text=True, env=env, cwd=ROOT, timeout=300)
    assert proc.returncode == 0, proc.stderr
