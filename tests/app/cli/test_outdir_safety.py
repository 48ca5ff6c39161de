"""Runs that harm nothing: one writer per output directory, no writes through links or onto a user's files,
a resume only with the files the run read, SIGTERM and SIGHUP as Ctrl-C, write errors that name their file.

Each test here failed before these guarantees were made (issue 32): two runs interleaved their rows, a planted
link was written through, a user's files were replaced, a changed rotor file was resumed with, SIGTERM left
``running``, a full disk exited 2 without naming the file, a device named by ``--json`` was replaced.
"""

import errno
import json
import os
import shlex
import shutil
import signal
import stat
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from conftest import no_hang
from contin.app.cli import main
from contin.output.results import read_csv

ROOT = Path(__file__).resolve().parents[3]
DUFFING = str(ROOT / "scenes/duffing.yaml")
#: a run of a second or so in a fresh process, of half a second in this one
SHORT = ["--set", "analysis.range=[0.5, 1.0]", "--set", "analysis.harmonics=3", "--set", "output.plots=false"]
#: the cheapest run: 16 points, no stability, no figures
CHEAP = ["-q", "--set", "analysis.harmonics=1", "--set", "output.plots=false", "--set", "analysis.stability=none",
         "--set", "analysis.range=[0.5, 1.5]"]


def run(argv, capsys):
    code = main(argv)
    err = capsys.readouterr().err
    assert "Traceback" not in err
    return code, " ".join(err.split())  # one line (messages are wrapped at 100 columns)


def same_table(a: Path, b: Path, name: str):
    ta, tb = read_csv(a / name), read_csv(b / name)
    assert list(ta) == list(tb) and len(ta["branch"]) == len(tb["branch"])
    for col, values in ta.items():
        if values.dtype.kind == "f":
            np.testing.assert_allclose(tb[col], values, rtol=1e-10, atol=1e-13, err_msg=f"{name}: {col}")
        else:
            np.testing.assert_array_equal(tb[col], values, err_msg=f"{name}: {col}")


