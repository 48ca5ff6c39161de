"""The run's checkpoint, ``state.jsonl``: what ``contin run --resume`` continues from.

One JSON record per line, appended and flushed as the run goes:

- ``{"type": "branch", "branch": j, "nu", "H", "unknown_scale", "parameter_scale", "dofs"}`` when branch ``j``
  stores its first point (``dofs``: the kept dofs of a condensed problem, else None);
- ``{"type": "point", "row", "branch", "nu", "H", "lam", "u", "tangent", "s", "step", "iterations",
  "residual", "data"}`` for every row of ``branches.csv`` (``data``: the monitored values);
- ``{"type": "special", "branch": j, "point": {...}, "csv": bool}`` for every special point of the branch
  (full :class:`SpecialPoint`; ``csv``: whether it is a row of ``special_points.csv``);
- ``{"type": "engine", "branch": j, "state": {...}}`` after each step that stored a point: everything the
  continuation engine carries to its next step (:func:`contin.engine.continuation.continuation`, ``checkpoint``);
- ``{"type": "end", "branch": j, "status", "message", "info", "monitors"}`` when branch ``j`` ends.

A run killed in the middle of a line leaves a last line that does not parse; it
and everything after it are ignored. :func:`resumable_prefix` cuts the records
back to the last point from which the run can go on exactly as it would have
without the interruption: after an ``engine`` or ``end`` record.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from contin.engine.branch import Branch, BranchBuilder, BranchStatus, SpecialPoint
from contin.engine.state import RESTART_KEYS

__all__ = ["CheckpointError", "encode", "decode", "read_records", "rebuild_branches", "resumable_prefix",
           "special_record"]


class CheckpointError(ValueError):
    """A line of a checkpoint that parses but is not a record contin writes."""


#: the keys each kind of record holds (what :func:`rebuild_branches` reads)
RECORD_KEYS = {"point": ("row", "branch", "lam", "u", "tangent"), "branch": ("branch",),
               "special": ("branch", "point"), "engine": ("branch", "state"), "end": ("branch", "status")}


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
    if kind == "engine" and not (isinstance(rec["state"], dict) and all(k in rec["state"] for k in ENGINE_KEYS)):
        raise CheckpointError(f"{where}: an engine record whose state has the keys {', '.join(ENGINE_KEYS)}")
    if kind == "end" and rec["status"] not in {s.value for s in BranchStatus}:
        raise CheckpointError(f"{where}: an end record with a branch status, found {rec['status']!r}")
    return rec


#: what an engine state must hold
ENGINE_KEYS = RESTART_KEYS


def encode(obj):
    """JSON-able form of numpy arrays and complex numbers (inverse: :func:`decode`)."""
    if isinstance(obj, np.ndarray):
        if np.iscomplexobj(obj):
            return {"__complex_array__": [obj.real.tolist(), obj.imag.tolist()]}
        if obj.dtype.kind in "biu":  # flags and counts come back as they were
            return {"__array__": obj.tolist(), "dtype": obj.dtype.str}
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


_DTYPES = {np.dtype(t).str for t in (bool, np.int8, np.int16, np.int32, np.int64, np.uint8, np.intp)}


def decode(obj):
    if isinstance(obj, dict):
        if "__array__" in obj:
            dtype = obj.get("dtype")
            return np.asarray(obj["__array__"], dtype=np.dtype(dtype) if dtype in _DTYPES else float)
        if "__complex_array__" in obj:
            re, im = obj["__complex_array__"]
            return np.asarray(re) + 1j * np.asarray(im)
        if "__complex__" in obj:
            return complex(*obj["__complex__"])
        return {k: decode(v) for k, v in obj.items()}
    if isinstance(obj, list):
        return [decode(v) for v in obj]
    return obj


def special_record(branch_id: int, sp: SpecialPoint, csv: bool = True) -> dict:
    return {"type": "special", "branch": branch_id, "point": encode(sp.to_dict()), "csv": bool(csv)}


def resumable_prefix(records: list[dict], n_rows: int) -> tuple[list[dict], int, int]:
    """The records up to the last point the run can go on from, and the CSV rows they account for.

    Parameters
    ----------
    records : list of dict
        Records of ``state.jsonl`` (:func:`read_records`).
    n_rows : int
        Complete rows of ``branches.csv``.

    Returns
    -------
    records : list of dict
        The records up to the last ``engine`` or ``end`` record whose points
        are all rows of ``branches.csv`` (what comes after it is computed again).
    rows : int
        Rows of ``branches.csv`` those records hold.
    special_rows : int
        Rows of ``special_points.csv`` they hold.
    """
    keep = rows = special = 0
    r = s = 0
    for i, rec in enumerate(records):
        kind = rec["type"]
        if kind == "point":
            if rec["row"] >= n_rows:
                break
            r += 1
        elif kind == "special":
            s += int(rec.get("csv", True))
        elif kind in ("engine", "end"):
            keep, rows, special = i + 1, r, s
    return records[:keep], rows, special


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
    """Branches (points, point data, special points, scales, ends) from checkpoint records.

    The records are a :func:`resumable_prefix`. The branches hold the
    continuation engine's unknowns: the coefficients of the dofs a branch
    record lists as ``dofs`` when its problem was condensed
    (:mod:`contin.hb.condensation`; ``u`` is stored full), all of them otherwise.
    A branch with an ``end`` record has its status, message and ``info``
    (``info["monitor_states"]``: its monitors' final states); the others are
    ``INTERRUPTED`` with ``info["restart"]``, the engine state of their last
    point (the ``restart`` of :func:`contin.engine.continuation.continuation`).
    """
    builders: dict[int, BranchBuilder] = {}
    headers: dict[int, dict] = {}
    ends: dict[int, dict] = {}
    states: dict[int, dict] = {}
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
            s = rec.get("s", 0.0 if not len(b) else b.arclength[-1] + 1.0)
            builders[j].append_point(u, rec["lam"], np.asarray(rec["tangent"]), s, rec.get("iterations", 0),
                                     rec.get("step", 0.0), rec.get("residual", 0.0), decode(rec.get("data") or {}))
        elif rec["type"] == "special" and j in builders:
            point = decode(rec["point"])
            point["unknowns"] = _kept(point["unknowns"], headers.get(j, {}).get("dofs"), headers.get(j, {}).get("H"))
            builders[j].add_special(SpecialPoint.from_dict(point))
        elif rec["type"] == "engine":
            states[j] = decode(rec["state"])
        elif rec["type"] == "end":
            ends[j] = rec
    out = {}
    for j, bld in builders.items():
        br = bld.branch
        h = headers.get(j, {})
        br.info.update(unknown_scale=h.get("unknown_scale"), parameter_scale=h.get("parameter_scale"),
                       subharmonic=h.get("nu"), harmonics=h.get("H"), resumed_points=len(br))
        if h.get("torus") is not None:  # a quasi-periodic branch (contin.hb.torus): its discretisation
            br.info["torus"] = h["torus"]
        if j in ends:
            end = ends[j]
            br.info.update(decode(end.get("info") or {}))
            br.info["monitor_states"] = decode(end.get("monitors") or [])
            bld.finish(BranchStatus(end["status"]), end.get("message", ""))
        else:
            br.info["restart"] = _checked_state(states.get(j), br, j)
            bld.finish(BranchStatus.INTERRUPTED, "restored from the checkpoint")
        out[j] = br
    return out


def _checked_state(state: dict | None, branch: Branch, j: int) -> dict | None:
    """``state`` if it fits ``branch`` (its last engine record belongs to its last point), else CheckpointError."""
    if state is None:
        return None
    m = branch.n_unknowns
    shapes = {"x": m + 1, "t": m + 1, "t_prev": m + 1, "prev_x": m + 1, "x_start": m + 1, "t_start": m + 1,
              "su": m, "groups": m}
    bad = [k for k, n in shapes.items() if np.shape(state[k]) != (n,) or not np.all(np.isfinite(state[k]))]
    if state["points"] != len(branch):
        bad.append("points")
    if bad:
        raise CheckpointError(f"the engine state of branch {j} does not fit its {len(branch)} points "
                              f"({m} unknowns): {', '.join(bad)}")
    return state
