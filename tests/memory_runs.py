"""A scene run in memory against the same scene run into a directory.

:func:`forbid_files` makes every way of creating a file or a directory raise
for the rest of a test; :func:`assert_tables_match` compares an outcome's
tables with ``read_csv`` of the files a directory run wrote: the same names,
columns, dtypes and values bit for bit (NaN equal to NaN).
"""

import builtins
import io
import os
import tempfile

import numpy as np

from contin.output.outcome import EXPORTED
from contin.output.results import read_csv


class FileCreated(AssertionError):
    """A run held in memory tried to create a file or a directory."""


def forbid_files(monkeypatch) -> None:
    """Make temporary files and directories, ``os.mkdir``, and opening a file for writing raise."""

    def refuse(name):
        def call(*args, **kwargs):
            raise FileCreated(f"{name}{args!r}")
        return call

    for name in ("mkdtemp", "mkstemp", "TemporaryDirectory", "NamedTemporaryFile", "TemporaryFile",
                 "SpooledTemporaryFile"):
        monkeypatch.setattr(tempfile, name, refuse(f"tempfile.{name}"))
    for name in ("mkdir", "makedirs"):
        monkeypatch.setattr(os, name, refuse(f"os.{name}"))
    real_open, real_os_open = builtins.open, os.open

    def open_(file, mode="r", *args, **kwargs):
        if any(c in mode for c in "wax+"):
            raise FileCreated(f"open({file!r}, {mode!r})")
        return real_open(file, mode, *args, **kwargs)

    def os_open(path, flags, *args, **kwargs):
        if flags & (os.O_WRONLY | os.O_RDWR | os.O_CREAT):
            raise FileCreated(f"os.open({path!r}, {flags})")
        return real_os_open(path, flags, *args, **kwargs)

    monkeypatch.setattr(builtins, "open", open_)
    monkeypatch.setattr(io, "open", open_)
    monkeypatch.setattr(os, "open", os_open)


def assert_same_column(name: str, got: np.ndarray, want: np.ndarray) -> None:
    """``got`` equals ``want``: the same dtype and the same values bit for bit (NaN equal to NaN)."""
    assert got.dtype == want.dtype, f"{name}: dtype {got.dtype}, the file's {want.dtype}"
    assert got.shape == want.shape, f"{name}: {got.shape} rows, the file's {want.shape}"
    if want.dtype == object:
        assert list(got) == list(want), name
    else:
        assert got.tobytes() == want.tobytes(), name


def assert_tables_match(tables: dict, outdir, skip=()) -> None:
    """Every table of ``tables`` is the CSV file of its name in ``outdir`` as ``read_csv`` reads it, and back.

    ``skip``: columns left out of the values compared (wall-clock times, which differ between two runs).
    """
    files = sorted(p.name for p in outdir.glob("*.csv") if p.name not in EXPORTED)  # exports: from the data
    assert sorted(tables) == files
    for name in files:
        want, got = read_csv(outdir / name), tables[name]
        assert list(got) == list(want), name
        for col in want:
            if col not in skip:
                assert_same_column(f"{name}:{col}", got[col], want[col])


def run_both_ways(scene, tmp_path, monkeypatch, skip=()):
    """``scene`` run into ``tmp_path / "d"``, then in memory with files forbidden (from an empty working
    directory); checks the in-memory run wrote nothing and holds the tables of the files. Returns both outcomes.

    The directory run comes first: it compiles the kernels (their cache is written then, not during the
    run held in memory).
    """
    from contin.app.runner import execute

    on_disk = execute(scene, tmp_path / "d", progress=False)
    assert_tables_match(on_disk.tables, tmp_path / "d", skip)
    forbid_files(monkeypatch)
    monkeypatch.chdir(tmp_path)
    held = execute(scene, None, progress=False)
    assert held.outdir is None and held.files == []
    assert sorted(p.name for p in tmp_path.iterdir()) == ["d"]
    assert_tables_match(held.tables, tmp_path / "d", skip)
    return on_disk, held
