"""Where a stable solution exists: parameter intervals read off a run's result files."""

from __future__ import annotations

import math

import numpy as np

__all__ = ["SPECIAL_KINDS", "stable_intervals"]

#: kinds of special points that change stability (counted per sweep point)
SPECIAL_KINDS = ("fold", "pd", "ns", "bp")


def _flags(col) -> list:
    """``stable`` column as True/False/None per row."""
    out = []
    for v in col:
        if isinstance(v, (bool, np.bool_)):
            out.append(bool(v))
        elif isinstance(v, str):
            out.append(True if v == "true" else False if v == "false" else None)
        else:
            out.append(None)
    return out


def stable_intervals(rows: dict, special: dict, parameter: str) -> dict[int, list[tuple[float, float]]]:
    """Parameter intervals where a stable solution of order ``nu`` exists, per ``nu``.

    Parameters
    ----------
    rows, special : dict of arrays
        ``branches.csv`` and ``special_points.csv`` as read by :func:`contin.output.results.read_csv`.
    parameter : str
        The continuation parameter (a column of both).

    Returns
    -------
    dict
        ``nu -> [(lo, hi), ...]``: the union over the branches of order ``nu``
        of their runs of consecutive stable rows, sorted and merged. Where a
        run of stable rows borders an unstable row and the branch has a
        located special point there (its nearest row, ``index``, is one of
        the two rows), the run extends to that point, the located change of
        stability (at a fold it lies beyond both rows); else the run ends at
        its last stable row. Orders whose branches have no stability data are
        left out, so the result is empty when stability was not computed.
    """
    if not rows or "stable" not in rows or parameter not in rows or len(rows["branch"]) == 0:
        return {}
    branch = [int(b) for b in rows["branch"]]
    nus = [int(n) for n in rows["nu"]]
    x = [float(v) for v in rows[parameter]]
    stable = _flags(rows["stable"])
    changes: dict[int, list[tuple[float, int | None]]] = {}
    if special and len(special.get("branch", [])):
        idx_col = special.get("index")
        for j, (b, k, v) in enumerate(zip(special["branch"], special["kind"], special[parameter])):
            if k in SPECIAL_KINDS or k == "stability":
                near = None
                if idx_col is not None and idx_col.dtype.kind == "f" and math.isfinite(idx_col[j]):
                    near = int(idx_col[j])
                changes.setdefault(int(b), []).append((float(v), near))
    per_nu: dict[int, list] = {}
    order: dict[int, list[int]] = {}
    for i, b in enumerate(branch):
        order.setdefault(b, []).append(i)
    for b, idx in order.items():
        if all(stable[i] is None for i in idx):
            continue
        nu = nus[idx[0]]
        per_nu.setdefault(nu, [])
        located = changes.get(b, [])

        def change(ra, rb):
            """The located special point between rows ``ra`` and ``rb`` (global row numbers), if any."""
            lo, hi = min(x[ra], x[rb]), max(x[ra], x[rb])
            by_row = [v for v, near in located if near in (ra, rb)]
            inside = [v for v in by_row if lo <= v <= hi] or by_row
            if not inside:
                inside = [v for v, near in located if near is None and lo <= v <= hi]
            return inside[0] if inside else None

        j = 0
        while j < len(idx):
            if stable[idx[j]] is not True:
                j += 1
                continue
            k = j
            while k + 1 < len(idx) and stable[idx[k + 1]] is True:
                k += 1
            xs = [x[i] for i in idx[j:k + 1]]
            if j > 0 and stable[idx[j - 1]] is False:
                v = change(idx[j - 1], idx[j])
                if v is not None:
                    xs.append(v)
            if k + 1 < len(idx) and stable[idx[k + 1]] is False:
                v = change(idx[k], idx[k + 1])
                if v is not None:
                    xs.append(v)
            per_nu[nu].append((min(xs), max(xs)))
            j = k + 1
    return {nu: _merge(iv) for nu, iv in sorted(per_nu.items())}


def _merge(intervals):
    out: list[list[float]] = []
    for lo, hi in sorted(intervals):
        if out and lo <= out[-1][1]:
            out[-1][1] = max(out[-1][1], hi)
        else:
            out.append([lo, hi])
    return [(a, b) for a, b in out]
