"""Writes that never follow a link, replace only regular files, and write a device or pipe the user named in
place: :mod:`contin.util.safe_files`."""

import errno
import json
import os
import stat
import threading

import pytest

from contin.util.safe_files import (UnsafeTarget, append_stream, create_stream, is_temporary_name, open_regular,
                                    replace_file, write_user_file)


def test_replace_file_writes_through_a_random_exclusive_temporary_file(tmp_path, monkeypatch):
    seen = []
    real_open = os.open

    def spy(path, flags, *args):
        seen.append((os.path.basename(path), flags))
        return real_open(path, flags, *args)

    monkeypatch.setattr(os, "open", spy)
    replace_file(tmp_path / "a.json", lambda fh: fh.write("{}"))
    (name, flags), = seen
    assert is_temporary_name(name) and name.startswith(".a.json.")
    assert flags & os.O_EXCL and flags & os.O_CREAT and flags & os.O_NOFOLLOW
    assert (tmp_path / "a.json").read_text() == "{}" and [p.name for p in tmp_path.iterdir()] == ["a.json"]


@pytest.mark.parametrize("make", ["directory", "fifo", "dangling link"])
def test_what_is_not_a_regular_file_is_never_replaced(tmp_path, make):
    path = tmp_path / "target"
    if make == "directory":
        path.mkdir()
    elif make == "fifo":
        os.mkfifo(path)
    else:
        path.symlink_to(tmp_path / "nowhere")
    for write in (lambda: replace_file(path, lambda fh: fh.write("x")), lambda: create_stream(path),
                  lambda: append_stream(path)):
        with pytest.raises(UnsafeTarget) as exc:
            write()
        assert exc.value.filename == str(path)
    assert not (tmp_path / "nowhere").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["target"]


def test_streams_name_their_file_in_a_write_error(tmp_path):
    with create_stream(tmp_path / "rows.csv") as s:
        s.write("a\n")
    s = append_stream(tmp_path / "rows.csv")

    class Full:
        def write(self, data):
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

        def close(self):
            pass

    s._fh = Full()
    with pytest.raises(OSError, match="No space left on device") as exc:
        s.write("c\n")
    assert exc.value.filename == str(tmp_path / "rows.csv")
    assert (tmp_path / "rows.csv").read_text() == "a\n"


def test_a_pipe_the_user_named_is_written_in_place(tmp_path):
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    got = []
    reader = threading.Thread(target=lambda: got.append(fifo.read_text()), daemon=True)
    reader.start()
    write_user_file(fifo, lambda fh: fh.write(json.dumps({"k2": 1.5})))
    reader.join(10)
    assert got == ['{"k2": 1.5}'] and stat.S_ISFIFO(os.lstat(fifo).st_mode)


def test_a_link_the_user_named_leads_to_the_file_it_points_at(tmp_path):
    (tmp_path / "real.json").write_text("old")
    (tmp_path / "latest.json").symlink_to(tmp_path / "real.json")
    write_user_file(tmp_path / "latest.json", lambda fh: fh.write("new"))
    assert (tmp_path / "latest.json").is_symlink() and (tmp_path / "real.json").read_text() == "new"
    with pytest.raises(IsADirectoryError):
        write_user_file(tmp_path, lambda fh: fh.write("x"))


def test_open_regular_refuses_links_pipes_and_files_too_large(tmp_path):
    (tmp_path / "big").write_bytes(b"x" * 100)
    with pytest.raises(OSError, match="larger than the 10 bytes") as exc:
        open_regular(tmp_path / "big", limit=10)
    assert exc.value.errno == errno.EFBIG
    with open_regular(tmp_path / "big", limit=100) as fh:
        assert fh.read() == "x" * 100
    (tmp_path / "link").symlink_to(tmp_path / "big")
    with pytest.raises(UnsafeTarget, match="symbolic link"):
        open_regular(tmp_path / "link")
