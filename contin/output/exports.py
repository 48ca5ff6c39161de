"""Data files of a run beside its CSV tables: the harmonic coefficients of every point
(``coefficients.csv``), and the whole run in one file for numpy (``results.npz``) or
MATLAB and NLvib users (``results.mat``).

What each file holds is documented in ``docs/reference/results.md``; in short:

========================  ====================================================================
name                      content
========================  ====================================================================
``branches/<column>``     every column of ``branches.csv``, one entry per row
``special/<column>``      every column of ``special_points.csv``
``coefficients``          (rows, 2H+1, n): the matrix ``U`` of each row's harmonic coefficients
                          (row ``r`` of ``U`` is the coefficient block ``r`` of
                          :mod:`contin.hb.harmonics`: mean, then cosine and sine of each k);
                          ``H`` is the largest count of the run, rows of fewer are zero-padded
``harmonics``             (rows,): each row's own harmonic count
``coefficient_rows``      (rows,): the ``branches.csv`` row of each ``coefficients`` entry (the
                          periodic rows)
``base_frequency``        (rows,): the base frequency ``w/nu`` of each row (rad per time unit)
``torus_coefficients``    (rows_t, 2P-1, n): the coefficients of the quasi-periodic rows on the
                          harmonic pairs ``torus_pairs`` (P, 2) of :mod:`contin.hb.qp_basis`
                          (the largest truncation of the run, zero-padded); ``torus_rows``
                          their ``branches.csv`` rows, ``frequency2`` their second frequency
``dofs``, ``parameter``   the dof names, the continued parameter's name
``H``, ``status``         harmonics; the run's status
========================  ====================================================================

In ``results.mat`` the groups are structs (``branches.amp_x``), and stability
cells that hold no verdict are stored as -1 (1 stable, 0 unstable) in both
files, so no NaN is written.
"""

from __future__ import annotations

import csv
import json
import re
import zipfile
from pathlib import Path

import numpy as np

from contin.hb.qp_basis import QPBasis
from contin.output.checkpoint import read_records
from contin.output.expansion import stores_kept
from contin.output.formats import EXPORT_FORMATS
from contin.output.results import read_csv
from contin.util.safe_files import open_regular, replace_file

__all__ = ["EXPORT_FORMATS", "RunData", "collect_run", "write_exports", "write_coefficients_csv",
           "coefficient_names", "stability_code"]

#: columns that hold a stability verdict (true, false, or empty: none)
_FLAG_COLUMNS = ("stable", "located")


def stability_code(column: np.ndarray) -> np.ndarray:
    """A column of ``true``/``false``/empty cells as int8 1/0/-1 (-1: no verdict), so that no NaN is stored."""
    col = np.asarray(column)
    if col.dtype == bool:
        return col.astype(np.int8)
    if col.dtype.kind == "f":
        return np.where(np.isnan(col), -1, col != 0).astype(np.int8)
    return np.array([{"true": 1, "false": 0}.get(str(c).lower(), -1) for c in col], dtype=np.int8)


def coefficient_names(dofs, H: int) -> list[str]:
    """Column names of ``coefficients.csv``: ``a0_x``, then ``a1_x``, ``b1_x``, ... (block order, dofs inside)."""
    names = [f"a0_{d}" for d in dofs]
    for k in range(1, H + 1):
        names += [f"a{k}_{d}" for d in dofs] + [f"b{k}_{d}" for d in dofs]
    return names


class RunData(dict):
    """Everything :func:`collect_run` read from a result directory (a dict of numpy arrays and names)."""


def _table(cols: dict) -> dict:
    """A table's columns as the exports hold them: flags as codes, text as str, empty cells kept apart."""
    out = {}
    for name, col in cols.items():
        if name in _FLAG_COLUMNS:
            out[name] = stability_code(col)
        elif col.dtype == object:
            out[name] = np.array([str(c) for c in col], dtype=str)
        elif col.size and np.isnan(col).any():
            # an empty cell of a numeric column (no verdict, not computed): kept apart, never as NaN
            out[name] = np.where(np.isnan(col), 0.0, col)
            out[name + "_missing"] = np.isnan(col)
        else:
            out[name] = col
    return out


