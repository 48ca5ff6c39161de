"""The example scenes that ship: listed, run and checked by name, copied without harm (contin/app/examples.py)."""

import os
import re
import tempfile
from pathlib import Path

import pytest
import yaml
from hypothesis import given, settings, strategies as st

from contin.app.cli import main
from contin.app.examples import copy_examples, describe, example_names, examples_dir, find_scene
from contin.scene.schema import SceneError
from conftest import fuzz_examples

ROOT = Path(__file__).resolve().parents[2]
SOURCE = ROOT / "scenes"


def source_files():
    """``{relative path: bytes}`` of the source tree's scenes and data files: what must ship."""
    out = {p.name: p.read_bytes() for p in SOURCE.glob("*.yaml")}
    out.update({f"data/{p.name}": p.read_bytes() for p in (SOURCE / "data").iterdir() if p.is_file()})
    return out


def test_every_scene_of_the_source_tree_is_an_example():
    assert example_names() == sorted(p.stem for p in SOURCE.glob("*.yaml"))
    assert "duffing" in example_names() and "rotor_fe_rig" in example_names()


def test_the_listing_has_one_line_per_scene_with_its_opening_sentence(capsys, monkeypatch, tmp_path):
    monkeypatch.chdir(tmp_path)
    assert main(["examples"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert [line.split()[0] for line in lines] == sorted(p.stem for p in SOURCE.glob("*.yaml"))
    duffing = next(line for line in lines if line.startswith("duffing "))
    assert duffing.split(None, 1)[1] == ("Forced Duffing oscillator x'' + 0.1 x' + x + x^3 = 0.5 cos(w t): two "
                                         "folds (a jump region)")
    # "Fig. 8" is no end of a sentence
    assert "Timing belt (seed 003), Fig. 8: backbone curves" in next(l for l in lines if l.startswith("belt_backbone"))
    assert all(len(line) <= 140 for line in lines)


@pytest.mark.parametrize("text,expected", [
    ("# One. Two.\n# Three\nmodel: {}\n", "One"),
    ("# A rotor, sec. 3 of the paper: its orbit\n# and more. Next\nmodel: {}\n",
     "A rotor, sec. 3 of the paper: its orbit and more"),
    ("model: {}\noutput:\n  title: the title\n", "the title"),
    ("model: {}\n", ""),
    ("model: [unclosed\n", ""),
])
def test_describe_takes_the_opening_comment_else_the_title(tmp_path, text, expected):
    path = tmp_path / "s.yaml"
    path.write_text(text)
    assert describe(path) == expected


def test_a_name_is_the_shipped_scene_a_path_or_a_local_file_is_itself(monkeypatch, tmp_path):
    monkeypatch.chdir(tmp_path)
    shipped = str(examples_dir() / "duffing.yaml")
    assert find_scene("duffing") == shipped and find_scene("duffing.yaml") == shipped
    assert Path(shipped).read_bytes() == (SOURCE / "duffing.yaml").read_bytes()
    (tmp_path / "duffing").mkdir()  # e.g. `-o duffing` of an earlier run: no scene file
    assert find_scene("duffing") == shipped
    (tmp_path / "duffing.yaml").write_text("model: {}\n")  # a file here is what the user means
    assert find_scene("duffing.yaml") == "duffing.yaml"
    assert find_scene("./duffing") == "./duffing" and find_scene("sub/duffing") == "sub/duffing"


@pytest.mark.parametrize("name,match", [
    ("dufing", r"dufing: expected a scene file, or the name of an example .*did you mean duffing"),
    ("__init__", r"__init__: expected a scene file, or the name of an example"),
    ("data", r"data: expected a scene file, or the name of an example"),
    ("rig_001.npz", r"rig_001.npz: expected a scene file"),
])
def test_an_unknown_name_is_refused_with_the_closest_names(monkeypatch, tmp_path, name, match):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SceneError, match=match):
        find_scene(name)


@settings(max_examples=fuzz_examples(200), deadline=None)
@given(st.text(st.characters(blacklist_categories=("Cs",), blacklist_characters="\x00/"), min_size=1, max_size=30))
def test_a_name_never_leads_outside_the_shipped_scenes(name):
    """Any name without a separator is an example's file in contin.scenes, or refused; nothing else is read."""
    here = os.getcwd()
    with tempfile.TemporaryDirectory() as empty:
        os.chdir(empty)
        try:
            try:
                got = find_scene(name)
            except SceneError as exc:
                assert "expected a scene file, or the name of an example" in str(exc)
                return
        finally:
            os.chdir(here)
    if name in (".", ".."):
        assert got == name
        return
    assert Path(got).parent == examples_dir() and Path(got).stem in example_names()


def test_check_and_run_by_name_from_another_directory(monkeypatch, tmp_path, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["check", "duffing"]) == 0
    assert f"scene: {examples_dir() / 'duffing.yaml'}" in capsys.readouterr().out
    assert main(["run", "two_dof_modes", "-o", "out", "-q"]) == 0
    assert (tmp_path / "out" / "summary.json").is_file()
    assert main(["check", "no_such_scene"]) == 2
    assert "no_such_scene: expected a scene file, or the name of an example" in capsys.readouterr().err


def test_a_shipped_scene_reads_its_data_beside_it():
    from contin.scene.fe_model import rotor_path

    scene = find_scene("rotor_fe_rig")
    model = yaml.safe_load(Path(scene).read_text())["model"]
    assert model["file"] == "data/rig_001.npz"  # relative: read from the package, or from a copy
    path = rotor_path(model, scene)
    assert path.read_bytes() == (SOURCE / "data" / "rig_001.npz").read_bytes()


def test_help_points_at_the_examples(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["--help"])
    assert exc.value.code == 0
    text = " ".join(capsys.readouterr().out.split())
    assert "`contin examples` lists them" in text and "contin run duffing -o results/duffing" in text


def test_copy_writes_every_scene_and_its_data(tmp_path, capsys):
    dest = tmp_path / "new" / "examples"
    assert main(["examples", "--copy", str(dest)]) == 0
    want = source_files()
    got = {p.relative_to(dest).as_posix(): p.read_bytes() for p in dest.rglob("*") if p.is_file()}
    assert got == want
    assert f"{len(want)} files copied to {dest}" in capsys.readouterr().out
    from contin.scene.fe_model import rotor_path  # the copy reads its own data

    model = yaml.safe_load((dest / "rotor_fe_rig.yaml").read_text())["model"]
    assert rotor_path(model, str(dest / "rotor_fe_rig.yaml")) == dest / "data" / "rig_001.npz"


def test_copy_refuses_to_overwrite_without_force(tmp_path, capsys):
    copy_examples(tmp_path)
    (tmp_path / "duffing.yaml").write_text("mine\n")
    (tmp_path / "mathieu.yaml").unlink()
    assert main(["examples", "--copy", str(tmp_path)]) == 2
    err = " ".join(capsys.readouterr().err.split())
    assert re.search(r"--copy: expected a directory without files of the examples' names \(or --force", err)
    assert "absorber_exercise.yaml" in err and "nothing was copied" in err
    assert (tmp_path / "duffing.yaml").read_text() == "mine\n" and not (tmp_path / "mathieu.yaml").exists()
    assert main(["examples", "--copy", str(tmp_path), "--force"]) == 0
    assert (tmp_path / "duffing.yaml").read_bytes() == (SOURCE / "duffing.yaml").read_bytes()
    assert (tmp_path / "mathieu.yaml").is_file()


def test_copy_never_writes_through_a_link_even_with_force(tmp_path, capsys):
    victim = tmp_path / "victim.txt"
    victim.write_text("keep\n")
    dest = tmp_path / "ex"
    dest.mkdir()
    (dest / "duffing.yaml").symlink_to(victim)
    assert main(["examples", "--copy", str(dest), "--force"]) == 2
    assert "duffing.yaml" in capsys.readouterr().err
    assert victim.read_text() == "keep\n" and (dest / "duffing.yaml").is_symlink()


def test_copy_refuses_a_data_directory_that_is_a_link(tmp_path, capsys):
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    dest = tmp_path / "ex"
    dest.mkdir()
    (dest / "data").symlink_to(elsewhere, target_is_directory=True)
    assert main(["examples", "--copy", str(dest), "--force"]) == 2
    assert "data/ in the directory to be a plain directory" in " ".join(capsys.readouterr().err.split())
    assert not any(elsewhere.iterdir()) and not any(p.suffix == ".yaml" for p in dest.iterdir())


def test_copy_into_a_file_and_force_alone_are_refused(tmp_path, capsys):
    (tmp_path / "f").write_text("x")
    assert main(["examples", "--copy", str(tmp_path / "f")]) == 2
    assert "a directory for the examples (new or existing)" in capsys.readouterr().err
    assert main(["examples", "--force"]) == 2
    assert "--force goes with --copy DIR" in capsys.readouterr().err
