"""What an analysis returns in Python: :class:`Result`, its :class:`BranchResult` s and
:class:`LocatedPoint` s, made from the run's :class:`~contin.output.outcome.Outcome` as held
in memory (a call) or as written (``load("results/rotor")`` rebuilds the same object from
the files of ``contin run`` or of a call given ``outdir``)."""

from __future__ import annotations

import shutil
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from contin.api.plot import plot_result
from contin.app.pointplot import stored_expansion
from contin.output.exports import EXPORT_FORMATS, run_data, stability_code, write_exports
from contin.output.outcome import Outcome
from contin.output.plotting import branch_label
from contin.output.results import write_json_atomic

__all__ = ["Result", "BranchResult", "LocatedPoint", "load"]


@dataclass(frozen=True)
class LocatedPoint:
    """A special point of a branch (a row of ``special_points.csv``).

    Attributes
    ----------
    branch : int
    kind : str
        ``fold``, ``pd``, ``ns``, ``bp``, ``grazing``, ``kink``, ``end`` (backbones:
        ``frequency_min``, ``frequency_max``; static runs: their kinds).
    parameter : float
        The located parameter value.
    row : int
        Row of ``branches.csv`` nearest to it.
    interval : (float, float)
        Parameters of the two stored points bracketing it, increasing.
    located : bool
        Located to tolerance.
    detail : str
    measures : dict
        The measures at the point (``amp_x``, ...).
    """

    branch: int
    kind: str
    parameter: float
    row: int
    interval: tuple
    located: bool
    detail: str
    measures: dict = field(default_factory=dict, repr=False)


@dataclass(frozen=True)
class BranchResult:
    """One branch: its rows of ``branches.csv`` as arrays, its status and special points.

    Attributes
    ----------
    id : int
    nu : int
        ``1`` harmonic, ``nu`` for a ``1/nu`` subharmonic.
    status, message : str
        How the branch ended (``range_end``, ``closed_loop``, ``newton_failed``, ...).
    rows : ndarray of int, shape (P,)
        Its rows in ``branches.csv``.
    parameter : ndarray, shape (P,)
    stable : ndarray of int8, shape (P,), or None
        1 stable, 0 unstable, -1 no verdict; None when stability was not computed.
    columns : dict of str to ndarray (P,)
        Every column of its rows.
    special_points : list of LocatedPoint
    torus : bool
        A quasi-periodic branch (columns ``frequency2``, ``forced_``, ``free_``, ``comb_``).
    """

    id: int
    nu: int
    status: str
    message: str
    rows: np.ndarray = field(repr=False)
    parameter: np.ndarray = field(repr=False)
    stable: np.ndarray | None = field(repr=False)
    columns: dict = field(repr=False)
    special_points: list = field(default_factory=list, repr=False)
    torus: bool = False

    @property
    def name(self) -> str:
        return "quasi-periodic" if self.torus else branch_label(self.nu)

    def __getitem__(self, column: str) -> np.ndarray:
        try:
            return self.columns[column]
        except KeyError:
            raise KeyError(f"no column {column!r}; the columns are {', '.join(self.columns)}") from None

    def __len__(self) -> int:
        return len(self.rows)


