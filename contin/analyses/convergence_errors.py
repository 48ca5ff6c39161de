"""``convergence``: the error measures of a convergence study: the quantities of one run, their errors, the budget.

:func:`extract` reads the quantities of interest (``peak``, ``fold`` and
``special``, ``stable_interval``, ``value`` and ``static_deflection``) from
one run's tables; :func:`quantity_error` is a quantity's error against the
reference (relative or absolute); :func:`recommend` picks the cheapest
setting within an error budget; :func:`read_records` and
:func:`format_table` read and print the study's table.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np

from contin.analyses.convergence_plan import quantity_items
from contin.analyses.intervals import stable_intervals

__all__ = ["Missing", "extract", "format_table", "quantity_error", "read_records", "recommend", "TIME_TIE"]

#: relative difference of two timings below which the budget counts them as equal
TIME_TIE = 0.05


class Missing(Exception):
    """A quantity a run did not produce (its reason is the message)."""


def _branch_rows(rows: dict, q: dict) -> np.ndarray:
    n = len(next(iter(rows.values()))) if rows else 0
    sel = np.ones(n, bool)
    if q.get("branch") is not None and "branch" in rows:
        sel &= np.asarray(rows["branch"]) == q["branch"]
    if q.get("nu") is not None and "nu" in rows:
        sel &= np.asarray(rows["nu"]) == q["nu"]
    return np.flatnonzero(sel)


def _column(table: dict, name: str, what: str, file: str):
    if name not in table:
        raise KeyError(f"{what} '{name}' is not a column of {file} ({', '.join(list(table)[:40])})")
    col = table[name]
    if col.dtype.kind not in "fb":
        raise KeyError(f"{what} '{name}' is not a numeric column of {file}")
    return col.astype(float)


def _peak(rows, q, measure, param, file):
    m = _column(rows, measure, "measure", file)
    idx = _branch_rows(rows, q)
    idx = idx[np.isfinite(m[idx])] if len(idx) else idx
    if len(idx) == 0:
        raise Missing("no rows on the selected branches")
    i = int(idx[np.argmax(m[idx])])
    best = float(m[i])
    if not q["refine"]:
        return best
    b = rows["branch"] if "branch" in rows else np.zeros(len(m))
    if 0 < i < len(m) - 1 and b[i - 1] == b[i] == b[i + 1]:
        p = _column(rows, param, "parameter", file)
        pts = [(p[j], m[j]) for j in (i - 1, i, i + 1)]
        sp = max(np.ptp(p[b == b[i]]), 1e-300)
        sm = max(np.ptp(m[b == b[i]]), 1e-300)
        s = [0.0]
        for (pa, ma), (pb, mb) in zip(pts[:-1], pts[1:]):
            s.append(s[-1] + math.hypot((pb - pa) / sp, (mb - ma) / sm))
        if s[1] > 0 and s[2] > s[1]:
            c = np.polyfit(s, [v for _, v in pts], 2)
            if c[0] < 0:
                sv = -c[1] / (2 * c[0])
                if s[0] <= sv <= s[2]:
                    best = max(best, float(np.polyval(c, sv)))
    return best


def _fold(rows, special, q, param, file):
    kind = q.get("kind", "fold")
    kinds = list(special.get("kind", [])) if special else []
    what = q["of"] or param
    if not kinds:
        raise Missing("no special points")
    col = _column(special, what, "column", "special_points.csv")
    br = np.asarray(special["branch"])
    keep = [j for j, k in enumerate(kinds) if k == kind]
    if q["branch"] is not None:
        keep = [j for j in keep if br[j] == q["branch"]]
    if q["nu"] is not None:
        nu_of = {int(b): int(n) for b, n in zip(rows["branch"], rows["nu"])}
        keep = [j for j in keep if nu_of.get(int(br[j])) == q["nu"]]
    if not keep:
        raise Missing(f"no {kind} found")
    if q["near"] is not None:
        pv = _column(special, param, "parameter", "special_points.csv")
        j = min(keep, key=lambda j: abs(pv[j] - q["near"]))
        if q["window"] is not None and abs(pv[j] - q["near"]) > q["window"]:
            raise Missing(f"no {kind} within {q['window']:g} of {q['near']:g} (nearest at {pv[j]:.6g})")
        return float(col[j])
    if q["index"] >= len(keep):
        raise Missing(f"{kind} {q['index']} asked, {len(keep)} found")
    return float(col[keep[q["index"]]])


def _stable_interval(rows, special, q, param, file):
    if "stable" not in rows or rows["stable"].dtype != bool:
        raise Missing("no stability in the results")
    rows = dict(rows)
    if q["measure"] is not None and q["min"] is not None:
        m = _column(rows, q["measure"], "measure", file)
        rows["stable"] = rows["stable"] & (m > q["min"])
    iv = stable_intervals(rows, special, param).get(q["nu"], [])
    if not iv:
        raise Missing(f"no stable nu={q['nu']} solution")
    lo, hi = iv[0][0], iv[-1][1]
    return [{"from": lo, "to": hi, "length": sum(b - a for a, b in iv)}[e] for e in q["ends"]]


def _value(rows, q, measure, param, file):
    m = _column(rows, measure, "measure", file)
    p = _column(rows, param, "parameter", file)
    idx = np.flatnonzero(np.asarray(rows["branch"]) == q["branch"]) if "branch" in rows else np.arange(len(m))
    if len(idx) == 0:
        raise Missing(f"no branch {q['branch']}")
    at = q["at"]
    for a, b in zip(idx[:-1], idx[1:]):
        if p[a] == at:
            return float(m[a])
        if (p[a] - at) * (p[b] - at) < 0:
            t = (at - p[a]) / (p[b] - p[a])
            return float(m[a] + t * (m[b] - m[a]))
    if p[idx[-1]] == at:
        return float(m[idx[-1]])
    raise Missing(f"branch {q['branch']} does not reach {param} = {at:g}")


def extract(tables: dict, quantities: list[dict], defaults: dict, table_file: str,
            strict: bool = False) -> tuple[dict, dict]:
    """Values of the quantities in the tables of one run.

    Parameters
    ----------
    tables : dict
        The tables of a finished run of the base analysis, by file name
        (:attr:`contin.output.outcome.Outcome.tables`: what
        :func:`contin.output.results.read_csv` reads from its files).
    quantities : list of dict
        Checked quantities (:func:`normalize_quantity`).
    defaults : dict
        ``parameter``, ``measure`` and ``static_measure`` of the base run.
    table_file : str
        ``branches.csv`` or ``simulation.csv``.
    strict : bool
        Raise ``KeyError`` for a named column the results do not have;
        else such a quantity is missing at this run.

    Returns
    -------
    values : dict
        Column -> float for the quantities found.
    missing : dict
        Column -> reason for the others.

    Raises
    ------
    KeyError
        With ``strict``, a named column that the results do not have.
    """
    rows = tables.get(table_file) or {}
    special = tables.get("special_points.csv") or {}
    values, missing = {}, {}
    for q in quantities:
        cols = [c for c, _ in quantity_items(q, defaults)]
        param = q.get("parameter") or defaults["parameter"]
        try:
            if not rows or len(next(iter(rows.values()))) == 0:
                raise Missing(f"no rows in {table_file}")
            t = q["type"]
            if t == "peak":
                got = [_peak(rows, q, q["measure"] or defaults["measure"], param, table_file)]
            elif t in ("fold", "special"):
                got = [_fold(rows, special, q, param, table_file)]
            elif t == "stable_interval":
                got = _stable_interval(rows, special, q, param, table_file)
            else:
                got = [_value(rows, q, q["measure"] or defaults["static_measure"], param, table_file)]
            values.update(zip(cols, got))
        except Missing as exc:
            missing.update({c: str(exc) for c in cols})
        except KeyError as exc:
            if strict:
                raise
            missing.update({c: exc.args[0] for c in cols})
    return values, missing


# ---------------------------------------------------------------- errors, budget, table
def quantity_error(v, ref, kind):
    """``v``'s error against the reference's ``ref`` (``kind``: relative or absolute); None if either is None."""
    if v is None or ref is None:
        return None
    d = abs(v - ref)
    if kind == "relative":
        return d / abs(ref) if ref != 0 else (0.0 if d == 0 else math.inf)
    return d


def recommend(records: list[dict], columns: list[str], budget: float, cost: str = "wall_time") -> dict:
    """The cheapest setting whose errors of all quantities are at most ``budget``.

    Timings within :data:`TIME_TIE` (5 %) of the fastest passing one count as
    equal (timing noise); among those the first in ``records`` (the coarsest
    setting, as listed) is recommended.

    Parameters
    ----------
    records : list of dict
        Rows of ``convergence.csv`` as dicts (``setting``, ``reference``,
        ``wall_time``, ``<column>_error``).
    columns : list of str
        The quantity columns.
    budget : float
    cost : str
        ``wall_time`` or ``cpu_time``: the column that decides which setting is cheapest.

    Returns
    -------
    dict
        ``budget``, ``setting`` (label or None), the cost (``wall_time`` or
        ``cpu_time``) of that setting, ``max_error``,
        ``message`` (one sentence saying what was found, or that no setting
        reaches the budget and which came closest).
    """
    cands = [r for r in records if not r.get("reference") and r.get("status") == "complete"]
    passing, best = [], None
    for r in cands:
        errs = [r.get(f"{c}_error") for c in columns]
        if any(e is None or (isinstance(e, float) and math.isnan(e)) for e in errs):
            continue
        worst = max(errs)
        if best is None or worst < best[1]:
            best = (r, worst)
        if worst <= budget:
            passing.append((r[cost], r, worst))
    if passing:
        fastest = min(t for t, _, _ in passing)
        # timings within TIME_TIE of the fastest are equal within their noise: the first listed (coarsest) wins
        t, r, worst = next(p for p in passing if p[0] <= (1 + TIME_TIE) * fastest)
        tie = "" if t == fastest else f"; within {TIME_TIE:.0%} of the fastest, {fastest:.3g} s, so equal in cost"
        return {"budget": budget, "setting": r["setting"], cost: t, "max_error": worst,
                "message": f"cheapest setting with every error <= {budget:.3g}: {r['setting']} "
                           f"({t:.3g} s, largest error {worst:.2e}{tie})"}
    msg = f"no setting (the reference excluded: its own error is not measured) reaches every error <= {budget:.3g}"
    if best is not None:
        msg += f"; the smallest largest error is {best[1]:.2e}, at {best[0]['setting']} ({best[0][cost]:.3g} s)"
    else:
        msg += "; no setting has every quantity"
    return {"budget": budget, "setting": None, cost: None, "max_error": None if best is None else best[1],
            "message": msg}


def read_records(path: Path, columns: list[str]) -> list[dict]:
    """Rows of a ``convergence.csv`` as dicts for :func:`recommend` (empty cells as None)."""
    out = []
    with open(path, newline="") as fh:
        for row in csv.DictReader(fh):
            rec = {"setting": row["setting"], "group": row.get("group", ""), "reference": row["reference"] == "true",
                   "status": row["status"]}
            for k in ["wall_time", "cpu_time"] + [f"{c}_error" for c in columns]:
                v = row.get(k, "")
                rec[k] = float(v) if v not in ("", None) else None
            out.append(rec)
    return out


def _fmt(v, err=False) -> str:
    if v is None:
        return "-"
    if err:
        return "0" if v == 0 else f"{v:.2e}"
    return f"{v:.10g}"


def format_table(records: list[dict], items: list[tuple[str, str]], error_kinds: dict) -> list[str]:
    """The printed table: one line per setting, value and error of each quantity."""
    head = ["setting", "wall [s]", "cpu [s]"]
    for c, _ in items:
        head += [c, f"{'rel.' if error_kinds[c] == 'relative' else 'abs.'} error"]
    body = []
    for r in records:
        label = r["setting"] + (" (ref.)" if r["reference"] else "")
        line = [label] + [f"{r[k]:.3f}" if r[k] is not None else "-" for k in ("wall_time", "cpu_time")]
        for c, _ in items:
            line += [_fmt(r.get(c)), "-" if r["reference"] else _fmt(r.get(f"{c}_error"), True)]
        body.append(line)
    widths = [max(len(x[j]) for x in [head] + body) for j in range(len(head))]
    fmt = lambda cells: "  ".join(c.ljust(w) if j == 0 else c.rjust(w) for j, (c, w) in enumerate(zip(cells, widths)))
    out = [fmt(head), fmt(["-" * w for w in widths])] + [fmt(b) for b in body]
    for r in records:
        if r["missing"]:
            out.append(f"missing at {r['setting']}: {r['missing']}")
    return out
