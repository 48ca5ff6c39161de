"""Every script under scripts/ runs at its small (--quick) settings (the benchmarks in the slow tier).

The scripts are grouped by purpose: ``scripts/bench/`` (``bench_*.py``, timings),
``scripts/figures/<system>/`` (the papers' figures and tables) and ``scripts/docs/``
(generators of documentation pages; with ``--quick`` they only check that the
committed page is current). They run in this process (``runpy``, ``sys.argv``
patched, in the test's temporary directory): each one's check is the same as
from a shell, it exits with status 0 (returns, or raises ``SystemExit`` with 0
or None) and prints what it measured, without paying a fresh interpreter and
the loading of the compiled kernels once per script.
"""

import os
import runpy
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SCRIPTS_DIR = ROOT / "scripts"
#: every script, as its path under scripts/ (``bench/bench_belt.py``)
SCRIPTS = sorted(p.relative_to(SCRIPTS_DIR).as_posix() for p in SCRIPTS_DIR.rglob("*.py"))


def test_scripts_are_grouped_by_purpose():
    """No loose script at the top of scripts/, the benchmarks in scripts/bench/ and nothing else there,
    and unique file names (a figure script may import a sibling, or a benchmark, by its name)."""
    assert SCRIPTS, "no script found under scripts/"
    assert all("/" in s for s in SCRIPTS), [s for s in SCRIPTS if "/" not in s]
    for s in SCRIPTS:
        assert (Path(s).name.startswith("bench_")) == s.startswith("bench/"), s
    names = [Path(s).name for s in SCRIPTS]
    assert len(names) == len(set(names)), sorted(n for n in names if names.count(n) > 1)


@pytest.fixture
def isolated(tmp_path, monkeypatch):
    """The temporary directory as the working directory; the environment, ``sys.path``, the modules
    imported from scripts/ and the figures restored afterwards."""
    monkeypatch.chdir(tmp_path)
    env = dict(os.environ)
    before = set(sys.modules)
    yield monkeypatch
    for name in set(sys.modules) - before:
        if (getattr(sys.modules[name], "__file__", None) or "").startswith(str(SCRIPTS_DIR)):
            del sys.modules[name]
    os.environ.clear()
    os.environ.update(env)
    if "matplotlib.pyplot" in sys.modules:
        sys.modules["matplotlib.pyplot"].close("all")


def _scripts(folder):
    """The scripts of one folder; the benchmarks (bench_*.py) in the slow tier: they time, the others
    reproduce the papers' figures."""
    out = [s for s in SCRIPTS if s.rsplit("/", 1)[0] == folder]
    return [pytest.param(s, marks=pytest.mark.slow) if Path(s).name.startswith("bench_") else s for s in out]


def run_quick(script, isolated, capsys):
    path = SCRIPTS_DIR / script
    isolated.syspath_prepend(str(path.parent))  # its sibling imports, as when run from a shell
    isolated.setattr(sys, "argv", [str(path), "--quick"])
    try:
        runpy.run_path(str(path), run_name="__main__")
    except SystemExit as exc:
        assert exc.code in (0, None), f"{script} --quick exited with {exc.code!r}"
    assert capsys.readouterr().out.strip(), "a script prints what it measured"


# one class per folder: the test workers (pytest-xdist, --dist loadscope) take the folders apart
class _Folder:
    folder = ""

    def test_script_runs_quick(self, script, isolated, capsys):
        run_quick(script, isolated, capsys)


def pytest_generate_tests(metafunc):
    if metafunc.cls is not None and issubclass(metafunc.cls, _Folder) and "script" in metafunc.fixturenames:
        metafunc.parametrize("script", _scripts(metafunc.cls.folder))


class TestBench(_Folder):
    folder = "bench"


class TestRotorFigures(_Folder):
    folder = "figures/rotor"


class TestBeltFigures(_Folder):
    folder = "figures/belt"


class TestAbsorberFigures(_Folder):
    folder = "figures/absorber"


class TestTwoDofFigures(_Folder):
    folder = "figures/two_dof"


class TestVanDerPolFigures(_Folder):
    folder = "figures/van_der_pol"


class TestDocsGenerators(_Folder):
    folder = "docs"


def test_every_folder_has_its_class():
    assert {c.folder for c in _Folder.__subclasses__()} == {s.rsplit("/", 1)[0] for s in SCRIPTS}
