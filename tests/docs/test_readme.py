"""The README: short, its two set-up commands first, the second one exactly what CI runs."""

import re
from pathlib import Path

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