def collect_run(outdir: str | Path, summary: dict | None = None, expand=None) -> RunData:
    """Read a result directory's tables, summary and point coefficients into arrays (:func:`run_data`).

    Parameters
    ----------
    outdir : path
    summary : dict, optional
        The run's summary, when it is not yet written to ``summary.json``.
    expand : StoredExpansion, optional
        Gives the full coefficients of the rows of condensed branches, which
        ``state.jsonl`` holds for the kept dofs only
        (:class:`contin.output.expansion.StoredExpansion`); without it, a run
        with such rows has no ``coefficients``.
    """
    outdir = Path(outdir)
    tables = {name: read_csv(outdir / name) for name in ("branches.csv", "special_points.csv")
              if (outdir / name).is_file()}
    if summary is None and (outdir / "summary.json").is_file():
        summary = json.loads((outdir / "summary.json").read_text(encoding="utf-8"))
    path = outdir / "state.jsonl"
    points, headers = {}, {}
    if path.is_file():
        for rec in read_records(path):
            if rec.get("type", "point") == "point":
                points[int(rec["row"])] = rec  # a resumed run rewrites its last rows: the latest wins
            elif rec.get("type") == "branch":
                headers[int(rec["branch"])] = rec
        for r, rec in points.items():
            header = headers.get(int(rec["branch"]))
            if stores_kept(header):
                u = None if expand is None else expand(header, rec["u"], rec["lam"])
                if u is None:  # the kept dofs only, and nothing to expand them: left in state.jsonl
                    return run_data(tables, summary, {}, headers)
                points[r] = dict(rec, u=u)
    return run_data(tables, summary, points, headers)


def run_data(tables: dict, summary: dict | None, points: dict, headers: dict, parameter: str | None = None) -> RunData:
    """A run's tables, summary and point coefficients as arrays.

    Parameters
    ----------
    tables : dict
        ``branches.csv`` and ``special_points.csv`` by name, as columns (:func:`contin.output.results.read_csv`).
    summary : dict or None
    points : dict
        Row of ``branches.csv`` -> ``{"branch", "lam", "u", "H", "nu"}`` with ``u`` its full coefficients.
    headers : dict
        Branch id -> its branch record (``torus``: a quasi-periodic branch's discretisation).
    parameter : str, optional
        The continuation parameter (default: the summary's ``analysis.parameter``).

    Returns
    -------
    RunData
        Keys ``branches`` and ``special`` (dicts of column arrays), ``summary`` (dict),
        ``parameter`` (str or None), ``dofs`` (list of str), ``H`` (int or None), and when the
        run stored solutions: ``coefficients`` (rows, 2H+1, n),
        ``harmonics`` (rows,), ``coefficient_rows`` (rows,), ``nu`` (rows,), ``base_frequency`` (rows,).
    """
    data = RunData(branches=_table(tables.get("branches.csv", {})),
                   special=_table(tables.get("special_points.csv", {})))
    data["summary"] = summary = summary or {}
    analysis = summary.get("analysis") if isinstance(summary.get("analysis"), dict) else {}
    data["parameter"] = parameter if parameter is not None else analysis.get("parameter")
    data["dofs"] = list((summary.get("model") or {}).get("dofs") or [])
    data["H"] = None
    tori = {j: h["torus"] for j, h in headers.items() if h.get("torus") is not None}
    if not points:
        return data
    n = len(data["dofs"])
    # an invariant circle's rows hold its points, not coefficients (left in state.jsonl)
    balanced = {j: t for j, t in tori.items() if not t.get("circle")}
    torus_rows = sorted(r for r, p in points.items() if int(p["branch"]) in balanced)
    if torus_rows and n:
        _torus_coefficients(data, points, torus_rows, balanced, n)
    rows = sorted(r for r in points if int(points[r]["branch"]) not in tori)
    if not rows:
        return data
    Hs = [int(points[r].get("H") or 0) for r in rows]
    if n == 0 or any(len(points[r]["u"]) != n * (2 * h + 1) for r, h in zip(rows, Hs)):
        return data  # solutions of another form (a frequency among the unknowns): left in state.jsonl
    H = max(Hs)
    # a subharmonic branch has more harmonics of its lower base frequency: pad with zeros (exact)
    coefficients = np.zeros((len(rows), 2 * H + 1, n))
    for i, (r, h) in enumerate(zip(rows, Hs)):
        coefficients[i, :2 * h + 1] = np.reshape(points[r]["u"], (2 * h + 1, n))
    data["H"] = H
    data["coefficients"] = coefficients
    data["harmonics"] = np.array(Hs, dtype=np.int64)
    data["coefficient_rows"] = np.array(rows, dtype=np.int64)
    data["nu"] = np.array([int(points[r].get("nu") or 1) for r in rows], dtype=np.int64)
    data["base_frequency"] = _base_frequency(data, points, rows)
    return data


