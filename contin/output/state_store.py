"""The arrays of the run's checkpoint, in binary beside ``state.jsonl``.

``state.jsonl`` holds small records in strict JSON (:mod:`contin.output.checkpoint`);
an array of more than :data:`INLINE` numbers is not written there as a list of
numbers but as a reference to its bytes:

- ``state.bin``: every array of the points, special points, branch headers and
  branch ends, appended as the run goes (raw little-endian values, never
  rewritten). A record refers to one as ``{"__bin__": [offset, dtype, shape],
  "crc": crc32}``; an array equal to one written a moment before (the engine's
  tangent, its start and scales, stored again at every step) refers to the same
  bytes.
- ``state_last.npz``: what only the latest engine record needs: its state
  (the engine's step sizes, monitors and counters, as the bytes of a JSON
  object) and the arrays that change at every step (its point ``x`` and the
  one before, ``prev_x``, in the engine's scaled coordinates), replaced whole
  (:func:`contin.util.safe_files.replace_file`) at every step. It holds those
  of the last two engine records, so the engine record before the one being
  written still resolves when the run is killed between the two writes. A
  record refers to one as ``{"__last__": "a<crc32>n<size>"}``; an earlier
  engine record, whose state is no longer held, is not resumed from.

Order of the writes: the bytes of a record's arrays are flushed to
``state.bin`` (and ``state_last.npz`` replaced) before its JSON line is
written, so a run killed at any moment leaves either a whole record or a torn
last line (dropped on reading) and unreferenced bytes at the end of
``state.bin`` (left there; the next bytes are appended after them).
"""

from __future__ import annotations

import json
import math
import os
import zipfile
import zlib
from pathlib import Path

import numpy as np

from contin.util.safe_files import open_regular

__all__ = ["ARRAYS_NAME", "LAST_NAME", "INLINE", "VOLATILE", "ArrayReader", "CheckpointError", "TornRecord",
           "last_key", "little", "read_last"]

#: the append-only file of arrays, and the file of the engine's last positions (beside ``state.jsonl``)
ARRAYS_NAME = "state.bin"
LAST_NAME = "state_last.npz"
#: arrays of at most this many numbers (a complex one counts two) stay in the JSON line (a reference would be
#: about as long)
INLINE = 8
#: the engine state's arrays that change at every step and are needed for the last record only
VOLATILE = ("x", "prev_x")
#: the dtypes an array of the checkpoint has (floats, complex numbers, the engine's integer groups, flags)
_DTYPES = {np.dtype(t).newbyteorder("<").str for t in (np.float64, np.complex128, np.int64, np.int32, np.intp,
                                                         np.int8, np.uint8, bool)}


class CheckpointError(ValueError):
    """A line of a checkpoint that parses but is not a record contin writes."""


class TornRecord(Exception):
    """A record referring to bytes past the end of ``state.bin``: the run was killed while writing it."""


def little(a: np.ndarray) -> np.ndarray:
    """``a`` contiguous, little-endian (as ``state.bin`` holds it)."""
    a = np.ascontiguousarray(a)
    return a.astype(a.dtype.newbyteorder("<"), copy=False) if a.dtype.byteorder == ">" else a


def last_key(a: np.ndarray) -> str:
    """The name of ``a`` in ``state_last.npz``: its checksum and size."""
    return f"a{zlib.crc32(a.tobytes()):08x}n{a.size}"


def read_last(path: Path) -> dict:
    """The arrays of ``state_last.npz`` by key ({} when absent or not an archive contin wrote)."""
    if not path.exists():
        return {}
    try:
        with open_regular(path, encoding=None, follow=True, limit=1 << 30) as fh, \
                np.load(fh, allow_pickle=False) as z:
            out = {}
            for key in z.files:
                a = z[key]
                if a.ndim == 1 and a.dtype in (np.float64, np.uint8) and key == last_key(a):
                    out[key] = a
            return out
    except (OSError, ValueError, EOFError, zlib.error, KeyError, zipfile.BadZipFile):
        return {}  # its records are not resumed from (their engine record is stale)


def _json_object(a: np.ndarray, where: str) -> dict:
    """The JSON object whose bytes ``a`` holds (strict JSON, as contin writes it)."""
    def refuse(token):
        raise CheckpointError(f"{where}: strict JSON in {LAST_NAME}, found the token {token}")

    try:
        obj = json.loads(a.tobytes().decode("utf-8"), parse_constant=refuse)
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise CheckpointError(f"{where}: a JSON object in {LAST_NAME} ({exc})") from None
    if not isinstance(obj, dict):
        raise CheckpointError(f"{where}: a JSON object in {LAST_NAME}, found {type(obj).__name__}")
    return obj


class ArrayReader:
    """Resolves the array references of the records of a checkpoint (``state.bin``, ``state_last.npz``)."""

    def __init__(self, path: Path):
        self.path = Path(path).with_name(ARRAYS_NAME)
        self._fh = None
        self.size = 0
        self._last_path = Path(path).with_name(LAST_NAME)
        self._last = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        if self._fh is not None:
            self._fh.close()

    def _open(self):
        if self._fh is None:
            self._fh = open_regular(self.path, encoding=None, follow=True)
            self.size = os.fstat(self._fh.fileno()).st_size
        return self._fh

    def resolve(self, obj, where: str):
        """``obj`` with its references replaced by arrays; a ``__last__`` no longer held becomes None.

        Raises
        ------
        TornRecord
            A reference past the end of ``state.bin``.
        CheckpointError
            A reference that is not one contin writes, or bytes that do not match its checksum.
        """
        if isinstance(obj, list):
            return [self.resolve(v, where) for v in obj]
        if not isinstance(obj, dict):
            return obj
        if "__bin__" in obj:
            return self._array(obj, where)
        if "__last__" in obj:
            if self._last is None:
                self._last = read_last(self._last_path)
            a = self._last.get(obj["__last__"]) if isinstance(obj["__last__"], str) else None
            if a is not None and a.dtype == np.uint8:  # an engine state: a JSON object with references of its own
                return self.resolve(_json_object(a, where), where)
            return a
        return {k: self.resolve(v, where) for k, v in obj.items()}

    def _array(self, ref: dict, where: str) -> np.ndarray:
        spec, crc = ref.get("__bin__"), ref.get("crc")
        ok = (isinstance(spec, list) and len(spec) == 3 and isinstance(spec[0], int) and spec[0] >= 0
              and spec[1] in _DTYPES and isinstance(spec[2], list) and len(spec[2]) <= 2
              and all(isinstance(n, int) and 0 <= n < 1 << 40 for n in spec[2]) and isinstance(crc, int))
        if not ok:
            raise CheckpointError(f"{where}: an array reference {{\"__bin__\": [offset, dtype, shape], \"crc\": n}}, "
                                  f"found {json.dumps(ref)[:80]}")
        offset, dtype, shape = spec[0], np.dtype(spec[1]), tuple(spec[2])
        nbytes = math.prod(shape) * dtype.itemsize  # Python integers: a hostile shape does not wrap around
        try:
            fh = self._open()
        except FileNotFoundError:
            raise CheckpointError(f"{where}: its arrays in {self.path}, which is missing") from None
        if offset + nbytes > self.size:
            raise TornRecord(where)
        fh.seek(offset)
        data = fh.read(nbytes)
        if len(data) != nbytes or zlib.crc32(data) != crc:
            raise CheckpointError(f"{where}: the bytes {offset} to {offset + nbytes} of {self.path} do not match "
                                  "the checksum of the array they hold (the file was changed)")
        return np.frombuffer(data, dtype=dtype).reshape(shape).astype(dtype.newbyteorder("="))