# ---------------------------------------------------------------- one writer at a time
def test_a_second_run_into_a_directory_being_written_is_refused_naming_the_holder(tmp_path, capsys):
    """Two runs into one directory: the second is refused (exit 2, the first's pid and command named) and
    the first's tables are those of a run alone. The first is paused in the middle of its branch, so that
    the two certainly overlap."""
    out = tmp_path / "shared"
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]))
    first = subprocess.Popen([sys.executable, "-m", "contin", "run", DUFFING, "-o", str(out), "-q", *SHORT],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    lock = out / ".contin.lock"
    try:
        t0 = time.time()
        while first.poll() is None and time.time() - t0 < 120:
            if (out / "branches.csv").is_file() and len((out / "branches.csv").read_text().splitlines()) > 3:
                first.send_signal(signal.SIGSTOP)  # three points stored: it runs
                break
            time.sleep(0.002)
        assert first.poll() is None, "the first run ended before the second could start"
        code, err = run(["run", DUFFING, "-o", str(out), "-q", *SHORT], capsys)
    finally:
        first.send_signal(signal.SIGCONT)
    stdout, stderr = first.communicate(timeout=120)
    assert code == 2 and f"process {first.pid}" in err and "contin run" in err and "running since" in err, err
    assert "no other contin process is writing" in err
    assert first.returncode == 0, stderr
    alone = tmp_path / "alone"
    assert main(["run", DUFFING, "-o", str(alone), "-q", *SHORT]) == 0
    for name in ("branches.csv", "special_points.csv"):
        same_table(alone, out, name)
    assert json.loads((out / "summary.json").read_text())["status"] == "complete"
    assert lock.read_text() == ""  # released: no holder


def test_a_sweep_into_a_locked_directory_is_refused(tmp_path, capsys):
    from contin.app.outdir import OutdirLock

    out = tmp_path / "sweep"
    out.mkdir()
    with OutdirLock(out):  # this process stands for a run writing there
        code, err = run(["sweep", DUFFING, "--grid", "model.parameters.F=0.3,0.5", "-o", str(out), "--serial",
                         *CHEAP], capsys)
    assert code == 2 and f"process {os.getpid()}" in err and "-o/--outdir" in err
    assert sorted(p.name for p in out.iterdir()) == [".contin.lock", "points"]


def test_a_sweep_into_a_directory_of_the_users_own_files_is_refused(tmp_path, capsys):
    out = tmp_path / "mine"
    out.mkdir()
    (out / "sweep.csv").write_text("my own index\n")
    code, err = run(["sweep", DUFFING, "--grid", "model.parameters.F=0.3,0.5", "-o", str(out), "--serial",
                     *CHEAP], capsys)
    assert code == 2 and "-o/--outdir" in err and "--force" in err
    assert [p.name for p in out.iterdir()] == ["sweep.csv"] and (out / "sweep.csv").read_text() == "my own index\n"


# ---------------------------------------------------------------- what is not contin's
def test_a_directory_of_the_users_own_files_is_refused_without_force(tmp_path, capsys):
    out = tmp_path / "mine"
    out.mkdir()
    (out / "branches.csv").write_text("my own table\n")
    (out / "notes.txt").write_text("keep\n")
    code, err = run(["run", DUFFING, "-o", str(out), *CHEAP], capsys)
    assert code == 2 and "-o" in err and "--force" in err and "branches.csv" in err
    assert sorted(p.name for p in out.iterdir()) == ["branches.csv", "notes.txt"]  # nothing written
    assert (out / "branches.csv").read_text() == "my own table\n"
    # --force: the user says so; contin's names are replaced, the rest is left alone
    code, err = run(["run", DUFFING, "-o", str(out), *CHEAP, "--force"], capsys)
    assert code == 0, err
    assert read_csv(out / "branches.csv")["w"][0] == pytest.approx(0.5)
    assert (out / "notes.txt").read_text() == "keep\n"


def test_a_planted_link_in_the_output_directory_is_refused_and_not_written_through(tmp_path, capsys):
    outside = tmp_path / "outside.txt"
    outside.write_text("not contin's\n")
    out = tmp_path / "run"
    out.mkdir()
    (out / ".contin.lock").write_text("")  # a directory contin wrote before
    (out / "branches.csv").symlink_to(outside)
    for extra in ([], ["--force"]):  # --force never makes contin write through a link
        code, err = run(["run", DUFFING, "-o", str(out), *CHEAP, *extra], capsys)
        assert code == 2 and "branches.csv" in err and "symbolic link" in err, err
        assert outside.read_text() == "not contin's\n"
        assert (out / "branches.csv").is_symlink()


def test_an_empty_output_name_is_bad_input(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)  # (where the results of -o '' went)
    code, err = run(["run", DUFFING, "-o", "", *CHEAP], capsys)
    assert code == 2 and "-o: expected a directory name for the results" in err
    code, err = run(["sweep", DUFFING, "--grid", "model.parameters.F=0.3,0.5", "-o", "", "--serial", *CHEAP], capsys)
    assert code == 2 and "-o/--outdir: expected a directory name" in err
    assert list(tmp_path.iterdir()) == []


# ---------------------------------------------------------------- resume checks what the scene reads
@pytest.fixture
def rotor_scene(tmp_path):
    """A short finite-element rotor run (10 points) from a copy of the shipped .npz rotor."""
    shutil.copy(ROOT / "scenes" / "data" / "rig_001.npz", tmp_path / "rig.npz")
    path = tmp_path / "fe.yaml"
    path.write_text("""model:
  from: ross
  file: rig.npz
  reduction: {modes: 6}
  contact: {node: 18, clearance: 1.0e-4, stiffness: 6.2e8, damping: 316}
  unbalance: [{node: 11, magnitude: 3.9e-3}]
  side_load: {node: 11, force: [0, 24.1]}
analysis: {type: frequency_response, parameter: w, range: [1.6, 1.604], start: 1.6, harmonics: 20, samples: 512,
           crossings: interval, stability: none}
output: {plots: false}
""")
    return path


def test_resume_after_the_rotor_file_changed_is_refused_naming_it(rotor_scene, tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["run", str(rotor_scene), "-o", str(out), "-q"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    npz = str((tmp_path / "rig.npz").resolve())
    summary["status"] = "interrupted"  # as a run killed at its end
    (out / "summary.json").write_text(json.dumps(summary))
    with np.load(tmp_path / "rig.npz") as z:
        arrays = {k: z[k] for k in z.files}
    arrays["damping"] = 3 * arrays["damping"]
    np.savez(tmp_path / "rig.npz", **arrays)
    rows = (out / "branches.csv").read_text()
    code, err = run(["run", str(rotor_scene), "-o", str(out), "-q", "--resume"], capsys)
    assert code == 2 and "--resume" in err and f"changed since it ran: {npz}" in err, err
    assert (out / "branches.csv").read_text() == rows
    # what the run read, by content, and what it built
    assert set(summary["inputs"]) == {str(rotor_scene.resolve()), npz} and len(summary["fingerprint"]) == 64


def test_a_model_built_differently_is_refused_by_its_fingerprint():
    from contin.app.run_inputs import check_same_inputs
    from contin.scene.parse import SceneError

    old = {"inputs": {"/a/scene.yaml": "0" * 64}, "fingerprint": "1" * 64}
    check_same_inputs(old, {"/a/scene.yaml": "0" * 64}, "1" * 64, "out")  # the same: accepted
    check_same_inputs({}, {}, "2" * 64, "out")  # a run that recorded neither: nothing to compare
    with pytest.raises(SceneError, match=r"--resume: expected the model of the run in out, found 'a model built "
                                         r"differently' \(its parameters, terms or matrices differ"):
        check_same_inputs(old, {"/a/scene.yaml": "0" * 64}, "2" * 64, "out")
    with pytest.raises(SceneError, match=r"changed since it ran: /a/scene.yaml\. Resume with the files"):
        check_same_inputs(old, {"/a/scene.yaml": "3" * 64}, "1" * 64, "out")


# ---------------------------------------------------------------- signals, write errors
@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGHUP], ids=["SIGTERM", "SIGHUP"])
def test_sigterm_and_sighup_stop_a_run_as_ctrl_c_does(signum, tmp_path, capsys, monkeypatch):
    from contin.app.progress import Progress

    update, calls = Progress.update, []

    def signal_at_the_fifth_point(self, text, **kwargs):
        calls.append(text)
        if len(calls) == 5:
            signal.raise_signal(signum)
        update(self, text, **kwargs)

    def not_handled(sig, frame):  # what the default action would have done: kill the process
        raise RuntimeError(f"signal {sig} reached no handler of the run")

    monkeypatch.setattr(Progress, "update", signal_at_the_fifth_point)
    previous = signal.signal(signum, not_handled)
    try:
        out = tmp_path / "run"
        code = main(["run", DUFFING, "-o", str(out), *CHEAP])
    finally:
        assert signal.getsignal(signum) is not_handled  # the run put the handler back
        signal.signal(signum, previous)
    err = capsys.readouterr().err
    command = shlex.join(["contin", "run", DUFFING, "-o", str(out), "--resume", *CHEAP[1:]])
    assert code == 130 and err.endswith(f"To resume it from the last stored point:\n  {command}\n")
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "interrupted" and summary["message"].endswith(command)
    assert signal.Signals(signum).name in summary["message"]
    assert len(read_csv(out / "branches.csv")["w"]) == 5


def test_a_full_disk_exits_1_naming_the_file_and_the_resume_command(tmp_path, capsys, monkeypatch):
    """ENOSPC when branches.csv is flushed to disk at the end of its branch (as a full disk reports it): exit 1,
    the file and the command that resumes the run named; once there is room, that command completes the run."""
    real_fsync = os.fsync

    def fsync(fd):
        if os.readlink(f"/proc/self/fd/{fd}").endswith("branches.csv"):
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))  # a write error names no file by itself
        real_fsync(fd)

    if not Path("/proc/self/fd").is_dir():
        pytest.skip("needs /proc/self/fd to tell the files apart")
    monkeypatch.setattr(os, "fsync", fsync)
    out = tmp_path / "run"
    code, err = run(["run", DUFFING, "-o", str(out), *CHEAP], capsys)
    command = shlex.join(["contin", "run", DUFFING, "-o", str(out), "--resume", *CHEAP[1:]])
    assert code == 1, err
    assert f"could not write {out / 'branches.csv'}: No space left on device" in err and command in err
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "failed" and "branches.csv: No space left on device" in summary["message"]
    monkeypatch.setattr(os, "fsync", real_fsync)
    assert main(shlex.split(command)[1:]) == 0
    assert len(read_csv(out / "branches.csv")["w"]) == sum(
        b["points"] for b in json.loads((out / "summary.json").read_text())["analysis"]["branches"])


