"""The README: short, its two set-up commands first, the second one exactly what CI runs."""

import os
import re
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
README = ROOT / "README.md"
#: the README is a front page: what contin is, how to start, where to read on
MAX_LINES = 200


def setup_commands() -> list[str]:
    """The ``$`` lines of the README's first fenced block."""
    block = re.search(r"```console[^\n]*\n(.*?)```", README.read_text(encoding="utf-8"), re.S)
    assert block, "the README opens with a console block of its set-up commands"
    return [line[2:] for line in block.group(1).splitlines() if line.startswith("$ ")]


def test_the_readme_is_short():
    n = len(README.read_text(encoding="utf-8").splitlines())
    assert n <= MAX_LINES, f"README.md has {n} lines; the details belong in docs/"


def test_two_commands_install_and_run_the_main_job_then_the_tests():
    first, second = setup_commands()
    assert "install" in first and "contin run scenes/rotor_f0_05.yaml" in first
    assert "install" in second and ".[test]" in second and second.endswith("python -m pytest -q")


def test_ci_runs_the_readmes_test_command_verbatim():
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8").splitlines()
    assert setup_commands()[1] in [line.strip() for line in ci], ".ci/run must run the README's second command"


SHIM = """#!/usr/bin/env bash
echo "$*" >> "$CALLS"
case "$*" in
  *"pip install"*) exit "$PIP" ;;
  *"-m slow"*) exit "$SLOW" ;;
  *) exit "$DEFAULT" ;;
esac
"""


@pytest.mark.parametrize("pip, default, slow, status", [(0, 0, 0, 0), (0, 1, 0, 1), (0, 0, 1, 1), (0, 5, 0, 5),
                                                        (1, 0, 0, 1), (0, 2, 1, 2)])
def test_ci_runs_the_slow_tier_after_the_readmes_command_and_fails_if_either_fails(tmp_path, pip, default, slow,
                                                                                  status):
    # .ci/run in a copy of the tree's layout, with a stand-in for python that records its calls
    (tmp_path / ".ci").mkdir()
    shutil.copy(ROOT / ".ci" / "run", tmp_path / ".ci" / "run")
    bindir = tmp_path / "bin"
    bindir.mkdir()
    (bindir / "python").write_text(SHIM)
    (bindir / "python").chmod(0o755)
    calls = tmp_path / "calls"
    env = {**os.environ, "PATH": f"{bindir}{os.pathsep}{os.environ['PATH']}", "CALLS": str(calls), "PIP": str(pip),
           "DEFAULT": str(default), "SLOW": str(slow)}
    proc = subprocess.run(["bash", str(tmp_path / ".ci" / "run")], env=env, capture_output=True, text=True,
                          timeout=60, check=False)
    assert proc.returncode == status, proc.stdout + proc.stderr
    want = ['-m pip install -e .[test]'] + (['-m pytest -q'] if pip == 0 else []) + ['-m pytest -q -m slow and not longest']
    assert calls.read_text().splitlines() == want  # the slow tier runs even after a failure, to report both
    lines = proc.stdout.splitlines()
    assert lines[-1] == "CI: passed, both tiers" if status == 0 else lines[-1].startswith("CI: failed")
