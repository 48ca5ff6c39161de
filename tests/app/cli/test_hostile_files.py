"""Files that are not what they should be: a message naming the file and what was expected, exit 2,
never a traceback, and nothing written."""

import json
from pathlib import Path

import pytest

from contin.output.checkpoint import CheckpointError, read_records
from contin.app.cli import main

ROOT = Path(__file__).resolve().parents[3]
DUFFING = str(ROOT / "scenes/duffing.yaml")
FAST = ["-q", "--set", "analysis.harmonics=1", "--set", "output.plots=false"]


def run(argv, capsys):
    code = main(argv)
    err = capsys.readouterr().err
    assert "Traceback" not in err
    return code, " ".join(err.split())  # the message as one line (it is wrapped at 100 columns)


def test_a_scene_that_is_not_utf8_is_named(tmp_path, capsys):
    path = tmp_path / "latin1.yaml"
    path.write_bytes(b"model: {builtin: duffing}\n# r\xe9sonance\n")
    code, err = run(["check", str(path)], capsys)
    assert code == 2 and "UTF-8" in err and "0xe9" in err


@pytest.mark.parametrize("text,fragment", [
    ("a: &x [*x]\nmodel: {builtin: duffing}\n", "refer to themselves"),
    # nine levels of nine aliases: 9^9 values once expanded, a few lines of YAML
    ("l0: &l0 [lol, lol, lol, lol, lol, lol, lol, lol, lol]\n"
     + "".join(f"l{i}: &l{i} [{', '.join([f'*l{i - 1}'] * 9)}]\n" for i in range(1, 9))
     + "model: {builtin: duffing}\n", "aliases nested within aliases"),
])
def test_aliases_that_build_too_much_are_refused(tmp_path, capsys, text, fragment):
    path = tmp_path / "alias.yaml"
    path.write_text(text)
    code, err = run(["run", str(path), "-o", str(tmp_path / "out"), "-q"], capsys)
    assert code == 2 and fragment in err
    assert not (tmp_path / "out").exists()


def test_a_recursive_alias_in_set_is_refused(tmp_path, capsys):
    code, err = run(["run", DUFFING, "-o", str(tmp_path / "out"), *FAST, "--set", "model.parameters.F=&x [*x]"],
                    capsys)
    assert code == 2 and "--set model.parameters.F" in err and not (tmp_path / "out").exists()


def test_output_on_an_existing_file_is_refused(tmp_path, capsys):
    target = tmp_path / "afile"
    target.write_text("keep me")
    code, err = run(["run", DUFFING, "-o", str(target), *FAST], capsys)
    assert code == 2 and "-o" in err and "a file of that name exists" in err
    assert target.read_text() == "keep me"


def test_output_below_a_file_is_an_io_message(tmp_path, capsys):
    (tmp_path / "afile").write_text("")
    code, err = run(["run", DUFFING, "-o", str(tmp_path / "afile" / "out"), *FAST], capsys)
    assert code == 2 and "afile" in err


@pytest.fixture
def unfinished(tmp_path, capsys):
    """A run whose summary says it was interrupted: --resume would continue it."""
    out = tmp_path / "run"
    assert main(["run", DUFFING, "-o", str(out), *FAST]) == 0
    capsys.readouterr()
    summary = json.loads((out / "summary.json").read_text())
    summary["status"] = "interrupted"
    (out / "summary.json").write_text(json.dumps(summary))
    return out


def test_resume_with_a_corrupt_summary_is_refused(unfinished, capsys):
    (unfinished / "summary.json").write_text("{not json")
    code, err = run(["run", DUFFING, "-o", str(unfinished), *FAST, "--resume"], capsys)
    assert code == 2 and "summary.json" in err and "without --resume" in err


@pytest.mark.parametrize("line,fragment", [
    ("[1, 2]", "a JSON object, found list"),
    ('{"type": "point", "row": 0}', "with the keys branch, lam, u, tangent"),
    ('{"type": "point", "row": 0, "branch": 0, "lam": 1.0, "u": "x", "tangent": [1.0]}', "lists of numbers"),
    ('{"type": "elsewhere", "branch": 0}', "a record of type point, branch, special"),
    ('{"type": "branch", "branch": -1}', "a branch number"),
])
def test_resume_with_a_state_file_contin_did_not_write_is_refused(unfinished, capsys, line, fragment):
    rows_before = (unfinished / "branches.csv").read_text()
    (unfinished / "state.jsonl").write_text(line + "\n")
    code, err = run(["run", DUFFING, "-o", str(unfinished), *FAST, "--resume"], capsys)
    assert code == 2 and "state.jsonl line 1" in err and fragment in err
    assert (unfinished / "branches.csv").read_text() == rows_before  # nothing rewritten


def test_a_line_cut_by_a_killed_run_ends_the_records(tmp_path):
    path = tmp_path / "state.jsonl"
    path.write_text('{"type": "branch", "branch": 0}\n{"type": "point", "row": 0, "branch": 0, "lam": 1, "u": [1.0, 2')
    assert [r["type"] for r in read_records(path)] == ["branch"]
    path.write_text('{"type": "branch", "branch": 0}\n{"type": "point", "row": "0"}\n')
    with pytest.raises(CheckpointError, match="line 2: a point record with the keys branch, lam, u, tangent"):
        read_records(path)


def test_plot_of_a_missing_directory_is_named(tmp_path, capsys):
    code, err = run(["plot", str(tmp_path / "nowhere"), "--point", "0"], capsys)
    assert code == 2 and "a result directory written by `contin run`" in err


@pytest.mark.parametrize("text,line", [
    ("model: {builtin: duffing}\nanalysis:\n  type: frequency_response\n  range: [0.5, 2]\n  range: [0.5, 3]\n", 5),
    ("model: {builtin: duffing, builtin: mathieu}\n", 1),
])
def test_a_key_given_twice_is_refused_with_its_lines(tmp_path, capsys, text, line):
    path = tmp_path / "twice.yaml"
    path.write_text(text)
    code, err = run(["check", str(path)], capsys)
    assert code == 2 and f"(line {line})" in err and "is given twice (first on line" in err


def test_a_merged_key_may_be_overridden(tmp_path, capsys):
    path = tmp_path / "merge.yaml"
    path.write_text("model:\n  <<: {builtin: mathieu}\n  builtin: duffing\n"
                    "analysis: {type: frequency_response, range: [0.5, 2.0]}\n")
    code = main(["check", str(path)])
    out = capsys.readouterr().out
    assert code == 0 and "duffing" in out and "mathieu" not in out
