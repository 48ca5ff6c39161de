"""The checkpoint's arrays in binary: a size that grows by the arrays' own bytes, read back exactly,
a torn last record dropped, damaged or older files refused by name, and a stored point still drawn."""

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from contin.app.cli import main
from contin.output.checkpoint import CheckpointError, read_records, resumable_prefix
from contin.output.results import read_csv
from contin.output.state_store import ARRAYS_NAME, INLINE, LAST_NAME
from contin.output.state_writer import StateWriter

ROOT = Path(__file__).resolve().parents[2]
DUFFING = str(ROOT / "scenes/duffing.yaml")
#: no stability, no figures, a short range: about 20 points in a fraction of a second
CHEAP = ["-q", "--set", "output.plots=false", "--set", "analysis.stability=none", "--set", "analysis.range=[0.5, 1.2]"]


def run(out, H):
    assert main(["run", DUFFING, "-o", str(out), *CHEAP, "--set", f"analysis.harmonics={H}"]) == 0
    return out


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """The same scene with 17 and 81 unknowns (H = 8 and 40; 1 dof): made once, copied before a change."""
    base = tmp_path_factory.mktemp("state")
    return {H: run(base / f"h{H}", H) for H in (8, 40)}


def points(out) -> int:
    return sum(1 for r in read_records(out / "state.jsonl") if r["type"] == "point")


def test_the_state_grows_by_the_bytes_of_the_arrays(runs):
    """Per point: state.bin holds the coefficients and the tangent as float64 (8 bytes a value) and little else,
    while the JSON lines do not grow with the unknowns (before: 6 MB of JSON lists for the rotor's 99 points)."""
    per_point = {}
    for H, out in runs.items():
        n = 2 * H + 1  # unknowns of 1 dof; the tangent has n + 1 values
        p = points(out)
        arrays = (out / ARRAYS_NAME).stat().st_size / p
        assert arrays <= 1.2 * 8 * (n + n + 1) + 64, (H, arrays)
        # the engine's last two positions and states only (a state: its scalars and references, about 1.3 KB)
        assert (out / LAST_NAME).stat().st_size <= 4 * 8 * (n + 1) + 2 * 1536 + 1024
        per_point[H] = (out / "state.jsonl").stat().st_size / p
    # 64 more unknowns add 2 x 64 x 8 = 1 KB of arrays per point, not one byte of JSON beyond a few digits
    assert abs(per_point[40] - per_point[8]) < 64, per_point
    assert max(len(line) for line in (runs[40] / "state.jsonl").read_text().splitlines()) < 4096


def test_a_stored_point_reads_back_exactly_and_is_drawn(runs, tmp_path, capsys):
    out = tmp_path / "copy"
    shutil.copytree(runs[8], out)
    line = next(json.loads(s) for s in (out / "state.jsonl").read_text().splitlines() if '"row": 3,' in s)
    assert "__bin__" in line["u"] and "__bin__" in line["tangent"]  # the bytes, not a list of numbers
    rec = next(r for r in read_records(out / "state.jsonl") if r["type"] == "point" and r["row"] == 3)
    u = rec["u"]
    assert isinstance(u, np.ndarray) and u.dtype == np.float64 and u.shape == (17,)
    # the coefficients solve the balance of the Duffing oscillator (truth of the model, not of the file)
    from contin.analyses.frequency_response import build_problem
    from contin.scene.build import build_model
    from contin.scene.parse import load_scene

    scene = load_scene(DUFFING, ["analysis.harmonics=8"])
    hb = build_problem(scene, build_model(scene))
    assert np.abs(hb.residual(u, rec["lam"])).max() < 1e-8
    assert rec["lam"] == pytest.approx(read_csv(out / "branches.csv")["w"][3], abs=1e-12)
    assert main(["plot", str(out), "--point", "3"]) == 0
    assert (out / "point_3.png").stat().st_size > 1000


finite = st.floats(allow_nan=False, allow_infinity=False, width=64)
values = st.floats(allow_nan=True, allow_infinity=True, width=64)


@settings(max_examples=25, deadline=None)
@given(st.lists(values, min_size=INLINE + 1, max_size=64), st.lists(finite, min_size=INLINE + 1, max_size=40),
       st.lists(st.integers(-2**62, 2**62), min_size=INLINE + 1, max_size=40))
def test_arrays_read_back_bit_for_bit(tmp_path_factory, u, re, ints):
    path = tmp_path_factory.mktemp("exact") / "state.jsonl"
    u = np.array(u)
    z = np.array(re) + 1j * np.array(re[::-1])
    groups = np.array(ints, dtype=np.int64)
    writer = StateWriter(path)
    rec = {"type": "point", "row": 0, "branch": 0, "lam": 1.0, "u": u, "tangent": u[::-1].copy(),
           "data": {"multipliers": z, "groups": groups}}
    writer.write(rec)
    size = path.with_name(ARRAYS_NAME).stat().st_size
    assert size <= u.nbytes * 2 + z.nbytes + groups.nbytes  # equal arrays share their bytes
    writer.write(dict(rec, row=1))  # the same arrays again: referred to, not written twice
    writer.close()
    assert path.with_name(ARRAYS_NAME).stat().st_size == size
    for got in read_records(path):
        assert got["u"].tobytes() == u.tobytes() and got["tangent"].tobytes() == u[::-1].tobytes()
        assert got["data"]["multipliers"].tobytes() == z.tobytes()
        assert got["data"]["groups"].dtype == np.int64 and np.array_equal(got["data"]["groups"], groups)
    assert path.read_text().isascii() and "NaN" not in path.read_text()


