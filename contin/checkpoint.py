"""The run's checkpoint, ``state.jsonl``: what ``contin run --resume`` continues from.

One JSON record per line, appended and flushed as the run goes:

- ``{"type": "branch", "branch": j, "nu", "H", "unknown_scale", "parameter_scale", "dofs"}`` when branch ``j``
  stores its first point (``dofs``: the kept dofs of a condensed problem, else None);
- ``{"type": "point", "row", "branch", "nu", "H", "lam", "u", "tangent"}`` for every row of ``branches.csv``;
- ``{"type": "special", "branch": j, "point": {...}}`` for every special point (full :class:`SpecialPoint`).

A run killed in the middle of a line leaves a last line that does not parse; it
and everything after it are ignored.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from contin.branch import Branch, BranchBuilder, BranchStatus, SpecialKind, SpecialPoint

__all__ = ["CheckpointError", "encode", "decode", "read_records", "rebuild_branches", "special_record"]


class CheckpointError(ValueError):
    """A line of a checkpoint that parses but is not a record contin writes."""


#: the keys each kind of record holds (what :func:`rebuild_branches` reads)
RECORD_KEYS = {"point": ("row", "branch", "lam", "u", "tangent"), "branch": ("branch",),
               "special": ("branch", "point")}


def _is_numbers(v) -> bool:
    return isinstance(v, list) and all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in v)


def _checked(rec, path, lineno: int) -> dict:
    where = f"{path} line {lineno}"
    if not isinstance(rec, dict):
        raise CheckpointError(f"{where}: a JSON object, found {type(rec).__name__}")
    kind = rec.setdefault("type", "point")
    if kind not in RECORD_KEYS:
        raise CheckpointError(f"{where}: a record of type {', '.join(RECORD_KEYS)}, found {kind!r}")
    missing = [k for k in RECORD_KEYS[kind] if k not in rec]
    if missing:
        raise CheckpointError(f"{where}: a {kind} record with the keys {', '.join(missing)}")
    if not (isinstance(rec["branch"], int) and rec["branch"] >= 0):
        raise CheckpointError(f"{where}: a branch number, found {rec['branch']!r}")
    if kind == "point" and not (isinstance(rec["row"], int) and isinstance(rec["lam"], (int, float))
                                and _is_numbers(rec["u"]) and _is_numbers(rec["tangent"])
                                and len(rec["tangent"]) >= 1):
        raise CheckpointError(f"{where}: a point record with an integer row, a number lam and lists of numbers "
                              "u and tangent")
    return rec


def encode(obj):
    """JSON-able form of numpy arrays and complex numbers (inverse: :func:`decode`)."""
    if isinstance(obj, np.ndarray):
        if np.iscomplexobj(obj):
            return {"__complex_array__": [obj.real.tolist(), obj.imag.tolist()]}
        return {"__array__": obj.tolist()}
    if isinstance(obj, (complex, np.complexfloating)):
        return {"__complex__": [float(np.real(obj)), float(np.imag(obj))]}
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, dict):
        return {str(k): encode(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [encode(v) for v in obj]
    if hasattr(obj, "value") and not isinstance(obj, (int, float, str, bool)):
        return obj.value
    return obj


def decode(obj):
    if isinstance(obj, dict):
        if "__array__" in obj:
            return np.asarray(obj["__array__"], dtype=float)
        if "__complex_array__" in obj:
            re, im = obj["__complex_array__"]
            return np.asarray(re) + 1j * np.asarray(im)
        if "__complex__" in obj:
            return complex(*obj["__complex__"])
        return {k: decode(v) for k, v in obj.items()}
    if isinstance(obj, list):
        return [decode(v) for v in obj]
    return obj


def special_record(branch_id: int, sp: SpecialPoint) -> dict:
    return {"type": "special", "branch": branch_id, "point": encode(sp.to_dict())}


def read_records(path: Path, max_row: int | None = None) -> list[dict]:
    """Records of a checkpoint, stopping at the first line that does not parse.

    Parameters
    ----------
    max_row : int, optional
        Drop point records with ``row >= max_row`` (rows missing from ``branches.csv``).

    Raises
    ------
    CheckpointError
        At a line that parses as JSON but is not a record contin writes (a
        line cut by a killed run does not parse and ends the records).
    """
    out = []
    if not Path(path).exists():
        return out
    with open(path, encoding="utf-8", errors="replace") as fh:
        for lineno, line in enumerate(fh, 1):
            try:
                rec = json.loads(line)
            except json.JSONDecodeError:
                break
            rec = _checked(rec, path, lineno)
            if rec["type"] == "point" and max_row is not None and rec["row"] >= max_row:
                break
            out.append(rec)
    return out


def _kept(u, dofs, H) -> np.ndarray:
    """The coefficients of the kept ``dofs`` out of a full coefficient vector (harmonic-major)."""
    u = np.asarray(u, dtype=float)
    return u if dofs is None else u.reshape(2 * int(H) + 1, -1)[:, np.asarray(dofs, dtype=int)].reshape(-1)


def rebuild_branches(records: list[dict], parameter_name: str) -> dict[int, Branch]:
    """Branches (points, special points, scales) from checkpoint records.

    The branches hold the continuation engine's unknowns: the coefficients of
    the dofs a branch record lists as ``dofs`` when its problem was condensed
    (:mod:`contin.condensation`; ``u`` is stored full), all of them otherwise.
    A branch that reached an end of its range (an ``end`` special point) is
    marked ``RANGE_END``; the others ``INTERRUPTED``, to be continued.
    """
    builders: dict[int, BranchBuilder] = {}
    headers: dict[int, dict] = {}
    for rec in records:
        j = rec["branch"]
        if rec["type"] == "branch":
            headers[j] = decode(rec)
        elif rec["type"] == "point":
            dofs = headers.get(j, {}).get("dofs")
            u = _kept(rec["u"], dofs, rec.get("H") or headers.get(j, {}).get("H"))
            if j not in builders:
                builders[j] = BranchBuilder(parameter_name, u.size)
            b = builders[j].branch
            s = 0.0 if not len(b) else b.arclength[-1] + 1.0
            builders[j].append_point(u, rec["lam"], np.asarray(rec["tangent"]), s, 0, 0.0, 0.0)
        elif rec["type"] == "special" and j in builders:
            point = decode(rec["point"])
            point["unknowns"] = _kept(point["unknowns"], headers.get(j, {}).get("dofs"), headers.get(j, {}).get("H"))
            builders[j].branch.special_points.append(SpecialPoint.from_dict(point))
    out = {}
    for j, bld in builders.items():
        br = bld.branch
        h = headers.get(j, {})
        br.info.update(unknown_scale=h.get("unknown_scale"), parameter_scale=h.get("parameter_scale"),
                       subharmonic=h.get("nu"), harmonics=h.get("H"), resumed_points=len(br))
        done = any(sp.kind is SpecialKind.END for sp in br.special_points)
        bld.finish(BranchStatus.RANGE_END if done else BranchStatus.INTERRUPTED,
                   "restored from the checkpoint")
        out[j] = br
    return out
