"""A run killed in the middle leaves parseable files, and --resume completes it."""

import json
import shlex
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from contin.app.cli import main
from contin.output.results import read_csv

ROOT = Path(__file__).resolve().parents[3]
SCENE = str(ROOT / "scenes/mathieu_duffing_pd.yaml")
SETS = ["--set", "analysis.continuation={ds: 0.002, ds_max: 0.004}", "--set", "analysis.harmonics=8"]


def rows_of(path):
    try:
        return max(0, sum(1 for _ in open(path)) - 1)
    except FileNotFoundError:
        return 0


def special_summary(outdir):
    sp = read_csv(outdir / "special_points.csv")
    return sorted((int(b), k, round(float(v), 7)) for b, k, v in zip(sp["branch"], sp["kind"], sp["delta"]))


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    out = tmp_path_factory.mktemp("ref")
    assert main(["run", SCENE, "-o", str(out), "-q", *SETS]) == 0
    return out


def assert_same_run(out, reference):
    """The rows (to 1e-9), the special points (with their row indices) and the branch ends of two runs agree."""
    ref, got = read_csv(reference / "branches.csv"), read_csv(out / "branches.csv")
    assert len(got["branch"]) == len(ref["branch"])
    for col, values in ref.items():
        if values.dtype.kind == "f":
            np.testing.assert_allclose(got[col], values, rtol=1e-9, atol=1e-12, err_msg=col)
        else:
            np.testing.assert_array_equal(got[col], values, err_msg=col)
    ref_sp, got_sp = read_csv(reference / "special_points.csv"), read_csv(out / "special_points.csv")
    assert list(got_sp["kind"]) == list(ref_sp["kind"])
    np.testing.assert_array_equal(got_sp["index"], ref_sp["index"])
    np.testing.assert_allclose(got_sp["delta"], ref_sp["delta"], rtol=1e-9, atol=1e-12)
    ends = [("branch", "nu", "points", "status", "message", "special_points", "parent", "rejected_steps", "newton")]

    def branches(path):
        summary = json.loads((path / "summary.json").read_text())
        return summary["status"], [{k: b[k] for k in ends[0]} for b in summary["analysis"]["branches"]]

    assert branches(out) == branches(reference)


