"""What the command says besides results: warnings as one line each, a closed pipe, the help of `run`."""

import os
import subprocess
import sys

import pytest

from contin.app.cli import EXIT_PIPE_CLOSED, main


def test_a_closed_pipe_ends_the_command_quietly():
    # before: `contin models | head` said "contin: error: Broken pipe" with exit status 2, which means bad input
    r, w = os.pipe()
    os.close(r)  # the reader is gone before contin writes a byte
    try:
        done = subprocess.run([sys.executable, "-m", "contin", "models"], stdout=w, stderr=subprocess.PIPE,
                              text=True, timeout=120)
    finally:
        os.close(w)
    assert (done.returncode, done.stderr) == (EXIT_PIPE_CLOSED, "") and EXIT_PIPE_CLOSED == 128 + 13


#: the command with warnings of two kinds, one of them given twice, and one from another library
WARNING_SCRIPT = """
import sys, warnings
import contin.app.cli as cli
from contin import ContinWarning

def models():
    for _ in range(2):
        warnings.warn("Hill's multipliers disagreed with the monodromy's at 3 of the branch's 9 points\\n"
                      "(w in [0.5, 0.6])", ContinWarning)
    warnings.warn("contin: not caching compiled kernels in /x: not private", ContinWarning)
    warnings.warn("overflow encountered", RuntimeWarning)
    print("listed")
    return 0

cli.cmd_models = models
sys.exit(cli.main(["models"]))
"""


def test_warnings_are_one_line_each_without_a_source_line():
    # before: Python's display, "monitor.py:141: RuntimeWarning: ..." followed by the source line of the call
    done = subprocess.run([sys.executable, "-c", WARNING_SCRIPT], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0 and done.stdout == "listed\n"
    assert done.stderr.splitlines() == [
        "contin: warning: Hill's multipliers disagreed with the monodromy's at 3 of the branch's 9 points "
        "(w in [0.5, 0.6])",
        "contin: warning: not caching compiled kernels in /x: not private",
        "contin: warning: RuntimeWarning: overflow encountered",
    ]


def test_warnings_recorded_by_the_caller_stay_recorded():
    import warnings

    from contin import ContinWarning
    import contin.app.cli as cli

    def models():
        warnings.warn("a caveat", ContinWarning)
        return 0

    original = cli.cmd_models
    cli.cmd_models = models
    try:
        with pytest.warns(ContinWarning, match="a caveat"):
            assert main(["models"]) == 0
    finally:
        cli.cmd_models = original
    assert warnings.showwarning is warnings._showwarning_orig


def test_run_help_has_an_example_and_the_exit_codes(capsys):
    # before: neither (`contin sweep --help` had both)
    with pytest.raises(SystemExit) as done:
        main(["run", "--help"])
    assert done.value.code == 0
    text = capsys.readouterr().out
    assert "examples:\n  contin run duffing -o results/duffing" in text
    assert "--set analysis.harmonics=15" in text
    for code in ("0 ", "1 ", "2 ", "130 ", "141 "):
        assert f"\n  {code}" in text, code
