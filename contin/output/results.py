"""Result files written as a run goes (SPEC 4.3).

``branches.csv`` and ``special_points.csv`` are appended row by row and
flushed, so a killed run leaves valid files holding every finished point;
``summary.json`` is replaced atomically (write to a temporary file, then
rename), so it is never seen half-written. Every file is written through
:mod:`contin.util.safe_files`: never through a symbolic link, replacing only
regular files, and a write error names its file.
"""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np

from contin.util.safe_files import append_stream, create_stream, open_regular, replace_file

__all__ = ["CsvStream", "write_json_atomic", "strict_json", "read_csv", "typed_columns", "format_value",
           "truncate_to_valid_rows"]


def format_value(v) -> str:
    """CSV text of a value: ``true``/``false`` for booleans, empty for None, repr-exact floats."""
    if v is None:
        return ""
    if isinstance(v, (bool, np.bool_)):
        return "true" if v else "false"
    if isinstance(v, (float, np.floating)):
        if not math.isfinite(v):
            raise ValueError(f"refusing to write a non-finite value ({v}) to a result file")
        return repr(float(v))
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    return str(v)


class CsvStream:
    """A table written row by row with a fixed header: to a CSV file, and held in memory.

    The rows are kept as the cells the file holds (:func:`format_value`), so
    :meth:`columns` gives exactly what :func:`read_csv` reads back from the
    file; without a ``path`` nothing is written (a run held in memory only).

    Parameters
    ----------
    path : Path or None
    columns : list of str
    append : bool
        Continue an existing file (its header must match; its rows are taken up).
    """

    def __init__(self, path: Path | None, columns: list[str], append: bool = False):
        self.path = None if path is None else Path(path)
        self.columns = list(columns)
        self.cells: list[list[str]] = []
        self._fh = None
        if self.path is None:
            self.rows = 0
            return
        exists = append and (self.path.exists() or self.path.is_symlink())
        if exists:
            with open_regular(self.path, newline="") as fh:
                rows = list(csv.reader(fh))
            exists = bool(rows)
            if exists and rows[0] != self.columns:
                raise ValueError(f"{self.path}: cannot resume, its columns differ from this run's")
            self.cells = rows[1:]
        # a new file is created exclusively, an existing one appended to only if it is a regular file (no link)
        self._fh = (append_stream if exists else create_stream)(self.path, newline="")
        self._w = csv.writer(self._fh)
        if not exists:
            self._w.writerow(self.columns)
            self._fh.flush()
        self.rows = len(self.cells)

    def write(self, row: dict) -> None:
        cells = [format_value(row.get(c)) for c in self.columns]
        if self._fh is not None:
            self._w.writerow(cells)
            self._fh.flush()
        self.cells.append(cells)
        self.rows += 1

    def table(self) -> dict[str, np.ndarray]:
        """The rows written (and taken up), as :func:`read_csv` reads the file."""
        return typed_columns(self.columns, self.cells)

    def close(self) -> None:
        if self._fh is not None and not self._fh.closed:
            try:
                self._fh.sync()
            finally:
                self._fh.close()


def write_json_atomic(path: Path, data) -> None:
    """Write strict JSON through a temporary file and an atomic rename (:func:`contin.util.safe_files.replace_file`).

    A value that is not finite (NaN, infinity), which JSON cannot hold, is written as ``null``.
    """
    text = json.dumps(strict_json(data), indent=2, default=_json_default, allow_nan=False)
    replace_file(path, lambda fh: fh.write(text))


def strict_json(data):
    """``data`` with every float that is not finite replaced by None (JSON's ``null``); numpy values as Python's."""
    if isinstance(data, dict):
        return {k: strict_json(v) for k, v in data.items()}
    if isinstance(data, (list, tuple)):
        return [strict_json(v) for v in data]
    if isinstance(data, np.ndarray):
        return strict_json(data.tolist())
    if isinstance(data, np.generic):
        data = data.item()
    if isinstance(data, float) and not math.isfinite(data):
        return None
    if isinstance(data, complex):
        return str(data)
    return data


def _json_default(o):
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, np.generic):
        return o.item()
    if hasattr(o, "value"):
        return o.value
    return str(o)


def read_csv(path: Path) -> dict[str, np.ndarray]:
    """Read a result CSV into columns (numbers as floats, ``true``/``false`` as bools, empty as NaN)."""
    with open_regular(path, newline="", follow=True) as fh:  # never a pipe or a device: a read that never ends
        rows = list(csv.reader(fh))
    if not rows:
        return {}
    return typed_columns(rows[0], rows[1:])


def typed_columns(header: list[str], body: list[list[str]]) -> dict[str, np.ndarray]:
    """Columns of CSV cells: numbers as floats, ``true``/``false`` as bools, empty as NaN, else strings."""
    out = {}
    for j, name in enumerate(header):
        col = [r[j] if j < len(r) else "" for r in body]
        if col and all(c in ("true", "false") for c in col):
            out[name] = np.array([c == "true" for c in col])
            continue
        try:
            out[name] = np.array([float(c) if c != "" else np.nan for c in col])
        except ValueError:
            out[name] = np.array(col, dtype=object)
    return out


def truncate_to_valid_rows(path: Path, max_rows: int | None = None) -> int:
    """Drop a last row cut short by a killed run (and rows beyond ``max_rows``); returns the data rows kept."""
    path = Path(path)
    if not path.exists() and not path.is_symlink():
        return 0
    with open_regular(path, newline="") as fh:
        text = fh.read()
    lines = text.splitlines(keepends=True)
    if not lines:
        return 0
    width = len(next(csv.reader([lines[0]])))
    keep = [lines[0]]
    for line in lines[1:]:
        if max_rows is not None and len(keep) > max_rows:
            break
        if not line.endswith("\n") or len(next(csv.reader([line]))) != width:
            break
        keep.append(line)
    if len(keep) != len(lines):
        replace_file(path, lambda fh: fh.writelines(keep), newline="")
    return len(keep) - 1