def test_a_record_whose_arrays_were_being_written_is_dropped(runs, tmp_path):
    out = tmp_path / "torn"
    shutil.copytree(runs[8], out)
    records = read_records(out / "state.jsonl")
    lines = (out / "state.jsonl").read_text().splitlines(keepends=True)
    last = max(i for i, line in enumerate(lines) if '"type": "point"' in line)
    ref = json.loads(lines[last])["tangent"]["__bin__"]
    # killed while the last point's tangent was written: its line refers to bytes past the end of state.bin
    with open(out / ARRAYS_NAME, "r+b") as fh:
        fh.truncate(ref[0] + 8)
    (out / "state.jsonl").write_text("".join(lines[:last + 1]) + lines[last + 1][:25])  # and a torn line after it
    got = read_records(out / "state.jsonl")
    assert len(got) == last and [r["type"] for r in got] == [r["type"] for r in records[:last]]


@pytest.mark.parametrize("damage, match", [
    (lambda p: p.write_bytes(p.read_bytes()[:200] + bytes([p.read_bytes()[200] ^ 1]) + p.read_bytes()[201:]),
     r"state\.bin do not match the checksum"),
    (lambda p: p.unlink(), r"its arrays in .*state\.bin, which is missing"),
])
def test_changed_or_missing_arrays_are_refused_by_name(runs, tmp_path, damage, match):
    out = tmp_path / "damaged"
    shutil.copytree(runs[8], out)
    damage(out / ARRAYS_NAME)
    with pytest.raises(CheckpointError, match=match):
        read_records(out / "state.jsonl")


@pytest.mark.parametrize("ref", [{"__bin__": [0, "|O", [20]], "crc": 0}, {"__bin__": [-8, "<f8", [20]], "crc": 0},
                                 {"__bin__": [0, "<f8", [20, 2, 2]], "crc": 0}, {"__bin__": [0, "<f8", [20]]}])
def test_a_reference_contin_does_not_write_is_refused(runs, tmp_path, ref):
    out = tmp_path / "hostile"
    shutil.copytree(runs[8], out)
    lines = (out / "state.jsonl").read_text().splitlines()
    first = next(i for i, line in enumerate(lines) if '"type": "point"' in line)
    rec = json.loads(lines[first])
    rec["u"] = ref  # an object array (pickles), a negative offset, three axes, no checksum
    lines[first] = json.dumps(rec)
    (out / "state.jsonl").write_text("\n".join(lines) + "\n")
    with pytest.raises(CheckpointError, match=rf"state\.jsonl line {first + 1}: an array reference"):
        read_records(out / "state.jsonl")


def test_a_state_of_an_older_contin_is_refused_on_resume(runs, tmp_path, capsys):
    out = tmp_path / "older"
    shutil.copytree(runs[8], out)
    summary = json.loads((out / "summary.json").read_text())
    summary["status"] = "interrupted"
    (out / "summary.json").write_text(json.dumps(summary))
    older = {"type": "point", "row": 0, "branch": 0, "nu": 1, "H": 8, "lam": 0.5, "u": [0.1] * 17,
             "tangent": [0.0] * 17 + [1.0]}  # arrays as JSON lists, as contin wrote them before state.bin
    (out / "state.jsonl").write_text(json.dumps(older) + "\n")
    code = main(["run", DUFFING, "-o", str(out), *CHEAP, "--set", "analysis.harmonics=8", "--resume"])
    err = " ".join(capsys.readouterr().err.split())
    assert code == 2 and "line 1: written by an older contin" in err and "run again without --resume" in err


def test_the_engine_positions_of_the_last_two_steps_are_held(runs, tmp_path, capsys):
    """Killed after state_last.npz was replaced but before the engine line: the line before still resumes."""
    out = tmp_path / "engine"
    shutil.copytree(runs[8], out)
    records = read_records(out / "state.jsonl")
    engines = [i for i, r in enumerate(records) if r["type"] == "engine" and r["branch"] == records[-1]["branch"]]
    assert not any(records[i].get("stale") for i in engines[-2:])
    assert all(records[i].get("stale") for i in engines[:-2])  # older positions are not kept
    lines = (out / "state.jsonl").read_text().splitlines(keepends=True)
    (out / "state.jsonl").write_text("".join(lines[:engines[-2] + 1]))
    prefix, rows, _ = resumable_prefix(read_records(out / "state.jsonl"), 1 << 62)
    assert len(prefix) == engines[-2] + 1
    summary = json.loads((out / "summary.json").read_text())
    summary["status"] = "interrupted"
    (out / "summary.json").write_text(json.dumps(summary))
    assert main(["run", DUFFING, "-o", str(out), *CHEAP, "--set", "analysis.harmonics=8", "--resume"]) == 0
    got, want = read_csv(out / "branches.csv"), read_csv(runs[8] / "branches.csv")
    np.testing.assert_allclose(got["amp_x"], want["amp_x"], rtol=1e-10, atol=0)
    # without the file of last positions no engine line resumes: the branch is traced again from its start
    (out / LAST_NAME).unlink()
    assert all(r.get("stale") for r in read_records(out / "state.jsonl") if r["type"] == "engine")
