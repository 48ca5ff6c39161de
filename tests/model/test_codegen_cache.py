"""The generated-kernel cache is used only in a private directory.

Importing a module file, or letting numba load the pickled cache index next to
it, runs whatever is in them. A cache directory is accepted only if it is a
real directory of the current user, not writable by group or others, reached
through directories nobody else can rename (:func:`contin.model.codegen.check_private_dir`);
otherwise it is skipped with a warning, and with no acceptable directory the
kernels are compiled in memory. Each test plants code in a refused directory
(bytecode next to the kernel module, or a numba index whose unpickling has a
visible effect) and checks that it does not run.
"""

from __future__ import annotations

import importlib.util
import marshal
import os
import pickle
import stat
import sys
import uuid
import warnings
from pathlib import Path

import pytest

from contin import ContinWarning
from contin.model import codegen

pytestmark = pytest.mark.skipif(not hasattr(os, "geteuid"), reason="POSIX owners and modes")


@pytest.fixture
def sandbox(tmp_path, monkeypatch):
    """Every candidate directory under ``tmp_path``: ``$HOME`` (``~/.cache/contin/kernels``) and the
    system temporary directory (mode 1777, like ``/tmp``); no ``$CONTIN_CACHE_DIR``; a fresh module table."""
    home, tmp = tmp_path / "home", tmp_path / "tmp"
    home.mkdir(mode=0o700)
    tmp.mkdir()
    tmp.chmod(0o1777)
    monkeypatch.setenv("HOME", str(home))
    monkeypatch.delenv("CONTIN_CACHE_DIR", raising=False)
    monkeypatch.setattr("tempfile.tempdir", str(tmp))
    monkeypatch.setattr(codegen, "_LOADED", {})
    monkeypatch.setattr(codegen, "_WARNED", set(), raising=False)
    import numba.core.config

    monkeypatch.setattr(numba.core.config, "CACHE_DIR", "")  # numba's index next to the module file
    before = set(sys.modules)
    yield tmp_path
    for name in set(sys.modules) - before:
        if name.startswith("contin_kernel_"):
            del sys.modules[name]


def unique_source(body: str = "VALUE = 'genuine'\n") -> str:
    """A module source of its own (its name is its hash) so no other test has loaded it."""
    return f"# contin test kernel {uuid.uuid4().hex}\n{body}"


def plant_bytecode(directory: Path, source: str) -> Path:
    """Put the genuine module file in ``directory`` with planted bytecode beside it.

    The ``.pyc`` header carries the source's time stamp and size (PEP 552), so
    an import of that file runs the planted code, ``VALUE = 'planted'``.
    """
    py = directory / f"{codegen.module_name(source)}.py"
    py.write_text(source)
    st = py.stat()
    header = (importlib.util.MAGIC_NUMBER + (0).to_bytes(4, "little")
              + (int(st.st_mtime) & 0xFFFFFFFF).to_bytes(4, "little") + (st.st_size & 0xFFFFFFFF).to_bytes(4, "little"))
    pyc = Path(importlib.util.cache_from_source(str(py)))
    pyc.parent.mkdir(exist_ok=True)
    pyc.write_bytes(header + marshal.dumps(compile("VALUE = 'planted'\n", str(py), "exec")))
    # the plant works: a plain import of that file runs it
    spec = importlib.util.spec_from_file_location("planted_probe", py)
    probe = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(probe)
    assert probe.VALUE == "planted"
    return py


def load(source: str):
    """``codegen.load_module(source)`` and the messages of the warnings it gave (recorded, not shown)."""
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        module = codegen.load_module(source)
    return module, [str(w.message) for w in record if issubclass(w.category, ContinWarning)]


def warned(messages, text):
    return any(text in m for m in messages)


def assert_not_from(module, directory: Path):
    assert module.VALUE == "genuine"
    assert not str(module.__file__).startswith(str(directory))


@pytest.mark.parametrize("mode", [0o777, 0o775])
def test_directory_writable_by_others_is_refused(sandbox, monkeypatch, mode):
    shared = sandbox / "shared"
    shared.mkdir()
    shared.chmod(mode)
    monkeypatch.setenv("CONTIN_CACHE_DIR", str(shared))
    source = unique_source()
    plant_bytecode(shared, source)
    module, messages = load(source)
    assert_not_from(module, shared)
    assert warned(messages, f"{shared}: it is writable by group or others (mode 0{mode:o})"), messages
    # the next candidate ($CONTIN_CACHE_DIR takes the place of ~/.cache/contin/kernels): the temporary one
    assert Path(module.__file__).parent == sandbox / f"tmp/contin-kernels-{os.geteuid()}"


def test_directory_of_another_user_is_refused(sandbox, monkeypatch):
    theirs = sandbox / "theirs"
    theirs.mkdir(mode=0o700)
    monkeypatch.setenv("CONTIN_CACHE_DIR", str(theirs))
    source = unique_source()
    plant_bytecode(theirs, source)
    # as another user every directory made here is someone else's: the home and temporary ones too
    monkeypatch.setattr(os, "geteuid", lambda: os.stat(theirs).st_uid + 1)
    module, messages = load(source)
    assert_not_from(module, theirs)
    assert module.__file__.startswith("<")  # compiled in memory
    assert warned(messages, f"{theirs}: it belongs to another user"), messages
    assert warned(messages, f"contin-kernels-{os.geteuid()}: it belongs to another user"), messages


