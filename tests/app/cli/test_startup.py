"""``contin --help`` and ``contin models`` answer without the machinery of a run (the CLI's deferred imports)."""

import subprocess
import sys

#: run one command in a fresh interpreter; print the top-level packages and contin modules it loaded
PROBE = """
import contextlib, io, sys
from contin.app.cli import main
with contextlib.redirect_stdout(io.StringIO()):
    try:
        main({args!r})
    except SystemExit as exc:
        assert exc.code == 0, exc.code
print(sorted({{m.split(".")[0] for m in sys.modules}} | {{m for m in sys.modules if m.startswith("contin.")}}))
"""


def _loaded(args):
    out = subprocess.run([sys.executable, "-c", PROBE.format(args=args)], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    return set(eval(out.stdout))


def test_help_loads_no_numpy():
    loaded = _loaded(["--help"])
    assert not loaded & {"numpy", "scipy", "numba", "matplotlib", "yaml"}, loaded
    assert "contin.app.cli" in loaded


def test_models_loads_no_scene_engine_or_figures():
    # before: the command's error handling imported contin.scene.parse (the figures, the engine: 1 s)
    loaded = _loaded(["models"])
    assert "contin.model.catalog" in loaded
    assert not loaded & {"matplotlib", "contin.scene.parse", "contin.output.outcome", "contin.engine.state",
                         "contin.hb.problem"}, loaded
