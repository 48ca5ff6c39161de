"""Writing the run's checkpoint: ``state.jsonl`` and its arrays (:mod:`contin.output.state_store`)."""

from __future__ import annotations

import collections
import json
import os
import zlib
from pathlib import Path

import numpy as np

from contin.output.checkpoint import encode
from contin.output.state_store import ARRAYS_NAME, INLINE, LAST_NAME, VOLATILE, last_key, little, read_last
from contin.util.safe_files import append_stream, create_stream, replace_file

__all__ = ["StateWriter"]

#: arrays remembered to be referred to again instead of written again
_REMEMBERED = 16


class StateWriter:
    """Writes the records of ``state.jsonl`` and their arrays (``state.bin``, ``state_last.npz``).

    Parameters
    ----------
    path : Path
        ``OUTDIR/state.jsonl``.
    append : bool
        Go on with the files of an interrupted run (``--resume``), else start them anew.
    """

    def __init__(self, path, append: bool = False):
        self.path = Path(path)
        opener = append_stream if append else create_stream
        self.arrays = opener(self.path.with_name(ARRAYS_NAME), binary=True)
        self.offset = os.fstat(self.arrays.fileno()).st_size  # after a torn record's bytes, if any
        self.lines = opener(self.path)
        self._known: collections.OrderedDict = collections.OrderedDict()  # (dtype, shape, crc) -> (array, ref)
        self._last: dict = read_last(self.path.with_name(LAST_NAME)) if append else {}

    @property
    def name(self) -> str:
        return str(self.path)

    def _store(self, a: np.ndarray) -> dict:
        """The reference of ``a`` in ``state.bin`` (written unless the same array was a moment before)."""
        a = little(a)
        crc = zlib.crc32(a.tobytes())
        key = (a.dtype.str, a.shape, crc)
        hit = self._known.get(key)
        if hit is not None and hit[0].tobytes() == a.tobytes():  # the same bits (-0.0 is not 0.0 here)
            self._known.move_to_end(key)
            return hit[1]
        ref = {"__bin__": [self.offset, a.dtype.str, list(a.shape)], "crc": crc}
        self.arrays.write(a.tobytes())
        self.offset += a.nbytes
        self._known[key] = (a.copy(), ref)
        while len(self._known) > _REMEMBERED:
            self._known.popitem(last=False)
        return ref

    def _encode(self, record: dict) -> str:
        return json.dumps(encode(record, store=self._store), allow_nan=False) + "\n"

    def write(self, record: dict) -> None:
        """Append ``record``: numpy values as they are, encoded by :func:`contin.output.checkpoint.encode`."""
        line = self._encode(record)
        self.arrays.flush()  # the bytes before the line that refers to them
        self.lines.write(line)
        self.lines.flush()

    def engine(self, record: dict) -> None:
        """Append an engine record: its state in ``state_last.npz`` (JSON, its :data:`VOLATILE` arrays beside it,
        its other arrays in ``state.bin``); the line refers to it.

        Only the last engine record of a run is resumed from, so ``state_last.npz`` holds those of the last two
        records (the one before still resolves when the run is killed between the two writes) and the
        ``state.jsonl`` lines of the earlier ones resolve to nothing (``stale``).
        """
        state = dict(record["state"])
        current = {}
        for name in VOLATILE:
            if isinstance(state.get(name), np.ndarray) and state[name].size > INLINE:
                a = little(np.asarray(state[name], dtype=float))
                key = last_key(a)
                current[key] = a
                state[name] = {"__last__": key}
        text = json.dumps(encode(state, store=self._store), allow_nan=False).encode("utf-8")
        blob = np.frombuffer(text, dtype=np.uint8)
        key = last_key(blob)
        current[key] = blob
        line = json.dumps(encode(dict(record, state={"__last__": key})), allow_nan=False) + "\n"
        self.arrays.flush()
        keep = {**self._last, **current}  # this record's and the one before's: either may be the last read
        replace_file(self.path.with_name(LAST_NAME), lambda fh: np.savez(fh, **keep), binary=True, sync=False)
        self._last = current
        self.lines.write(line)
        self.lines.flush()

    def flush(self) -> None:
        self.arrays.flush()
        self.lines.flush()

    def close(self) -> None:
        self.arrays.close()
        self.lines.close()