@pytest.fixture
def device(tmp_path):
    """``make(name, minor)``: a character device of the memory driver in tmp_path (3: null, 7: full)."""
    def make(name, minor):
        path = tmp_path / name
        try:
            os.mknod(path, stat.S_IFCHR | 0o666, os.makedev(1, minor))
            with open(path, "wb"):
                pass
        except OSError as exc:  # pragma: no cover  (not root, or a container without devices)
            pytest.skip(f"cannot make a device node here: {exc}")
        return path
    return make


def test_absorber_writes_a_device_it_is_given_in_place(device, capsys):
    null, full = device("null", 3), device("full", 7)
    args = ["absorber", "--m1", "100", "--k1", "5e5", "--m2", "10"]
    code, err = run([*args, "--json", str(null), "--plot", str(null)], capsys)
    assert code == 0, err
    code, err = run([*args, "--json", str(full)], capsys)
    assert code == 1 and f"{full}: No space left on device" in err
    for path in (null, full):
        assert stat.S_ISCHR(os.lstat(path).st_mode), f"{path} was replaced"
    assert sorted(p.name for p in null.parent.iterdir()) == ["full", "null"]  # no temporary file left


# ---------------------------------------------------------------- strict JSON, a step that never ends
@pytest.fixture
def unfinished(tmp_path):
    out = tmp_path / "run"
    assert main(["run", DUFFING, "-o", str(out), *CHEAP]) == 0
    summary = json.loads((out / "summary.json").read_text())
    summary["status"] = "interrupted"
    (out / "summary.json").write_text(json.dumps(summary))
    return out


