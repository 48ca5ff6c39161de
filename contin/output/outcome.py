"""What a run computed, in memory: :class:`Outcome`, and :class:`Sink`, through which an analysis writes it.

An analysis writes its tables through the run's :class:`Sink`
(``ctx.sink.table("branches.csv", columns)``): into the result directory when
the run has one (row by row, flushed, so a killed run leaves valid files), and
always into memory. What it returns is an :class:`Outcome`: its part of
``summary.json``, its tables, its solutions' arrays and what it fell short of.
The runner completes it (the whole summary, the figures) and writes the files
of ``OUTDIR`` from it; the Python API wraps it directly (no directory, no file
read back), and :meth:`Outcome.from_directory` rebuilds the same object from a
result directory (``contin.load``).
"""

from __future__ import annotations

import csv
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

from contin.output.exports import RunData, collect_run, solutions_from_npz
from contin.output.results import CsvStream, read_csv
from contin.util.safe_files import replace_file

__all__ = ["EXPORTED", "Outcome", "Sink", "TABLE_SUFFIX"]

#: the tables of a result directory are the files with this suffix (their names are the keys of ``Outcome.tables``)
TABLE_SUFFIX = ".csv"
#: tables written from :attr:`Outcome.data` at the end of a run (exports), not by the analysis
EXPORTED = ("coefficients.csv",)


class Sink:
    """Where an analysis writes its tables and figures: a result directory, or memory only.

    Parameters
    ----------
    outdir : Path or None
        The run's result directory; None for a run held in memory (the Python API), which writes no file.
    """

    def __init__(self, outdir: Path | None):
        self.outdir = None if outdir is None else Path(outdir)
        self._tables: dict[str, CsvStream] = {}

    @property
    def writes(self) -> bool:
        """Whether files are written (a result directory)."""
        return self.outdir is not None

    def path(self, name: str) -> Path | None:
        """``OUTDIR/name``, or None when the run writes no files."""
        return None if self.outdir is None else self.outdir / name

    def table(self, name: str, columns: list[str], append: bool = False) -> CsvStream:
        """A table written row by row (``name``: its file's name, e.g. ``branches.csv``).

        ``append`` takes up the rows of the file an interrupted run left (``--resume``).
        """
        stream = CsvStream(self.path(name), columns, append and self.writes)
        self._tables[name] = stream
        return stream

    def tables(self) -> dict[str, dict]:
        """Every table written, by name: its columns as :func:`contin.output.results.read_csv` reads the file."""
        return {name: stream.table() for name, stream in self._tables.items()}

    def cells(self) -> dict[str, tuple]:
        """Every table written, by name: ``(header, rows of cells)`` as its file holds them."""
        return {name: (list(stream.columns), stream.cells) for name, stream in self._tables.items()}

    def close(self) -> None:
        for stream in self._tables.values():
            stream.close()


@dataclass
class Outcome:
    """What a run computed, in memory.

    Attributes
    ----------
    analysis : dict
        The analysis' part of ``summary.json`` (its branches with their
        statuses and messages, counts, settings).
    tables : dict of str to dict of str to ndarray
        Every table by its file's name (``branches.csv``, ...): its columns,
        numbers as floats, flags as bools, text as objects.
    data : RunData or None
        The solutions' arrays (``coefficients``, ``harmonics``, ...;
        :func:`contin.output.exports.collect_run`) of a run that stores
        solutions, else None.
    shortfalls : list of str
        What the run did not do that its scene asked (empty: ``complete``).
    summary : dict
        The whole ``summary.json`` (the scene, the model, versions, timings,
        the status), set by the runner.
    outdir : Path or None
        The result directory, None for a run held in memory.
    files : list of str
        The figures drawn (names in ``outdir``).
    draw : callable or None
        ``draw() -> list of file names``: the analysis' figures into
        ``outdir`` (not kept by :meth:`from_directory`).
    cells : dict
        Table name -> ``(header, rows of cells)`` as its file holds them
        (:meth:`write_tables`; empty for an outcome read from a directory,
        whose files hold them).
    """

    analysis: dict
    tables: dict = field(default_factory=dict)
    data: RunData | None = None
    shortfalls: list = field(default_factory=list)
    summary: dict = field(default_factory=dict)
    outdir: Path | None = None
    files: list = field(default_factory=list)
    draw: Callable | None = field(default=None, repr=False, compare=False)
    cells: dict = field(default_factory=dict, repr=False, compare=False)

    def write_tables(self, directory: str | Path) -> list[str]:
        """Write the tables as CSV files into ``directory`` (the cells as the run wrote them); their names."""
        names = []
        for name, (header, rows) in self.cells.items():
            def write(fh, header=header, rows=rows):
                w = csv.writer(fh)
                w.writerow(header)
                w.writerows(rows)

            replace_file(Path(directory) / name, write, newline="")
            names.append(name)
        return names

    @property
    def status(self) -> str:
        """``complete``, ``incomplete``, ``interrupted`` or ``failed`` (``summary.json``'s)."""
        return str(self.summary.get("status", "complete" if not self.shortfalls else "incomplete"))

    @classmethod
    def from_directory(cls, outdir: str | Path, expand=None) -> "Outcome":
        """The outcome a run wrote into ``outdir`` (its ``summary.json``, tables and stored solutions).

        ``expand``: what gives the full coefficients of condensed branches
        (:class:`contin.output.expansion.StoredExpansion`; without it such rows have no coefficients).
        """
        outdir = Path(outdir)
        summary = json.loads((outdir / "summary.json").read_text(encoding="utf-8"))
        tables = {p.name: read_csv(p) for p in sorted(outdir.glob("*" + TABLE_SUFFIX)) if p.name not in EXPORTED}
        if (outdir / "state.jsonl").is_file():
            data = collect_run(outdir, summary, expand)
        elif (outdir / "results.npz").is_file():  # saved from memory: its solutions are in the export
            data = solutions_from_npz(outdir / "results.npz", collect_run(outdir, summary))
        else:
            data = None
        analysis = summary.get("analysis") if isinstance(summary.get("analysis"), dict) else {}
        return cls(analysis=analysis, tables=tables, data=data, shortfalls=list(summary.get("shortfalls") or []),
                   summary=summary, outdir=outdir, files=list(summary.get("plots") or []))
