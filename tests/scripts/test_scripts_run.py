"""Every script in scripts/ runs at its small (--quick) settings."""

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SCRIPTS = sorted(p.name for p in (ROOT / "scripts").glob("*.py"))


@pytest.mark.parametrize("name", SCRIPTS)
def test_script_runs_quick(name, tmp_path):
    r = subprocess.run([sys.executable, str(ROOT / "scripts" / name), "--quick"], capture_output=True, text=True,
                       cwd=tmp_path, timeout=600)
    assert r.returncode == 0, r.stderr[-2000:]
    assert r.stdout.strip(), "a script prints what it measured"