# inside the first branch; inside a switched branch (slow: the whole reference run is redone)
@pytest.mark.parametrize("kill_at", [60, pytest.param(330, marks=pytest.mark.slow)])
def test_killed_run_resumes_to_the_same_result(tmp_path, reference, kill_at):
    out = tmp_path / "run"
    proc = subprocess.Popen([sys.executable, "-m", "contin", "run", SCENE, "-o", str(out), "-q", *SETS],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    t0 = time.time()
    while rows_of(out / "branches.csv") < kill_at and proc.poll() is None and time.time() - t0 < 120:
        time.sleep(0.01)
    assert proc.poll() is None, "the run finished before it could be killed"
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    # the files of the killed run parse, hold only finished points, and say the run did not complete
    rows = read_csv(out / "branches.csv")
    assert len(rows["delta"]) >= kill_at - 1 and np.all(np.isfinite(rows["delta"]))
    assert json.loads((out / "summary.json").read_text())["status"] == "running"
    assert main(["run", SCENE, "-o", str(out), "-q", "--resume", *SETS]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "complete" and summary["resumed"] is not None
    # the same run as the uninterrupted one (before: the step size and the loop history were lost,
    # the special points' row indices were off and the summary counted the resumed part only)
    assert_same_run(out, reference)


def test_resume_refuses_a_different_scene(tmp_path, reference):
    import shutil

    out = tmp_path / "copy"
    shutil.copytree(reference, out)
    summary = json.loads((out / "summary.json").read_text())
    summary["status"] = "running"
    (out / "summary.json").write_text(json.dumps(summary))
    assert main(["run", SCENE, "-o", str(out), "-q", "--resume", "--set", "analysis.harmonics=7"]) == 2


@pytest.mark.slow  # 14 s; in the default tier the handler's path runs in-process (the two ctrl-c tests below)
def test_ctrl_c_stops_cleanly_with_what_was_computed(tmp_path, reference):
    out = tmp_path / "int"
    proc = subprocess.Popen([sys.executable, "-m", "contin", "run", SCENE, "-o", str(out), *SETS],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    t0 = time.time()
    while rows_of(out / "branches.csv") < 50 and proc.poll() is None and time.time() - t0 < 120:
        time.sleep(0.01)
    proc.send_signal(signal.SIGINT)
    stdout, stderr = proc.communicate(timeout=120)
    assert proc.returncode == 130, stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "interrupted"
    assert any(b["status"] == "interrupted" for b in summary["analysis"]["branches"])
    rows = read_csv(out / "branches.csv")
    assert len(rows["delta"]) >= 50 and (out / "bifurcation_diagram.png").exists()
    assert "Traceback" not in stderr
    # the message says how to go on: the command that resumes the run, on stderr and in summary.json
    command = shlex.join(["contin", "run", SCENE, "-o", str(out), "--resume", *SETS])
    assert f"\n  {command}\n" in stderr and summary["message"].endswith(command)
    assert "stopped by the callback" not in stdout and "points, interrupted at delta=" in stdout
    # and the interrupted run can be resumed, to the uninterrupted run
    assert main(["run", SCENE, "-o", str(out), "-q", "--resume", *SETS]) == 0
    assert_same_run(out, reference)


def test_plot_command_draws_a_stored_point(tmp_path, reference):
    assert main(["plot", str(reference), "--point", "300"]) == 0
    assert (reference / "point_300.png").stat().st_size > 10_000
    assert main(["plot", str(reference), "--point", "100000"]) == 2


def test_progress_line_appears_only_for_long_runs():
    import io

    from contin.app.progress import Progress

    buf = io.StringIO()
    p = Progress(stream=buf, delay=0.0, interval=0.0)
    p.update("branch 0  w=1.5  point 3")
    p.close()
    assert "w=1.5" in buf.getvalue()
    quiet = io.StringIO()
    q = Progress(stream=quiet, delay=10.0)
    q.update("never shown")
    q.close()
    assert quiet.getvalue() == ""


DUFFING = str(ROOT / "scenes/duffing.yaml")
QUICK = ["--set", "output.plots=false", "--set", "analysis.harmonics=3", "--set", "analysis.stability=none"]


def test_ctrl_c_in_the_middle_of_a_run_prints_the_command_that_resumes_it(tmp_path, capsys, monkeypatch):
    from contin.app.progress import Progress

    update, calls = Progress.update, []

    def ctrl_c_at_the_fifth_point(self, text, **kwargs):
        calls.append(text)
        if len(calls) == 5:
            signal.raise_signal(signal.SIGINT)  # the runner's handler sets the stop flag
        update(self, text, **kwargs)

    monkeypatch.setattr(Progress, "update", ctrl_c_at_the_fifth_point)
    out = tmp_path / "run dir"
    assert main(["run", DUFFING, "-o", str(out), "-q", *QUICK]) == 130
    captured = capsys.readouterr()
    command = f"contin run {DUFFING} -o '{out}' --resume " + " ".join(QUICK)
    assert captured.err.endswith(f"To resume it from the last stored point:\n  {command}\n")
    assert "branch 0 (nu=1): 5 points, interrupted at w=" in captured.out
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "interrupted" and summary["message"].endswith(command)
    # the command does resume it
    monkeypatch.setattr(Progress, "update", update)
    assert main(shlex.split(command)[1:] + ["-q"]) == 0
    assert json.loads((out / "summary.json").read_text())["status"] == "complete"


def test_a_second_ctrl_c_still_says_how_to_resume(tmp_path, capsys, monkeypatch):
    from contin.app.progress import Progress

    update, calls = Progress.update, []

    def escapes_at_the_fifth_point(self, text, **kwargs):
        calls.append(text)
        if len(calls) == 5:
            raise KeyboardInterrupt  # a Ctrl-C that escapes the analysis (a second one, or outside it)
        update(self, text, **kwargs)

    monkeypatch.setattr(Progress, "update", escapes_at_the_fifth_point)
    out = tmp_path / "run"
    assert main(["run", DUFFING, "-o", str(out), "-q", *QUICK]) == 130
    command = f"contin run {DUFFING} -o {out} --resume " + " ".join(QUICK)
    assert f"\n  {command}\n" in capsys.readouterr().err
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "interrupted" and summary["message"].endswith(command)



@pytest.mark.slow
@pytest.mark.parametrize("name, torus", [("van_der_pol", "{harmonics: 8, harmonics2: 8, stability: none}"),
                                         ("van_der_pol_circle", "{points: 11}")])
def test_killed_run_inside_a_torus_branch_resumes_to_the_same_result(tmp_path, name, torus):
    """Killed while a quasi-periodic branch is traced (a two-frequency balance, or an invariant circle with its
    Lyapunov exponents): the resumed run takes that branch up from its last point (not anew) and ends as the
    uninterrupted run does."""
    scene = str(ROOT / f"scenes/{name}.yaml")
    sets = ["--set", f"analysis.torus={torus}"]
    ref = tmp_path / "ref"
    assert main(["run", scene, "-o", str(ref), "-q", *sets]) == 0
    first_torus_row = int(np.flatnonzero(read_csv(ref / "branches.csv")["branch"] == 1)[0])
    out = tmp_path / "run"
    proc = subprocess.Popen([sys.executable, "-m", "contin", "run", scene, "-o", str(out), "-q", *sets],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    t0 = time.time()
    while rows_of(out / "branches.csv") < first_torus_row + 8 and proc.poll() is None and time.time() - t0 < 120:
        time.sleep(0.005)
    assert proc.poll() is None, "the run finished before it could be killed"
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    assert main(["run", scene, "-o", str(out), "-q", "--resume", *sets]) == 0
    a, b = read_csv(ref / "branches.csv"), read_csv(out / "branches.csv")
    assert len(a["branch"]) == len(b["branch"])
    for col in ("w", "frequency2", "free_x", "amp_x", "max_multiplier"):
        np.testing.assert_allclose(b[col], a[col], rtol=1e-9, atol=1e-12, err_msg=col, equal_nan=True)
    summary = [json.loads((p / "summary.json").read_text())["analysis"]["branches"] for p in (ref, out)]
    assert [(s["status"], s["points"], s["torus"]) for s in summary[0]] == \
        [(s["status"], s["points"], s["torus"]) for s in summary[1]]