def strict(text: str):
    def refuse(token):
        raise ValueError(f"{token} is not JSON")
    return json.loads(text, parse_constant=refuse)


def engine_states(outdir: Path) -> dict:
    """The engine states held in state_last.npz, as the text of their JSON, by key."""
    with np.load(outdir / "state_last.npz") as z:
        return {k: z[k].tobytes().decode("utf-8") for k in z.files if z[k].dtype == np.uint8}


def edit_last_engine_state(outdir: Path, edit) -> None:
    """Cut state.jsonl after its last engine line and replace that line's state by ``edit(its JSON text)``."""
    from contin.output.state_store import last_key

    path = outdir / "state.jsonl"
    lines = path.read_text().splitlines()
    last = max(i for i, line in enumerate(lines) if line.startswith('{"type": "engine"'))
    rec = json.loads(lines[last])
    with np.load(outdir / "state_last.npz") as z:
        arrays = {k: z[k] for k in z.files}
    blob = np.frombuffer(edit(arrays[rec["state"]["__last__"]].tobytes().decode("utf-8")).encode("utf-8"),
                         dtype=np.uint8)
    arrays[last_key(blob)] = blob
    rec["state"]["__last__"] = last_key(blob)
    lines[last] = json.dumps(rec)
    path.write_text("\n".join(lines[:last + 1]) + "\n")
    np.savez(outdir / "state_last.npz", **arrays)


def test_state_and_summary_are_strict_json(unfinished):
    lines = (unfinished / "state.jsonl").read_text().splitlines()
    records = [strict(line) for line in lines]
    states = engine_states(unfinished)
    assert len(states) == 2  # the last two engine records' states
    for text in states.values():
        strict(text)
    assert any('"__float__": "inf"' in text for text in states.values())  # the engine's event cap: none ahead
    strict((unfinished / "summary.json").read_text())
    assert len(records) > 16


@pytest.mark.parametrize("ds, fragment", [
    ("Infinity", "found the token Infinity"),
    ("NaN", "found the token NaN"),
    ("1e400", "ds = inf"),  # read as infinity by JSON parsers
    ('{"__float__": "inf"}', "ds = inf"),
    ("0.0", "ds = 0.0"),
    ("-0.01", "ds = -0.01"),
    ('"fast"', "ds = 'fast'"),
])
def test_a_resume_state_with_a_step_that_is_not_positive_and_finite_is_refused(unfinished, capsys, ds, fragment):
    edit_last_engine_state(unfinished, lambda text: json.dumps(dict(json.loads(text), ds="@DS@"))
                           .replace('"@DS@"', ds))
    with no_hang(60):  # a step of inf made the resumed run hang
        code, err = run(["run", DUFFING, "-o", str(unfinished), *CHEAP, "--resume"], capsys)
    assert code == 2 and "state.jsonl" in err and fragment in err, err


def test_a_run_started_to_ignore_sighup_keeps_ignoring_it(tmp_path, monkeypatch):
    """``nohup contin run ...``: a closed terminal does not stop the run."""
    from contin.app.progress import Progress

    update, calls = Progress.update, []

    def hang_up_at_the_fifth_point(self, text, **kwargs):
        calls.append(text)
        if len(calls) == 5:
            signal.raise_signal(signal.SIGHUP)
        update(self, text, **kwargs)

    monkeypatch.setattr(Progress, "update", hang_up_at_the_fifth_point)
    previous = signal.signal(signal.SIGHUP, signal.SIG_IGN)
    try:
        assert main(["run", DUFFING, "-o", str(tmp_path / "run"), *CHEAP]) == 0
        assert signal.getsignal(signal.SIGHUP) is signal.SIG_IGN
    finally:
        signal.signal(signal.SIGHUP, previous)
