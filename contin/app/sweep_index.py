"""The index of a parameter sweep: a summary of each finished point, ``sweep.csv``, and the progress lines.

:func:`summarize_point` reads a finished run directory into the summary
columns of ``sweep.csv`` (counts, special points, stable intervals per
subharmonic order); :class:`SweepIndex` writes ``sweep.csv`` atomically as
points finish; :func:`progress_line` is the line printed per finished point.
"""

from __future__ import annotations

import csv
import json
import math
import re
import time
from pathlib import Path
from typing import Any

from contin.analyses.intervals import SPECIAL_KINDS, stable_intervals
from contin.app.sweep_grid import GridPoint
from contin.output.results import format_value, read_csv
from contin.util.safe_files import replace_file

__all__ = ["INDEX_COLUMNS", "SUMMARY_COLUMNS", "SweepIndex", "progress_line", "summarize_point"]

#: the fixed leading columns of ``sweep.csv`` after ``point`` and the grid keys
INDEX_COLUMNS = ("status", "message", "reused", "run_seconds", "task_seconds", "started_at", "finished_at",
                 "worker")
#: summary columns that follow (then ``n_KIND``, ``KIND_at`` and ``stable_nuN...``)
SUMMARY_COLUMNS = ("rows", "branches", "branch_status", "parameter")


def _num(v: float) -> str:
    return repr(float(v))


def summarize_point(outdir: str | Path) -> dict:
    """The ``sweep.csv`` summary of a finished run directory.

    Returns
    -------
    dict
        ``rows`` and ``branches`` (counts), ``branch_status`` (the distinct
        branch end statuses), ``parameter`` (the continuation parameter), per
        kind in :data:`SPECIAL_KINDS` the count ``n_KIND`` and the located
        parameter values ``KIND_at`` (``;``-separated, in branch order), and
        per subharmonic order ``nu`` found: ``stable_nuN`` (the intervals of
        :func:`stable_intervals` as ``lo..hi;lo..hi``), ``stable_nuN_from``,
        ``stable_nuN_to`` (their hull) and ``stable_nuN_length`` (their total
        length). Analyses without branches give only what applies.
    """
    outdir = Path(outdir)
    out: dict[str, Any] = {}
    try:
        summary = json.loads((outdir / "summary.json").read_text())
    except (OSError, ValueError):
        return out
    analysis = summary.get("analysis") or {}
    branches = analysis.get("branches") if isinstance(analysis, dict) else None
    if isinstance(branches, list):
        out["branches"] = len(branches)
        out["branch_status"] = ";".join(dict.fromkeys(str(b.get("status")) for b in branches))
    if not (outdir / "branches.csv").exists():
        return out
    rows = read_csv(outdir / "branches.csv")
    special = read_csv(outdir / "special_points.csv") if (outdir / "special_points.csv").exists() else {}
    header = list(rows)
    parameter = analysis.get("parameter") if isinstance(analysis, dict) else None
    if parameter not in rows:
        parameter = header[2] if len(header) > 2 else None
    out["rows"] = len(rows.get("branch", []))
    out["parameter"] = parameter
    if parameter is None:
        return out
    kinds = list(special.get("kind", [])) if special else []
    for kind in SPECIAL_KINDS:
        vals = [float(v) for k, v in zip(kinds, special.get(parameter, [])) if k == kind] if kinds else []
        out[f"n_{kind}"] = len(vals)
        out[f"{kind}_at"] = ";".join(_num(v) for v in vals)
    for nu, iv in stable_intervals(rows, special, parameter).items():
        out[f"stable_nu{nu}"] = ";".join(f"{_num(a)}..{_num(b)}" for a, b in iv)
        out[f"stable_nu{nu}_from"] = iv[0][0] if iv else None
        out[f"stable_nu{nu}_to"] = iv[-1][1] if iv else None
        out[f"stable_nu{nu}_length"] = sum(b - a for a, b in iv) if iv else 0.0
    return out



class SweepIndex:
    """``sweep.csv``: written atomically whenever it changes (at most every ``interval`` s, and at the end)."""

    def __init__(self, path: Path, axes, points, interval: float = 1.0):
        self.path, self.axes, self.points = path, axes, points
        self.records: dict[int, dict] = {}
        self.interval, self._last = interval, 0.0

    def set(self, point: GridPoint, record: dict) -> None:
        self.records[point.index] = record
        now = time.monotonic()
        if now - self._last >= self.interval:
            self.write()

    def rows(self) -> list[dict]:
        out = []
        for p in self.points:
            r = self.records.get(p.index, {"status": "pending", "message": "not run yet"})
            row = {"point": p.name, **{k: v for k, v in p.values}}
            for c in INDEX_COLUMNS:
                row[c] = r.get(c)
            for k, v in (r.get("summary") or {}).items():
                row.setdefault(k, v)
            out.append(row)
        return out

    def columns(self, rows) -> list[str]:
        cols = ["point", *[a.key for a in self.axes], *INDEX_COLUMNS]
        extra: list[str] = []
        for kind in (*SUMMARY_COLUMNS, *(f"n_{k}" for k in SPECIAL_KINDS), *(f"{k}_at" for k in SPECIAL_KINDS)):
            if any(kind in r for r in rows):
                extra.append(kind)
        nus = sorted({int(m.group(1)) for r in rows for k in r for m in [re.fullmatch(r"stable_nu(\d+)", k)] if m})
        for nu in nus:
            extra += [f"stable_nu{nu}", f"stable_nu{nu}_from", f"stable_nu{nu}_to", f"stable_nu{nu}_length"]
        return cols + [c for c in extra if c not in cols]

    def write(self) -> Path:
        rows = self.rows()
        cols = self.columns(rows)

        def write(fh):
            w = csv.writer(fh)
            w.writerow(cols)
            for r in rows:
                w.writerow([_cell(r.get(c), format_value) for c in cols])

        replace_file(self.path, write, newline="")  # a random temporary file, renamed onto a regular file only
        self._last = time.monotonic()
        return self.path


def _cell(v, format_value) -> str:
    if isinstance(v, float) and not math.isfinite(v):
        return ""
    return format_value(v)


def progress_line(done: int, total: int, point: GridPoint, rec: dict) -> str:
    """The line printed when a point finishes: ``[done/total] label: status (seconds)`` and what it found."""
    w = len(str(total))
    secs = rec.get("task_seconds") or rec.get("run_seconds")
    head = f"[{done:>{w}}/{total}] {point.label}: {rec.get('status')}"
    if secs is not None:
        head += f" ({secs:.1f} s)"
    if rec.get("status") != "complete":
        msg = " ".join(str(rec.get("message", "")).split())
        return head + (f": {msg[:160]}" if msg else "")
    s = rec.get("summary") or {}
    bits = [f"{s['n_' + k]} {k}" for k in SPECIAL_KINDS if s.get("n_" + k)]
    return head + (", " + ", ".join(bits) if bits else "")