def test_symbolic_link_is_refused(sandbox, monkeypatch):
    target = sandbox / "target"
    target.mkdir(mode=0o700)
    link = sandbox / "link"
    link.symlink_to(target, target_is_directory=True)
    monkeypatch.setenv("CONTIN_CACHE_DIR", str(link))
    source = unique_source()
    plant_bytecode(target, source)
    module, messages = load(source)
    assert_not_from(module, link)
    assert_not_from(module, target)
    assert warned(messages, f"{link}: it is a symbolic link"), messages


def test_parent_writable_by_others_is_refused_unless_sticky(sandbox, monkeypatch):
    # a world-writable, non-sticky parent: anyone can rename our private directory away and put theirs
    shared = sandbox / "shared"
    shared.mkdir()
    shared.chmod(0o777)
    ours = shared / "kernels"
    ours.mkdir(mode=0o700)
    monkeypatch.setenv("CONTIN_CACHE_DIR", str(ours))
    source = unique_source()
    plant_bytecode(ours, source)
    module, messages = load(source)
    assert_not_from(module, ours)
    assert warned(messages, f"{ours}: {shared} is writable by group or others (mode 0777) and not sticky"), messages
    # sticky (like /tmp): others cannot rename or delete our entries, the directory is used
    shared.chmod(0o1777)
    source = unique_source()
    module = codegen.load_module(source)
    assert module.VALUE == "genuine" and Path(module.__file__).parent == ours


def test_fresh_directories_are_created_private(sandbox, monkeypatch):
    monkeypatch.setenv("CONTIN_CACHE_DIR", str(sandbox / "a/b/kernels"))
    old = os.umask(0o022)
    try:
        module = codegen.load_module(unique_source())
    finally:
        os.umask(old)
    assert Path(module.__file__).parent == sandbox / "a/b/kernels"
    for d in ("a", "a/b", "a/b/kernels"):
        assert stat.S_IMODE(os.lstat(sandbox / d).st_mode) == 0o700, d


def test_an_existing_private_directory_is_used_as_it_is(sandbox, monkeypatch):
    mine = sandbox / "mine"
    mine.mkdir()
    mine.chmod(0o755)  # readable by others is fine: they cannot change anything in it
    monkeypatch.setenv("CONTIN_CACHE_DIR", str(mine))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no warning for an acceptable directory
        module = codegen.load_module(unique_source())
    assert Path(module.__file__).parent == mine
    assert stat.S_IMODE(mine.stat().st_mode) == 0o755


def test_planted_numba_cache_in_the_temporary_fallback_does_not_run(sandbox):
    """The reported case: ``~/.cache`` unusable, ``$TMPDIR/contin-kernels-<uid>`` made beforehand by
    someone else (mode 0777) with the kernel file and a numba cache index that runs code when loaded."""
    (sandbox / "home/.cache").write_text("not a directory")
    source = unique_source("from numba import njit\n\n\n@njit(cache=True)\ndef bump(x):\n    return x + 1\n")
    name = codegen.module_name(source)
    # the index file name numba looks for: from the same file loaded elsewhere (nothing compiled)
    scratch = sandbox / "scratch"
    scratch.mkdir()
    (scratch / f"{name}.py").write_text(source)
    spec = importlib.util.spec_from_file_location(name, scratch / f"{name}.py")
    probe = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(probe)
    index_name = probe.bump._cache._cache_file._index_name

    planted = sandbox / f"tmp/contin-kernels-{os.geteuid()}"
    planted.mkdir()
    planted.chmod(0o777)
    (planted / f"{name}.py").write_text(source)
    (planted / "__pycache__").mkdir()
    marker = sandbox / "planted-code-ran"

    class Payload:
        def __reduce__(self):
            return os.mkdir, (str(marker),)

    (planted / "__pycache__" / index_name).write_bytes(pickle.dumps(Payload()))
    module, messages = load(source)
    assert module.bump(1) == 2
    assert not marker.exists(), "the planted numba cache index was loaded"
    assert module.__file__.startswith("<")  # no acceptable directory: compiled in memory
    assert type(module.bump._cache).__name__ == "NullCache"  # and numba's disk cache off
    assert warned(messages, f"{sandbox / 'home/.cache/contin/kernels'}: cannot create it"), messages
    assert warned(messages, f"{planted}: it is writable by group or others"), messages


def test_each_refused_directory_is_warned_about_once(sandbox, monkeypatch, recwarn):
    shared = sandbox / "shared"
    shared.mkdir()
    shared.chmod(0o777)
    monkeypatch.setenv("CONTIN_CACHE_DIR", str(shared))
    for _ in range(3):
        assert codegen.load_module(unique_source()).VALUE == "genuine"
    about = [w for w in recwarn if str(shared) in str(w.message)]
    assert len(about) == 1 and issubclass(about[0].category, ContinWarning)
    assert not list(shared.iterdir())

