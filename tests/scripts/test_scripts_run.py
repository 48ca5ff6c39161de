"""Every script in scripts/ runs at its small (--quick) settings (the benchmarks in the slow tier).

The scripts run in this process (``runpy``, ``sys.argv`` patched, in the test's
temporary directory): each one's check is the same as from a shell, it exits
with status 0 (returns, or raises ``SystemExit`` with 0 or None) and prints
what it measured, without paying a fresh interpreter and the loading of the
compiled kernels once per script.
"""

import os
import runpy
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SCRIPTS = sorted(p.name for p in (ROOT / "scripts").glob("*.py"))


@pytest.fixture
def isolated(tmp_path, monkeypatch):
    """The script's own directory on ``sys.path`` (its sibling imports), the temporary directory as the
    working directory, and the environment, the modules imported from scripts/ and the figures restored."""
    scripts = str(ROOT / "scripts")
    monkeypatch.chdir(tmp_path)
    monkeypatch.syspath_prepend(scripts)
    env = dict(os.environ)
    before = set(sys.modules)
    yield
    for name in set(sys.modules) - before:
        if (getattr(sys.modules[name], "__file__", None) or "").startswith(scripts):
            del sys.modules[name]
    os.environ.clear()
    os.environ.update(env)
    if "matplotlib.pyplot" in sys.modules:
        sys.modules["matplotlib.pyplot"].close("all")


# the benchmarks (bench_*.py) in the slow tier: they time, the others reproduce the papers' figures
@pytest.mark.parametrize("name", [pytest.param(n, marks=pytest.mark.slow) if n.startswith("bench_") else n
                                  for n in SCRIPTS])
def test_script_runs_quick(name, isolated, monkeypatch, capsys):
    path = str(ROOT / "scripts" / name)
    monkeypatch.setattr(sys, "argv", [path, "--quick"])
    try:
        runpy.run_path(path, run_name="__main__")
    except SystemExit as exc:
        assert exc.code in (0, None), f"{name} --quick exited with {exc.code!r}"
    assert capsys.readouterr().out.strip(), "a script prints what it measured"
