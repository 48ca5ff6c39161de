"""Whose an output directory is, and the lock of the process writing it (:mod:`contin.app.outdir`)."""

import json
import os

import pytest

from contin.app.outdir import LOCK_NAME, OutdirLock, check_outdir, clean_temporary_files, is_contins
from contin.scene.parse import SceneError


def test_a_directory_is_contins_by_its_lock_file_or_a_summary_contin_wrote(tmp_path):
    assert not is_contins(tmp_path)
    (tmp_path / "summary.json").write_text(json.dumps({"status": "complete"}))  # a user's JSON of that name
    assert not is_contins(tmp_path)
    (tmp_path / "summary.json").write_text(json.dumps({"status": "complete", "scene": {}, "versions": {}}))
    assert is_contins(tmp_path)  # results of a version before the lock file
    other = tmp_path / "other"
    other.mkdir()
    (other / LOCK_NAME).symlink_to(tmp_path / "summary.json")
    assert not is_contins(other)  # a link is no sign


def test_hidden_entries_do_not_make_a_directory_the_users(tmp_path):
    (tmp_path / ".DS_Store").write_text("")
    check_outdir(tmp_path)
    (tmp_path / "results.npz").write_bytes(b"mine")
    with pytest.raises(SceneError, match=r"it holds 1 entry \(results.npz\) and no sign of contin"):
        check_outdir(tmp_path)
    check_outdir(tmp_path, force=True)
    with pytest.raises(SceneError, match="a file of that name exists"):
        check_outdir(tmp_path / "results.npz")


@pytest.mark.parametrize("name, make", [("summary.json", "fifo"), ("results.npz", "directory"),
                                        ("runs", "link"), ("figure.svg", "link")])
def test_a_result_name_that_is_no_regular_file_is_refused_even_with_force(tmp_path, name, make):
    (tmp_path / LOCK_NAME).write_text("")
    path = tmp_path / name
    if make == "fifo":
        os.mkfifo(path)
    elif make == "directory":
        path.mkdir()
    else:
        path.symlink_to(tmp_path)
    with pytest.raises(SceneError, match=rf"{name} is contin's own .*remove it, or choose another -o"):
        check_outdir(tmp_path, force=True)


def test_the_lock_names_its_holder_and_is_free_again_when_released(tmp_path):
    lock = OutdirLock(tmp_path).acquire()
    note = json.loads((tmp_path / LOCK_NAME).read_text())
    assert note["pid"] == os.getpid() and note["since"] and note["command"]
    with pytest.raises(SceneError, match=rf"no other contin process is writing.*process {os.getpid()}, running since"):
        OutdirLock(tmp_path).acquire()  # another open file: flock refuses it, as for another process
    lock.release()
    assert (tmp_path / LOCK_NAME).read_text() == ""
    with OutdirLock(tmp_path):
        pass


def test_a_lock_file_that_is_a_link_is_refused(tmp_path):
    (tmp_path / "elsewhere").write_text("x")
    (tmp_path / LOCK_NAME).symlink_to(tmp_path / "elsewhere")
    with pytest.raises(SceneError, match="regular file.*symbolic link"):
        OutdirLock(tmp_path).acquire()
    assert (tmp_path / "elsewhere").read_text() == "x"


def test_temporary_files_of_killed_writes_are_cleaned(tmp_path):
    for name in (".summary.json.0123456789ab.tmp", ".x.tmp", "summary.json.tmp", ".a.csv.0123456789ab.tmp"):
        (tmp_path / name).write_text("")
    assert clean_temporary_files(tmp_path) == 2
    assert sorted(p.name for p in tmp_path.iterdir()) == [".x.tmp", "summary.json.tmp"]
