"""Result files written as a run goes (SPEC 4.3).

``branches.csv`` and ``special_points.csv`` are appended row by row and
flushed, so a killed run leaves valid files holding every finished point;
``summary.json`` is replaced atomically (write to a temporary file, then
rename), so it is never seen half-written.
"""

from __future__ import annotations

import csv
import json
import math
import os
from pathlib import Path

import numpy as np

__all__ = ["CsvStream", "write_json_atomic", "read_csv", "format_value", "truncate_to_valid_rows"]


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
    """A CSV file written row by row with a fixed header.

    Parameters
    ----------
    path : Path
    columns : list of str
    append : bool
        Continue an existing file (its header must match).
    """

    def __init__(self, path: Path, columns: list[str], append: bool = False):
        self.path = Path(path)
        self.columns = list(columns)
        exists = append and self.path.exists() and self.path.stat().st_size > 0
        if exists:
            with open(self.path, newline="", encoding="utf-8") as fh:
                header = next(csv.reader(fh), [])
            if header != self.columns:
                raise ValueError(f"{self.path}: cannot resume, its columns differ from this run's")
        self._fh = open(self.path, "a" if exists else "w", newline="", encoding="utf-8")
        self._w = csv.writer(self._fh)
        if not exists:
            self._w.writerow(self.columns)
            self._fh.flush()
        self.rows = 0

    def write(self, row: dict) -> None:
        self._w.writerow([format_value(row.get(c)) for c in self.columns])
        self._fh.flush()
        self.rows += 1

    def close(self) -> None:
        if not self._fh.closed:
            self._fh.flush()
            os.fsync(self._fh.fileno())
            self._fh.close()


def write_json_atomic(path: Path, data) -> None:
    """Write JSON through a temporary file and an atomic rename."""
    path = Path(path)
    tmp = path.with_name(path.name + ".tmp")
    with open(tmp, "w") as fh:
        json.dump(data, fh, indent=2, default=_json_default)
        fh.flush()
        os.fsync(fh.fileno())
    os.replace(tmp, path)


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
    with open(path, newline="") as fh:
        rows = list(csv.reader(fh))
    if not rows:
        return {}
    header, body = rows[0], rows[1:]
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
    if not path.exists():
        return 0
    with open(path, newline="", encoding="utf-8") as fh:
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
        tmp = path.with_name(path.name + ".tmp")
        with open(tmp, "w", newline="") as fh:
            fh.writelines(keep)
        os.replace(tmp, path)
    return len(keep) - 1