def _torus_coefficients(data: RunData, points: dict, rows: list, tori: dict, n: int) -> None:
    """The torus rows' coefficients on the pairs of the largest truncation (zeros where a branch has none)."""
    H1 = max(int(t["harmonics"]) for t in tori.values())
    H2 = max(int(t["harmonics2"]) for t in tori.values())
    big = QPBasis(H1, H2)
    out = np.zeros((len(rows), big.rows, n))
    for i, r in enumerate(rows):
        t = tori[int(points[r]["branch"])]
        own = QPBasis(int(t["harmonics"]), int(t["harmonics2"]))
        U = np.reshape(points[r]["u"][:-1], (own.rows, n))
        out[i, 0] = U[0]
        for j, (k1, k2) in enumerate(own.pairs[1:], start=1):
            J = big.pair(int(k1), int(k2))[0]
            out[i, 2 * J - 1], out[i, 2 * J] = U[2 * j - 1], U[2 * j]
    data["torus_coefficients"] = out
    data["torus_pairs"] = big.pairs.copy()
    data["torus_rows"] = np.array(rows, dtype=np.int64)
    data["frequency2"] = np.array([float(points[r]["u"][-1]) for r in rows])


def _base_frequency(data: RunData, points: dict, rows: list) -> np.ndarray:
    """``w/nu`` at each row: w is the continued parameter, or fixed in the scene's parameters."""
    summary = data["summary"]
    freq = (summary.get("model") or {}).get("frequency") or "w"
    nu = data["nu"].astype(float)
    if freq == data["parameter"]:
        return np.array([float(points[r]["lam"]) for r in rows]) / nu
    value = ((summary.get("model") or {}).get("parameters") or {}).get(freq, 1.0)
    return float(value) / nu


def write_coefficients_csv(outdir: str | Path, data: RunData | None = None) -> str | None:
    """``coefficients.csv``: per stored point its row, branch, nu, parameter, base frequency and
    coefficients (columns of :func:`coefficient_names`). Returns the file name, or None without solutions."""
    outdir = Path(outdir)
    data = collect_run(outdir) if data is None else data
    if "coefficients" not in data:
        return None
    branches = data["branches"]
    par = data["parameter"]
    names = coefficient_names(data["dofs"], data["H"])

    def write(fh):
        w = csv.writer(fh)
        w.writerow(["row", "branch", "nu", par or "parameter", "base_frequency"] + names)
        for i, r in enumerate(data["coefficient_rows"]):
            branch = int(branches["branch"][r]) if "branch" in branches and r < len(branches["branch"]) else 0
            lam = float(branches[par][r]) if par in branches and r < len(branches[par]) else 0.0
            w.writerow([int(r), branch, int(data["nu"][i]), repr(lam), repr(float(data["base_frequency"][i]))]
                       + [repr(float(v)) for v in data["coefficients"][i].ravel()])

    # a temporary file of a random name, made exclusively, renamed onto a regular file only
    replace_file(outdir / "coefficients.csv", write, newline="")
    return "coefficients.csv"


