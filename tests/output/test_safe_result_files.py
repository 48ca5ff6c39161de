"""Result files are never written through a link planted where they (or their temporary files) go, replace
only regular files, and hold strict JSON; each case was written through, or held NaN, before (issue 32)."""

import json
import os
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from contin.output.exports import RunData, write_coefficients_csv
from contin.output.results import CsvStream, truncate_to_valid_rows, write_json_atomic

OUTSIDE = "a file of someone else's\n"


@pytest.fixture
def outside(tmp_path):
    path = tmp_path / "outside.txt"
    path.write_text(OUTSIDE)
    return path


@pytest.fixture
def outdir(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    return out


def test_a_planted_temporary_name_is_not_written_through(outdir, outside):
    (outdir / "summary.json.tmp").symlink_to(outside)
    write_json_atomic(outdir / "summary.json", {"status": "complete"})
    assert outside.read_text() == OUTSIDE
    assert (outdir / "summary.json.tmp").is_symlink()  # left as it was, pointing where it pointed
    assert not (outdir / "summary.json").is_symlink()
    assert json.loads((outdir / "summary.json").read_text()) == {"status": "complete"}


def test_json_onto_a_link_is_refused(outdir, outside):
    (outdir / "summary.json").symlink_to(outside)
    with pytest.raises(OSError, match="symbolic link") as exc:
        write_json_atomic(outdir / "summary.json", {"status": "complete"})
    assert exc.value.filename == str(outdir / "summary.json")
    assert outside.read_text() == OUTSIDE and (outdir / "summary.json").is_symlink()
    assert [p.name for p in outdir.iterdir()] == ["summary.json"]  # no temporary file left


@pytest.mark.parametrize("append", [False, True], ids=["new", "appended"])
def test_a_table_onto_a_link_is_refused(outdir, outside, append):
    (outdir / "branches.csv").symlink_to(outside)
    with pytest.raises(OSError, match="symbolic link"):
        CsvStream(outdir / "branches.csv", ["branch", "w"], append=append).write({"branch": 0, "w": 1.0})
    assert outside.read_text() == OUTSIDE


def test_a_new_table_replaces_a_regular_file_and_appends_after_a_header(outdir):
    (outdir / "t.csv").write_text("old,content\n1,2\n")
    s = CsvStream(outdir / "t.csv", ["a", "b"])
    s.write({"a": 1, "b": 2.5})
    s.close()
    s = CsvStream(outdir / "t.csv", ["a", "b"], append=True)
    s.write({"a": 2, "b": None})
    s.close()
    assert (outdir / "t.csv").read_text() == "a,b\n1,2.5\n2,\n"
    with pytest.raises(ValueError, match="columns differ"):
        CsvStream(outdir / "t.csv", ["a", "c"], append=True)


def test_cutting_a_table_back_does_not_write_through_its_temporary_name(outdir, outside):
    (outdir / "branches.csv").write_text("a,b\n1,2\n3,")  # a last row cut by a killed run
    (outdir / "branches.csv.tmp").symlink_to(outside)
    assert truncate_to_valid_rows(outdir / "branches.csv") == 1
    assert (outdir / "branches.csv").read_text() == "a,b\n1,2\n" and outside.read_text() == OUTSIDE


def test_coefficients_do_not_go_through_a_planted_temporary_name(outdir, outside):
    (outdir / "coefficients.csv.tmp").symlink_to(outside)
    data = RunData(branches={"branch": np.array([0.0]), "w": np.array([0.7])}, special={}, parameter="w",
                   dofs=["x"], H=1, coefficients=np.array([[[0.1], [0.2], [0.3]]]), coefficient_rows=np.array([0]),
                   nu=np.array([1]), base_frequency=np.array([0.7]), summary={})
    assert write_coefficients_csv(outdir, data) == "coefficients.csv"
    assert outside.read_text() == OUTSIDE
    assert (outdir / "coefficients.csv").read_text().splitlines()[1] == "0,0,1,0.7,0.7,0.1,0.2,0.3"


def test_a_figure_onto_a_link_is_refused(outdir, outside):
    from contin.output.figures import new_figure, save_figure

    (outdir / "diagram.png").symlink_to(outside)
    fig = new_figure()
    fig.add_subplot().plot([0, 1], [0, 1])
    with pytest.raises(OSError, match="symbolic link"):
        save_figure(fig, outdir / "diagram", ("png",))
    assert outside.read_text() == OUTSIDE
    assert save_figure(fig, outdir / "other", ("png", "svg")) == ["other.png", "other.svg"]
    assert (outdir / "other.png").read_bytes()[:4] == b"\x89PNG"


def strict(text: str):
    def refuse(token):
        raise ValueError(f"{token} is not JSON")
    return json.loads(text, parse_constant=refuse)


@settings(max_examples=30, deadline=None)
@given(st.recursive(st.floats(allow_nan=True, allow_infinity=True) | st.integers() | st.text(max_size=4),
                    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=3), inner, max_size=3),
                    max_leaves=12))
def test_summary_json_is_strict_json(tmp_path_factory, value):
    """Whatever floats a summary holds, the file is JSON (no NaN, Infinity); a value that is not finite is null."""
    path = tmp_path_factory.mktemp("j") / "summary.json"
    write_json_atomic(path, {"value": value, "array": np.array([1.0, np.nan, np.inf])})
    got = strict(path.read_text())
    assert got["array"] == [1.0, None, None]

    def same(a, b):
        if isinstance(a, float):
            return b is None if not np.isfinite(a) else a == b
        if isinstance(a, list):
            return len(a) == len(b) and all(same(x, y) for x, y in zip(a, b))
        if isinstance(a, dict):
            return a.keys() == b.keys() and all(same(a[k], b[k]) for k in a)
        return a == b

    assert same(value, got["value"])
    assert not [p for p in Path(path).parent.iterdir() if p.name != "summary.json"]  # no temporary file left


def test_a_failed_write_leaves_the_old_file_and_no_temporary_one(outdir, monkeypatch):
    write_json_atomic(outdir / "summary.json", {"status": "running"})

    def full(fd):
        raise OSError(28, os.strerror(28))

    monkeypatch.setattr(os, "fsync", full)
    with pytest.raises(OSError, match="No space left on device") as exc:
        write_json_atomic(outdir / "summary.json", {"status": "complete"})
    assert exc.value.filename == str(outdir / "summary.json")  # named, though the system named no file
    assert json.loads((outdir / "summary.json").read_text()) == {"status": "running"}
    assert [p.name for p in outdir.iterdir()] == ["summary.json"]
