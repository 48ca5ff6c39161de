"""``contin sweep``: an interrupted sweep resumes without recomputing, bad input, failed runs, exit codes."""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from conftest import no_hang
from contin.app.cli import main
from contin.output.results import read_csv

ROOT = Path(__file__).resolve().parents[3]
DUFFING = str(ROOT / "scenes/duffing.yaml")
# a few seconds per point: slow enough to interrupt the sweep in the middle
SLOW = ["--set", "analysis.harmonics=3", "--set", "output.plots=false",
        "--set", "analysis.continuation={ds: 0.08, ds_max: 0.08}"]
GRID = ["--grid", "model.parameters.F=0.3,0.5", "--grid", "model.parameters.c=0.1,0.2"]


def finished_points(outdir):
    """Point directories in place (finished runs), by name, with their point.json."""
    out = {}
    for d in (Path(outdir) / "points").glob("[!.]*"):
        try:
            out[d.name] = json.loads((d / "point.json").read_text())
        except (OSError, ValueError):
            pass
    return out


@pytest.mark.slow  # a killed worker's point is rerun in tests/test_sweep.py
def test_an_interrupted_sweep_reruns_only_the_unfinished_points(tmp_path, capsys, dask_cluster):
    out = tmp_path / "sweep"
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]))
    # the whole sweep (command, cluster and workers) killed at once, as by a crash
    proc = subprocess.Popen([sys.executable, "-m", "contin", "sweep", DUFFING, *GRID, *SLOW, "-o", str(out),
                             "--workers", "2", "-q"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            env=env, start_new_session=True)
    try:
        t0 = time.time()
        while not finished_points(out) and proc.poll() is None and time.time() - t0 < 180:
            time.sleep(0.05)
    finally:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
    done = finished_points(out)
    assert 1 <= len(done) < 4, f"the sweep was not caught in the middle ({len(done)} of 4 points finished)"
    assert all(r["status"] == "complete" for r in done.values())
    stamps = {n: (out / "points" / n / "summary.json").stat().st_mtime_ns for n in done}

    # rerun on a running two-worker cluster (the one the sweep tests share)
    with no_hang(300):
        code = main(["sweep", DUFFING, *GRID, *SLOW, "-o", str(out), "--scheduler", dask_cluster.scheduler_address,
                     "-q"])
    assert code == 0
    assert "4 complete" in capsys.readouterr().out
    after = finished_points(out)
    assert sorted(after) == ["F=0.3__c=0.1", "F=0.3__c=0.2", "F=0.5__c=0.1", "F=0.5__c=0.2"]
    assert all(r["status"] == "complete" for r in after.values())
    for n in done:  # the points finished before the interruption were not run again
        assert after[n]["finished_at"] == done[n]["finished_at"] and after[n]["worker"] == done[n]["worker"]
        assert (out / "points" / n / "summary.json").stat().st_mtime_ns == stamps[n]
    index = read_csv(out / "sweep.csv")
    reused = dict(zip(index["point"], index["reused"]))
    assert reused == {n: n in done for n in after}
    assert list(index["status"]) == ["complete"] * 4
    assert not list((out / "points").glob(".*"))  # the interrupted runs' temporary directories are gone
    assert (out / "sweep_map.png").stat().st_size > 5000
    # a third run has nothing to do
    with no_hang(120):
        assert main(["sweep", DUFFING, *GRID, *SLOW, "-o", str(out), "--serial", "-q"]) == 0
    assert "4 complete (4 from before)" in capsys.readouterr().out


@pytest.mark.parametrize("args,fragment", [
    (["--grid", "model.parameters.F"], "--grid: expected dotted.key=SPEC"),
    (["--grid", "model.parameters.F=0:1:1"], "--grid model.parameters.F: expected a range start:stop:count with a count"),
    (["--grid", "model.parameters.F=0.1,0.1"], "distinct values"),
    (["--grid", "model.parameters.FF=1,2"], "--grid model.parameters.FF: expected a parameter.*did you mean 'F'"),
    (["--grid", "analysis.harmonic=1,2"], "every point is refused.*did you mean 'harmonics'"),
    (["--grid", "model.parameters.F=1,2", "--set", "model.parameters.F=3"], "--set model.parameters.F"),
    (["--grid", "model.parameters.F=1,2", "--workers", "0"], "--workers"),
    (["--grid", "model.parameters.F=1,2", "--set", "analysis.harmonic=3"], "analysis.harmonic.*harmonics"),
])
def test_bad_input_exits_2_naming_the_option(args, fragment, tmp_path, capsys):
    import re

    assert main(["sweep", DUFFING, *args, "-o", str(tmp_path / "s"), "-q"]) == 2
    err = " ".join(capsys.readouterr().err.split())
    assert re.search(fragment, err), err


def test_a_failed_run_is_recorded_and_the_sweep_exits_1(tmp_path, capsys):
    # a start from a simulation stopped long before the motion settles does not converge (RunError); a
    # negative contact stiffness, which once served here, is bad input now (tests/cli/test_check_parity.py)
    out = tmp_path / "s"
    with no_hang(300):
        code = main(["sweep", str(ROOT / "scenes/rotor_harmonic.yaml"), "--grid",
                     "analysis.start_simulation.transient=0.01", "--set", "analysis.start_from=simulation",
                     "--set", "analysis.start_simulation.steps_per_period=2048",
                     "--set", "analysis.harmonics=10", "--set", "analysis.samples=256", "--set",
                     "analysis.crossings=none", "-o", str(out), "--serial", "-q", "--no-map"])
    assert code == 1
    printed = capsys.readouterr().out
    assert "1 failed" in printed and "no starting solution at w=1.6" in printed
    index = read_csv(out / "sweep.csv")
    assert list(index["status"]) == ["failed"] and "after 0.01 revolutions" in index["message"][0]
    [point] = list((out / "points").iterdir())
    summary = json.loads((point / "summary.json").read_text())
    assert summary["status"] == "failed" and "after 0.01 revolutions" in summary["message"]


# ---------------------------------------------------------------- Dask is optional; Ctrl-C says how to resume
def test_without_dask_the_sweep_says_what_to_install_and_writes_nothing(tmp_path, capsys, monkeypatch):
    monkeypatch.setitem(sys.modules, "distributed", None)  # `import distributed` raises ImportError
    out = tmp_path / "s"
    assert main(["sweep", DUFFING, "--grid", "model.parameters.F=0.3,0.5", "-o", str(out)]) == 2
    err = " ".join(capsys.readouterr().err.split())
    assert 'pip install "contin[sweep]"' in err and "--serial" in err and "not installed" in err
    assert not out.exists()


def test_a_serial_sweep_runs_without_dask(tmp_path, capsys, monkeypatch):
    for name in ("dask", "distributed"):
        monkeypatch.setitem(sys.modules, name, None)
    out = tmp_path / "s"
    with no_hang(120):
        assert main(["sweep", DUFFING, "--grid", "model.parameters.F=0.3", "--set", "output.plots=false",
                     "--set", "analysis.harmonics=3", "--set", "analysis.stability=none", "-o", str(out), "--serial",
                     "--no-map"]) == 0
    captured = capsys.readouterr()
    assert "1 complete" in captured.out
    assert captured.err.startswith(f"sweep of 1 points in {out}: 0 already complete, 1 to run (serial)")
    assert list(read_csv(out / "sweep.csv")["status"]) == ["complete"]


def test_an_interrupted_sweep_says_how_to_resume_it(tmp_path, capsys, monkeypatch):
    import contin.app.sweep_workers

    def ctrl_c(task):
        raise KeyboardInterrupt

    monkeypatch.setattr(contin.app.sweep_workers, "run_point", ctrl_c)  # Ctrl-C during the first point
    out = tmp_path / "the sweep"
    args = ["sweep", DUFFING, "--grid", "model.parameters.F=0:0.6:4", "--set", "output.plots=false", "-o", str(out),
            "--serial"]
    assert main(args) == 130
    command = f"contin sweep {DUFFING} --grid model.parameters.F=0:0.6:4 --set output.plots=false -o '{out}' --serial"
    err = capsys.readouterr().err
    assert "contin: the sweep was interrupted" in err and f"\n  {command}\n" in err
    meta = json.loads((out / "sweep.json").read_text())
    assert meta["status"] == "interrupted" and command in meta["message"]
    assert list(read_csv(out / "sweep.csv")["status"]) == ["pending"] * 4

