"""Scene files are read only if they are regular files under the size cap, once, and their hash is kept
(contin/scene/files.py, load_scene in contin/scene/parse.py)."""

import hashlib
import os
from pathlib import Path

import pytest

from conftest import no_hang
from contin.scene.parse import SceneError, SceneLoader, load_scene

ROOT = Path(__file__).resolve().parents[2]
DUFFING = ROOT / "scenes" / "duffing.yaml"


def _link(tmp_path, target) -> Path:
    link = tmp_path / "scene.yaml"
    link.symlink_to(target)
    return link


@pytest.mark.parametrize("device, kind", [("/dev/zero", "a character device"), ("/dev/urandom", "a character device")])
def test_a_scene_linked_to_a_device_is_refused_before_it_is_read(tmp_path, device, kind):
    if not os.path.exists(device):
        pytest.skip(f"no {device} here")
    with no_hang(20), pytest.raises(SceneError, match=f"{kind}, not a regular file") as exc:
        load_scene(_link(tmp_path, device))
    assert exc.value.key.endswith("scene.yaml") and "at most 8 MiB" in str(exc.value)


def test_a_fifo_is_refused_without_blocking(tmp_path):
    fifo = tmp_path / "scene.yaml"
    os.mkfifo(fifo)  # no writer: a plain open() would wait for one forever
    with no_hang(20), pytest.raises(SceneError, match=r"a named pipe \(FIFO\), not a regular file"):
        load_scene(fifo)


def test_a_directory_is_refused(tmp_path):
    with pytest.raises(SceneError, match="a directory, not a regular file"):
        load_scene(tmp_path)


def test_a_scene_over_the_cap_is_refused_by_its_size_before_it_is_parsed(tmp_path):
    from contin.scene.files import SCENE_FILE_CAP

    path = tmp_path / "big.yaml"
    comment = b"# " + b"x" * 77 + b"\n"
    path.write_bytes(DUFFING.read_bytes() + comment * (SCENE_FILE_CAP // len(comment) + 1))
    size = path.stat().st_size
    with no_hang(20), pytest.raises(SceneError, match="more than 8 MiB") as exc:
        load_scene(path)
    assert f"{size / 2**20:.3g} MiB" in str(exc.value)


def test_a_link_to_a_regular_scene_is_read_and_hashed(tmp_path):
    scene = load_scene(_link(tmp_path, DUFFING))
    assert scene.model["builtin"] == "duffing"
    assert scene.inputs == {str(DUFFING.resolve()): hashlib.sha256(DUFFING.read_bytes()).hexdigest()}


def test_a_scene_is_parsed_once(monkeypatch):
    calls = []
    original = SceneLoader.get_single_node

    def counted(self):
        calls.append(1)
        return original(self)

    monkeypatch.setattr(SceneLoader, "get_single_node", counted)
    scene = load_scene(DUFFING)
    assert len(calls) == 1  # the data and the line numbers come from one parse
    assert scene.lines["analysis.harmonics"] == next(i for i, line in enumerate(DUFFING.read_text().splitlines(), 1)
                                                     if line.strip().startswith("harmonics:"))


def test_windows_line_ends_keep_their_line_numbers(tmp_path):
    path = tmp_path / "crlf.yaml"
    path.write_bytes(DUFFING.read_bytes().replace(b"\n", b"\r\n"))
    assert load_scene(path).lines == load_scene(DUFFING).lines


def test_read_input_stops_at_the_cap_and_names_the_file(tmp_path):
    from contin.scene.files import read_input

    path = tmp_path / "f"
    path.write_bytes(b"abc")
    assert read_input(path, 3) == (b"abc", hashlib.sha256(b"abc").hexdigest())
    with pytest.raises(OSError, match="3 bytes, more than 2 bytes") as exc:
        read_input(path, 2)
    assert exc.value.filename == str(path)
    with pytest.raises(OSError) as exc:
        read_input(tmp_path / "missing", 10)
    assert exc.value.filename == str(tmp_path / "missing") and exc.value.strerror