def _flat(data: RunData) -> dict:
    out = {f"branches/{k}": v for k, v in data["branches"].items()}
    out.update({f"special/{k}": v for k, v in data["special"].items()})
    for key in SOLUTION_KEYS:
        if key in data:
            out[key] = data[key]
    out["dofs"] = np.array(data["dofs"], dtype=str)
    out["parameter"] = np.array(data["parameter"] or "", dtype=str)
    out["H"] = np.array(-1 if data["H"] is None else data["H"], dtype=np.int64)
    out["status"] = np.array(str(data["summary"].get("status", "")), dtype=str)
    return out


#: the arrays of a run's solutions, as :func:`run_data` makes them and ``results.npz`` holds them
SOLUTION_KEYS = ("coefficients", "harmonics", "coefficient_rows", "nu", "base_frequency", "torus_coefficients",
                 "torus_pairs", "torus_rows", "frequency2")


def solutions_from_npz(path: str | Path, data: RunData) -> RunData:
    """``data`` with the solutions' arrays of a ``results.npz`` (a run whose checkpoint is not at hand:
    a result saved from memory); ``data`` itself when the file holds none or cannot be read."""
    try:
        with open_regular(Path(path), encoding=None, follow=True, limit=1 << 34) as fh, \
                np.load(fh, allow_pickle=False) as z:
            found = {k: z[k] for k in SOLUTION_KEYS if k in z.files}
            H = int(z["H"]) if "H" in z.files else -1
    except (OSError, ValueError, KeyError, zipfile.BadZipFile):
        return data
    if "coefficients" in found:
        data.update(found)
        data["H"] = H if H >= 0 else None
    return data


def _matlab_name(name: str) -> str:
    """A valid MATLAB identifier (letters, digits, underscores; a letter first; at most 63 characters)."""
    text = re.sub(r"\W", "_", name)
    if not text or not text[0].isalpha():
        text = "v_" + text
    return text[:63]


def write_exports(outdir: str | Path, formats=("npz",), summary: dict | None = None, expand=None,
                  data: RunData | None = None) -> list[str]:
    """Write ``coefficients.csv`` (when the run stored solutions) and ``results.<fmt>`` for each format.

    Parameters
    ----------
    outdir : path
        A result directory (read and written).
    formats : sequence of str
        Among :data:`EXPORT_FORMATS`.
    summary : dict, optional
        The run's summary (read from ``summary.json`` if omitted).
    expand : StoredExpansion, optional
        Full coefficients of condensed branches' rows (as :func:`collect_run`).
    data : RunData, optional
        The run's arrays as held in memory (:func:`run_data`): then nothing is read from ``outdir``.

    Returns
    -------
    list of str
        The file names written.
    """
    outdir = Path(outdir)
    data = collect_run(outdir, summary, expand) if data is None else data
    names = []
    name = write_coefficients_csv(outdir, data)
    if name:
        names.append(name)
    flat = _flat(data)
    for fmt in formats:
        if fmt not in EXPORT_FORMATS:
            raise ValueError(f"unknown export format {fmt!r}; expected one of {', '.join(EXPORT_FORMATS)}")
        path = outdir / f"results.{fmt}"
        if fmt == "npz":
            replace_file(path, lambda fh: np.savez_compressed(fh, **flat), binary=True)
        else:
            from scipy.io import savemat

            mat = {}
            for key, value in flat.items():
                group, _, field = key.rpartition("/")
                if group:
                    mat.setdefault(group, {})[_matlab_name(field)] = value
                else:
                    mat[_matlab_name(key)] = value
            replace_file(path, lambda fh: savemat(fh, mat, do_compression=True, oned_as="column"),  # noqa: B023
                         binary=True)
        names.append(path.name)
    return names
