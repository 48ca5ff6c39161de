"""Packaging: the metadata in pyproject.toml's [project] table, every subpackage and the example scenes installed,
nothing generic at the top level, the dependencies and their lower bounds the documented ones, Dask optional."""

import fnmatch
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    tomllib = pytest.importorskip("tomli")

ROOT = Path(__file__).resolve().parents[1]
#: where the installed packages come from: contin/, models/ (contin.models) and scenes/ (contin.scenes)
SOURCES = {"contin": "contin", "contin.models": "models", "contin.scenes": "scenes"}


def pyproject() -> dict:
    with open(ROOT / "pyproject.toml", "rb") as fh:
        return tomllib.load(fh)


def project() -> dict:
    return pyproject()["project"]


def setuptools_config() -> dict:
    return pyproject()["tool"]["setuptools"]


def installed_packages() -> set[str]:
    """The packages setuptools finds from the package-dir mapping (its own discovery, no list kept by hand)."""
    from setuptools.discovery import _find_packages_within

    config = setuptools_config()
    assert "packages" not in config, "packages are found from package-dir; a hand-kept list goes stale"
    return {pkg for name, where in config["package-dir"].items() for pkg in _find_packages_within(name, ROOT / where)}


def test_the_metadata_is_in_pyproject_alone():
    assert not (ROOT / "setup.cfg").exists() and not (ROOT / "setup.py").exists()
    p = project()
    assert p["name"] == "contin" and p["dynamic"] == ["version"]
    assert pyproject()["tool"]["setuptools"]["dynamic"]["version"] == {"attr": "contin.util.version.__version__"}
    assert p["readme"] == "README.md" and p["requires-python"] == ">=3.10"
    assert p["scripts"] == {"contin": "contin.app.cli:main"}
    assert "Programming Language :: Python :: 3" in p["classifiers"]
    from importlib.metadata import version

    from contin.util.version import __version__

    assert version("contin") == __version__  # the installed metadata took the version from there


def test_the_licence_is_mit_and_ships():
    p = project()
    assert p["license"] == "MIT" and p["license-files"] == ["LICENSE"]
    text = (ROOT / "LICENSE").read_text(encoding="utf-8")
    assert text.startswith("MIT License\n") and re.search(r"^Copyright \(c\) \d{4} contin developers$", text, re.M)
    assert "THE SOFTWARE IS PROVIDED \"AS IS\", WITHOUT WARRANTY OF ANY KIND" in text
    # setuptools reads the licence as an SPDX expression from version 77 on
    assert pyproject()["build-system"]["requires"] == ["setuptools>=77"]


def test_urls_name_no_placeholder_hosts():
    """The project has no public home yet: no urls rather than invented ones; any added later are real https."""
    from urllib.parse import urlparse

    for label, url in project().get("urls", {}).items():
        host = urlparse(url).hostname or ""
        assert urlparse(url).scheme == "https" and "." in host, (label, url)
        assert not re.search(r"(^|\.)(example\.(com|org|net)|localhost|invalid|test)$", host), (label, url)


def test_every_subpackage_is_installed():
    found = {"contin." + ".".join(p.parent.relative_to(ROOT / "contin").parts) if p.parent != ROOT / "contin" else "contin"
             for p in (ROOT / "contin").rglob("__init__.py")}
    assert setuptools_config()["package-dir"] == SOURCES
    assert found | {"contin.models", "contin.scenes", "contin.scenes.data"} <= installed_packages()


def test_only_contin_is_installed_at_top_level():
    assert all(p == "contin" or p.startswith("contin.") for p in installed_packages())
    assert all(not p.endswith("__pycache__") for p in installed_packages())


def test_every_scene_and_data_file_is_package_data():
    patterns = setuptools_config()["package-data"]["contin.scenes"]
    files = [p.relative_to(ROOT / "scenes").as_posix() for p in (ROOT / "scenes").rglob("*")
             if p.is_file() and "__pycache__" not in p.parts and p.suffix not in (".py", ".pyc")]
    assert "rotor_fe_rig.yaml" in files and "data/rig_001.npz" in files
    missing = [f for f in files if not any(fnmatch.fnmatch(f, pat) for pat in patterns)]
    assert not missing, f"scenes/ files that would not ship: {missing}"


def test_builtin_models_import_through_the_package():
    import contin.models
    from contin.model.catalog import MODELS

    assert contin.models.__name__ == "contin.models"
    assert {"duffing", "mathieu"} <= set(MODELS)


def requirements(lines):
    """``{name: lower bound}`` of requirements ``name[extras]>=version``."""
    out = {}
    for line in lines:
        line = line.strip()
        if line:
            m = re.fullmatch(r"([A-Za-z0-9_.-]+)(\[[^\]]*\])?>=([0-9][0-9.]*)", line)
            assert m, f"a requirement without a lower bound: {line!r}"
            out[m.group(1).lower()] = m.group(3)
    return out


def test_dask_is_the_sweep_extra_not_a_dependency():
    p = project()
    install = requirements(p["dependencies"])
    assert "dask" not in install and "distributed" not in install
    assert requirements(p["optional-dependencies"]["sweep"]) == {"dask": "2024.1"}
    assert p["optional-dependencies"]["sweep"] == ["dask[distributed]>=2024.1"]


def test_the_extras_are_the_documented_ones():
    extras = project()["optional-dependencies"]
    assert set(extras) == {"ross", "sweep", "test", "docs"}
    assert requirements(extras["test"]) == {"pytest": "7", "pytest-xdist": "3.5", "hypothesis": "6", "dask": "2024.1",
                                            "pandas": "2.2"}
    assert requirements(extras["docs"]) == {"mkdocs": "1.5", "mkdocstrings": "0.24"}


def test_ross_is_an_extra_and_its_absence_is_told(monkeypatch):
    """ROSS (1.2 GB) is the `ross` extra, never a dependency; the bridge imports without it and says what to
    install when it is asked for."""
    p = project()
    assert "ross-rotordynamics" not in requirements(p["dependencies"])
    assert p["optional-dependencies"]["ross"] == ["ross-rotordynamics>=2.3", "plotly<6"]
    from contin.model.fem.ross_bridge import import_ross

    monkeypatch.setitem(sys.modules, "ross", None)
    with pytest.raises(ImportError, match=r"pip install 'contin\[ross\]'"):
        import_ross()


def test_lower_bounds_are_the_documented_ones():
    install = requirements(project()["dependencies"])
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