class Result:
    """The outcome of one analysis: tables, branches, special points, coefficients, figures, files.

    Attributes
    ----------
    outcome : Outcome
        What the run computed (:class:`contin.output.outcome.Outcome`).
    outdir : Path or None
        The result directory, None for a run held in memory (a call without ``outdir``).
    summary : dict
        ``summary.json``.
    status : str
        ``complete``, ``incomplete`` (see :attr:`message`) or ``interrupted``.
    analysis : str
        The ``analysis.type``.
    parameter : str or None
        The continued parameter.
    dofs : tuple of str
    tables : dict of str to dict
        Every table of the run by file stem (``branches``, ``special_points``, ``modes``, ``frf``, ...),
        each a dict of column arrays.
    branches : list of BranchResult
    special_points : list of LocatedPoint
    """

    def __init__(self, outcome: Outcome):
        if not isinstance(outcome, Outcome):
            raise TypeError(f"Result(outcome): an Outcome, not {type(outcome).__name__} (contin.load(outdir) "
                            "reads a result directory)")
        self.outcome = outcome
        self.outdir = outcome.outdir
        self.summary = outcome.summary
        self.status = self.summary.get("status", "")
        self.message = self.summary.get("message", "")
        scene = self.summary.get("scene") or {}
        self.scene = scene
        self.analysis = (scene.get("analysis") or {}).get("type", "")
        analysis = outcome.analysis if isinstance(outcome.analysis, dict) else {}
        self.parameter = analysis.get("parameter") or (scene.get("analysis") or {}).get("parameter")
        self.dofs = tuple((self.summary.get("model") or {}).get("dofs") or ())
        self.tables = {Path(name).stem: cols for name, cols in outcome.tables.items()}
        self.special_points = self._special_points()
        self.branches = self._branches(analysis)

    # ------------------------------------------------------------ reading
    def _special_points(self) -> list:
        sp = self.tables.get("special_points", {})
        out = []
        fixed = {"branch", "kind", "index", "interval_lo", "interval_hi", "located", "detail", self.parameter}
        for r in range(len(sp.get("kind", []))):
            out.append(LocatedPoint(
                branch=int(sp["branch"][r]) if "branch" in sp else 0, kind=str(sp["kind"][r]),
                parameter=float(sp[self.parameter][r]) if self.parameter in sp else float("nan"),
                row=int(sp["index"][r]) if "index" in sp else -1,
                interval=(float(sp["interval_lo"][r]), float(sp["interval_hi"][r])) if "interval_lo" in sp else (),
                located=bool(sp["located"][r]) if "located" in sp else True,
                detail=str(sp["detail"][r]) if "detail" in sp else "",
                measures={k: v[r] for k, v in sp.items() if k not in fixed}))
        return out

    def _branches(self, analysis: dict) -> list:
        table = self.tables.get("branches")
        if not table or "branch" not in table:
            return []
        info = {int(b["branch"]): b for b in analysis.get("branches", []) if isinstance(b, dict) and "branch" in b}
        ids = table["branch"].astype(int)
        out = []
        for bid in sorted(set(ids.tolist())):
            rows = np.flatnonzero(ids == bid)
            cols = {k: v[rows] for k, v in table.items()}
            stable = None
            if "stable" in table:
                stable = stability_code(table["stable"][rows])
            b = info.get(bid, {})
            nu = int(cols["nu"][0]) if "nu" in cols else int(b.get("nu", 1))
            out.append(BranchResult(
                id=bid, nu=nu, status=str(b.get("status", "")), message=str(b.get("message", "")), rows=rows,
                parameter=cols.get(self.parameter, np.arange(len(rows), dtype=float)), stable=stable, columns=cols,
                special_points=[s for s in self.special_points if s.branch == bid],
                torus=b.get("torus") is not None))
        return out

    @property
    def data(self) -> dict:
        """Every array of the run (:func:`contin.output.exports.run_data`): its tables and stored solutions."""
        if self.outcome.data is None:
            tables = {n: c for n, c in self.outcome.tables.items() if n in ("branches.csv", "special_points.csv")}
            self.outcome.data = run_data(tables, self.summary, {}, {})
        return self.outcome.data

    # ------------------------------------------------------------ access
    @property
    def columns(self) -> dict:
        """The main table's columns (``branches.csv``, else the run's first table)."""
        if "branches" in self.tables:
            return self.tables["branches"]
        return next(iter(self.tables.values()), {})

    def __getitem__(self, column: str) -> np.ndarray:
        try:
            return self.columns[column]
        except KeyError:
            raise KeyError(f"no column {column!r}; the columns are {', '.join(self.columns)}") from None

    def to_dataframe(self, table: str | None = None):
        """A table as a ``pandas.DataFrame`` (``branches`` by default; any stem of :attr:`tables`).

        pandas is optional: ``pip install pandas``.
        """
        try:
            import pandas as pd
        except ImportError:
            raise ImportError("Result.to_dataframe needs pandas, which contin does not require: "
                              "pip install pandas (the same data: Result.tables, Result.columns)") from None
        name = table or ("branches" if "branches" in self.tables else next(iter(self.tables), None))
        if name not in self.tables:
            raise KeyError(f"no table {name!r}; the tables are {', '.join(self.tables) or 'none'}")
        return pd.DataFrame(self.tables[name])

    def coefficients(self, row: int | None = None) -> np.ndarray:
        """Harmonic coefficients of the point in ``branches.csv`` row ``row`` (all rows if None).

        Returns
        -------
        ndarray, shape (2H+1, n) or (rows, 2H+1, n)
            Row ``r`` of a point's matrix is the coefficient block ``r`` of
            :mod:`contin.hb.harmonics`: the mean, then the cosine and the sine of each harmonic
            ``k = 1..H`` of the base frequency ``w/nu``; columns follow :attr:`dofs`.
        """
        data = self.data
        if row is not None and "torus_rows" in data and int(row) in data["torus_rows"]:
            raise IndexError(f"row {row} is a quasi-periodic point: its coefficients are on harmonic pairs, in "
                             "data['torus_coefficients'] (pairs data['torus_pairs']; contin.hb.qp_basis)")
        if "coefficients" not in data:
            raise ValueError(f"this {self.analysis or 'run'} stored no harmonic coefficients "
                             "(frequency_response and bifurcation_curve runs do)")
        if row is None:
            return data["coefficients"]
        where = np.flatnonzero(data["coefficient_rows"] == int(row))
        if where.size == 0:
            raise IndexError(f"row {row} has no stored coefficients (rows 0..{data['coefficient_rows'].max()})")
        return data["coefficients"][where[0]]

    def time_history(self, row: int, samples: int = 256, periods: float = 1.0):
        """The periodic solution of row ``row`` in time, from its harmonic coefficients.

        Parameters
        ----------
        row : int
            Row of ``branches.csv``.
        samples : int
            Time samples per period.
        periods : float
            Periods ``T = 2 pi nu / w`` to cover.

        Returns
        -------
        t : ndarray, shape (N,)
        x : ndarray, shape (N, n)
            Displacements; columns follow :attr:`dofs`.
        xdot : ndarray, shape (N, n)
            Velocities.
        """
        U = self.coefficients(row)
        i = int(np.flatnonzero(self.data["coefficient_rows"] == int(row))[0])
        omega = float(self.data["base_frequency"][i])
        H = (U.shape[0] - 1) // 2
        n_t = max(int(round(samples * periods)), 2)
        theta = np.linspace(0.0, 2.0 * np.pi * periods, n_t, endpoint=False)
        k = np.arange(1, H + 1)
        c, s = np.cos(np.outer(theta, k)), np.sin(np.outer(theta, k))
        a, b = U[1::2], U[2::2]  # (H, n) cosine and sine blocks
        x = U[0] + c @ a + s @ b
        xdot = omega * (-(s * k) @ a + (c * k) @ b)
        return theta / omega, x, xdot

    # ------------------------------------------------------------ figures and files
    def plot(self, ax=None, measure: str | None = None, *, table: bool | None = None, **options):
        """Draw the run's diagram into ``ax`` (a new pyplot figure if None) with the user's backend.

        Everything drawn into a given ``ax`` stays inside it (the legend too), so the figure's own
        layout, ``tight_layout()`` included, keeps its size.

        Parameters
        ----------
        ax : matplotlib Axes, optional
        measure : str, optional
            A column of ``branches.csv`` (the scene's ``output.measure`` by default).
        table : bool, optional
            Number the special points and list them in a table right of the axes. By default only
            without ``ax`` (a new figure with ``constrained`` layout, which makes room for it); in a
            given ``ax`` the points are marked and their kinds named in the legend. With ``table=True``
            in your own axes, give the figure a layout that makes room (``layout="constrained"``).
        **options
            Passed to :func:`contin.output.plotting.draw_bifurcation_diagram`.

        Returns
        -------
        Axes
        """
        return plot_result(self, ax, measure, table=table, **options)

    def save(self, path: str | Path, exports=EXPORT_FORMATS) -> Path:
        """Write the run's files into the directory ``path``: its tables, ``summary.json`` and the ``exports``.

        Parameters
        ----------
        path : path
            A directory (made if missing; files of the same names are replaced).
        exports : sequence of str
            Among ``npz``, ``mat``.

        Returns
        -------
        Path
        """
        path = Path(path)
        path.mkdir(parents=True, exist_ok=True)
        if self.outdir is not None and path.resolve() != self.outdir.resolve():
            for item in self.outdir.iterdir():
                target = path / item.name
                if item.is_dir():
                    shutil.copytree(item, target, dirs_exist_ok=True)
                elif not item.name.startswith("."):  # the directory's lock stays its own
                    shutil.copy2(item, target)
        elif self.outdir is None:
            self.outcome.write_tables(path)
            write_json_atomic(path / "summary.json", self.summary)
        write_exports(path, exports, self.summary, data=self.data)
        return path

    @property
    def files(self) -> list[str]:
        """The files of :attr:`outdir` (none for a run held in memory)."""
        return [] if self.outdir is None else sorted(p.name for p in self.outdir.iterdir())

    def __repr__(self) -> str:
        parts = [f"{self.analysis or 'run'}: {self.status}"]
        if self.branches:
            parts.append(", ".join(f"branch {b.id} ({b.name}): {len(b)} points, {b.status}" for b in self.branches))
        if self.special_points:
            kinds: dict = {}
            for s in self.special_points:
                n, lost = kinds.get(s.kind, (0, 0))
                kinds[s.kind] = (n + 1, lost + (not s.located))
            # a point whose location did not converge is only bracketed: said so, not counted as found
            parts.append("special points: " + ", ".join(f"{n} {k}" + (f" ({lost} not located)" if lost else "")
                                                        for k, (n, lost) in kinds.items()))
        if self.message:
            parts.append(self.message)
        return "<Result " + "; ".join(parts) + ">"


def load(outdir: str | Path) -> Result:
    """The :class:`Result` of a result directory written by ``contin run`` or by a call of this API."""
    outdir = Path(outdir)
    if not (outdir / "summary.json").is_file():
        raise FileNotFoundError(f"{outdir}: no summary.json; not a contin result directory")
    return Result(Outcome.from_directory(outdir, stored_expansion(outdir)))
