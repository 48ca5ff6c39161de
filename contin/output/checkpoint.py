"""The run's checkpoint, ``state.jsonl``: what ``contin run --resume`` continues from.

One JSON record per line, appended and flushed as the run goes:

- ``{"type": "branch", "branch": j, "nu", "H", "unknown_scale", "parameter_scale", "dofs", "unknowns"}`` when
  branch ``j`` stores its first point (``dofs``: the kept dofs of a condensed problem, else None;
  ``"unknowns": "engine"``: its points hold the engine's unknowns, :mod:`contin.output.expansion`);
- ``{"type": "point", "row", "branch", "nu", "H", "lam", "u", "tangent", "scale", "s", "step", "iterations",
  "residual", "data"}`` for every row of ``branches.csv`` (``u``: the engine's unknowns, the kept dofs'
  coefficients of a condensed problem; ``scale``: the engine's scales ``[su, sl]`` of its tangent;
  ``data``: the monitored values);
- ``{"type": "special", "branch": j, "point": {...}, "csv": bool}`` for every special point of the branch
  (full :class:`SpecialPoint`; ``csv``: whether it is a row of ``special_points.csv``);
- ``{"type": "engine", "branch": j, "state": {...}}`` after each step that stored a point: everything the
  continuation engine carries to its next step (:func:`contin.engine.continuation.continuation`, ``checkpoint``),
  held for the last two such records only (in ``state_last.npz``; the earlier ones are ``stale``);
- ``{"type": "end", "branch": j, "status", "message", "info", "monitors"}`` when branch ``j`` ends.

The arrays (a point's coefficients ``u`` and its tangent, the engine's
vectors) are not in the lines: an array of more than
:data:`~contin.output.state_store.INLINE` numbers is a reference to its
bytes in ``state.bin`` (or, for the engine's last positions, in
``state_last.npz``), read back exactly (:mod:`contin.output.state_store`).
:func:`read_records` gives the records with numpy arrays in their place. A
``state.jsonl`` with its arrays as JSON lists was written by an older contin
and is refused.

A run killed in the middle of a line leaves a last line that does not parse
(or one whose arrays are past the end of ``state.bin``); it and everything
after it are ignored.

Every line is strict JSON: a value that is not finite (a step cap of ``inf``,
a multiplier not computed, ``nan``) is written as ``{"__float__": "inf"}``
(:func:`encode`, :func:`dumps`) and read back by :func:`decode`; a line holding
the tokens ``NaN`` or ``Infinity``, which are not JSON, is refused. :func:`resumable_prefix` cuts the records
back to the last point from which the run can go on exactly as it would have
without the interruption: after an ``engine`` (whose last positions are still
held) or ``end`` record.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from contin.engine.branch import Branch, BranchBuilder, BranchStatus, SpecialPoint
from contin.engine.state import RESTART_KEYS
from contin.output.expansion import stores_kept
from contin.output.state_store import INLINE, VOLATILE, ArrayReader, CheckpointError, TornRecord
from contin.util.safe_files import open_regular, replace_file

__all__ = ["CheckpointError", "encode", "decode", "dumps", "keep_records", "read_records", "rebuild_branches",
           "resumable_prefix", "special_record"]


#: the keys each kind of record holds (what :func:`rebuild_branches` reads)
RECORD_KEYS = {"point": ("row", "branch", "lam", "u", "tangent"), "branch": ("branch",),
               "special": ("branch", "point"), "engine": ("branch", "state"), "end": ("branch", "status")}


#: the longest array contin has written as a JSON list (longer ones: a checkpoint before state.bin)
_LISTED = 16


def _is_numbers(v) -> bool:
    if isinstance(v, np.ndarray):  # read from state.bin
        return v.ndim == 1 and v.dtype.kind == "f"
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
    if kind == "point" and any(isinstance(rec[k], list) and len(rec[k]) > _LISTED for k in ("u", "tangent")):
        raise CheckpointError(f"{where}: written by an older contin (its arrays as JSON lists, without "
                              "state.bin), which this one does not resume")
    if kind == "point" and not (isinstance(rec["row"], int) and isinstance(rec["lam"], (int, float))
                                and _is_numbers(rec["u"]) and _is_numbers(rec["tangent"])
                                and len(rec["tangent"]) >= 1):
        raise CheckpointError(f"{where}: a point record with an integer row, a number lam and lists of numbers "
                              "u and tangent")
    natural = kind == "engine" and isinstance(rec["state"], dict) and "natural" in rec["state"]
    if kind == "engine" and isinstance(rec["state"], dict) and not natural:
        rec["state"].setdefault("step_control", None)  # written before the step control was a protocol: the default
    if natural and not (all(k in rec["state"] for k in NATURAL_KEYS) and isinstance(rec["state"]["natural"], dict)
                        and all(k in rec["state"]["natural"] for k in NATURAL_STEP_KEYS)):
        raise CheckpointError(f"{where}: a natural-step record whose state has the keys {', '.join(NATURAL_KEYS)} "
                              f"and natural: {', '.join(NATURAL_STEP_KEYS)}")
    if kind == "engine" and not natural and not rec.get("stale") and not (
            isinstance(rec["state"], dict) and all(k in rec["state"] for k in ENGINE_KEYS)):
        raise CheckpointError(f"{where}: an engine record whose state has the keys {', '.join(ENGINE_KEYS)}")
    if kind == "end" and rec["status"] not in {s.value for s in BranchStatus}:
        raise CheckpointError(f"{where}: an end record with a branch status, found {rec['status']!r}")
    return rec


#: what an engine state must hold
ENGINE_KEYS = RESTART_KEYS
#: what the state of a circle branch in natural steps holds (contin.bifurcation.circle_natural), and its steps'
NATURAL_KEYS = ("points", "natural", "monitors")
NATURAL_STEP_KEYS = ("step", "largest", "failures", "lu_u", "lu_lam")


def _float(v: float):
    """A float as strict JSON holds it: itself when finite, else ``{"__float__": "inf"}`` (or ``-inf``, ``nan``)."""
    return v if math.isfinite(v) else {"__float__": repr(float(v))}


def _float_list(a: np.ndarray) -> list:
    """``a.tolist()`` with its non-finite values as :func:`_float` gives them."""
    if np.all(np.isfinite(a)):
        return a.tolist()

    def walk(v):
        return [walk(x) for x in v] if isinstance(v, list) else _float(v)

    return walk(a.tolist())


def encode(obj, store=None):
    """JSON-able form of numpy arrays, complex numbers and non-finite floats (inverse: :func:`decode`).

    ``store(array)``, when given, takes every array of more than
    :data:`~contin.output.state_store.INLINE` numbers and returns what stands for it
    (a reference to its bytes: :class:`contin.output.state_store.StateWriter`).
    """
    if isinstance(obj, np.ndarray):
        if store is not None and obj.size * (1 + (obj.dtype.kind == "c")) > INLINE and obj.ndim <= 2 \
                and obj.dtype.kind in "biufc":
            return store(obj if obj.dtype.kind in "bic" else np.asarray(obj, dtype=np.int64 if obj.dtype.kind == "u"
                                                                         else float))
        if np.iscomplexobj(obj):
            return {"__complex_array__": [_float_list(obj.real), _float_list(obj.imag)]}
        if obj.dtype.kind in "biu":  # flags and counts come back as they were
            return {"__array__": obj.tolist(), "dtype": obj.dtype.str}
        return {"__array__": _float_list(np.asarray(obj, dtype=float))}
    if isinstance(obj, (complex, np.complexfloating)):
        return {"__complex__": [_float(float(np.real(obj))), _float(float(np.imag(obj)))]}
    if isinstance(obj, np.generic):
        return encode(obj.item())
    if isinstance(obj, float):
        return _float(obj)
    if isinstance(obj, dict):
        return {str(k): encode(v, store) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [encode(v, store) for v in obj]
    if hasattr(obj, "value") and not isinstance(obj, (int, float, str, bool)):
        return obj.value
    return obj


_DTYPES = {np.dtype(t).str for t in (bool, np.int8, np.int16, np.int32, np.int64, np.uint8, np.intp)}


def _floats(v):
    """The numbers of a list (nested) with the tagged non-finite values of :func:`_float` read back."""
    if isinstance(v, list):
        return [_floats(x) for x in v]
    if isinstance(v, dict) and "__float__" in v:
        return _tagged_float(v)
    return v


def _tagged_float(obj: dict) -> float:
    text = obj["__float__"]
    if text not in ("inf", "-inf", "nan"):
        raise CheckpointError(f"a non-finite value written as inf, -inf or nan, found {text!r}")
    return float(text)


def decode(obj):
    """The value :func:`encode` gave ``obj`` for (numpy arrays, complex numbers, non-finite floats)."""
    if isinstance(obj, dict):
        if "__float__" in obj:
            return _tagged_float(obj)
        if "__array__" in obj:
            dtype = obj.get("dtype")
            return np.asarray(_floats(obj["__array__"]), dtype=np.dtype(dtype) if dtype in _DTYPES else float)
        if "__complex_array__" in obj:
            re, im = (np.asarray(_floats(v), dtype=float) for v in obj["__complex_array__"])
            out = np.empty(np.broadcast_shapes(re.shape, im.shape), dtype=complex)
            out.real, out.imag = re, im  # not re + 1j * im: 1j * inf is nan + inf j
            return out
        if "__complex__" in obj:
            return complex(*_floats(obj["__complex__"]))
        return {k: decode(v) for k, v in obj.items()}
    if isinstance(obj, list):
        return [decode(v) for v in obj]
    return obj


def dumps(record: dict) -> str:
    """One line of ``state.jsonl``: ``record`` encoded (:func:`encode`) as strict JSON, without the newline."""
    return json.dumps(encode(record), allow_nan=False)


def keep_records(path: Path, count: int) -> None:
    """Cut the checkpoint at ``path`` to its first ``count`` records (atomically; a link there is refused).

    The lines are kept as they are, so their references into ``state.bin``
    still hold; the bytes of the records cut off stay there unreferenced.
    """
    with open_regular(path, encoding=None, follow=True) as fh:  # bytes: the lines exactly as they were
        lines = [line for _, line in zip(range(count), fh)]
    replace_file(path, lambda out: out.writelines(lines), binary=True)


def special_record(branch_id: int, sp: SpecialPoint, csv: bool = True) -> dict:
    """A special point's record (arrays encoded on writing: :class:`contin.output.state_writer.StateWriter`)."""
    return {"type": "special", "branch": branch_id, "point": sp.to_dict(), "csv": bool(csv)}


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
        elif kind == "end" or (kind == "engine" and not rec.get("stale")):
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
    if not Path(path).exists() and not Path(path).is_symlink():
        return out
    # a pipe or a device would never end
    with open_regular(path, errors="replace", follow=True) as fh, ArrayReader(path) as arrays:
        for lineno, line in enumerate(fh, 1):
            try:
                rec = json.loads(line, parse_constant=_not_json)
            except json.JSONDecodeError:
                break
            except _NonFinite as exc:
                raise CheckpointError(f"{path} line {lineno}: strict JSON (contin writes a value that is not finite "
                                      f'as {{"__float__": "inf"}}), found the token {exc.args[0]}') from None
            try:
                rec = _resolved(rec, arrays, f"{path} line {lineno}")
            except TornRecord:  # its arrays were being written when the run was killed
                break
            rec = _checked(rec, path, lineno)
            if rec["type"] == "point" and max_row is not None and rec["row"] >= max_row:
                break
            out.append(rec)
    return out


def _resolved(rec, arrays: ArrayReader, where: str):
    """``rec`` with its arrays read (:class:`ArrayReader`); an engine record whose last positions
    ``state_last.npz`` no longer holds is marked ``stale`` (no point to resume from)."""
    out = arrays.resolve(rec, where)
    if isinstance(rec, dict) and rec.get("type") == "engine" and isinstance(rec.get("state"), dict):
        if out["state"] is None:  # an earlier step's state, no longer held
            out["state"], out["stale"] = {}, True
        elif any(v is None for k, v in out["state"].items() if k in VOLATILE):
            out["stale"] = True
    return out


class _NonFinite(Exception):
    """``NaN``, ``Infinity`` or ``-Infinity`` in a line: Python's json reads them, JSON has no such tokens."""


def _not_json(token: str):
    raise _NonFinite(token)


def _kept(u, header: dict, H) -> np.ndarray:
    """The engine's unknowns of a stored vector: as stored (:func:`contin.output.expansion.stores_kept`), or in
    a checkpoint of an earlier contin, the coefficients of the kept dofs out of the full ones (harmonic-major)."""
    u = np.asarray(u, dtype=float)
    dofs = header.get("dofs")
    if dofs is None or stores_kept(header):
        return u
    return u.reshape(2 * int(H) + 1, -1)[:, np.asarray(dofs, dtype=int)].reshape(-1)


def rebuild_branches(records: list[dict], parameter_name: str) -> dict[int, Branch]:
    """Branches (points, point data, special points, scales, ends) from checkpoint records.

    The records are a :func:`resumable_prefix`. The branches hold the
    continuation engine's unknowns: the coefficients of the dofs a branch
    record lists as ``dofs`` when its problem was condensed
    (:mod:`contin.hb.condensation`; :mod:`contin.output.expansion` gives the full ones), all of them otherwise.
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
            u = _kept(rec["u"], headers.get(j, {}), rec.get("H") or headers.get(j, {}).get("H"))
            if j not in builders:
                builders[j] = BranchBuilder(parameter_name, u.size)
            b = builders[j].branch
            s = decode(rec.get("s", 0.0 if not len(b) else b.arclength[-1] + 1.0))
            builders[j].append_point(u, rec["lam"], np.asarray(rec["tangent"]), s, rec.get("iterations", 0),
                                     decode(rec.get("step", 0.0)), decode(rec.get("residual", 0.0)),
                                     decode(rec.get("data") or {}))
        elif rec["type"] == "special" and j in builders:
            point = decode(rec["point"])
            point["unknowns"] = _kept(point["unknowns"], headers.get(j, {}), headers.get(j, {}).get("H"))
            builders[j].add_special(SpecialPoint.from_dict(point))
        elif rec["type"] == "engine" and not rec.get("stale"):
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
    if "natural" in state:  # the stepper's: its step goes on, its factorisation's point has the branch's size
        nat = state["natural"]
        bad = [] if state["points"] == len(branch) else ["points"]
        if not _positive(abs(nat["step"]) if isinstance(nat["step"], (int, float)) else None, finite=True):
            bad.append(f"step = {nat['step']!r}")
        if nat["lu_u"] is not None and (np.shape(nat["lu_u"]) != (m,) or not np.all(np.isfinite(nat["lu_u"]))):
            bad.append("lu_u")
        if bad:
            raise CheckpointError(f"the natural-step state of branch {j} does not fit its {len(branch)} points "
                                  f"({m} unknowns): {', '.join(bad)}")
        return state
    shapes = {"x": m + 1, "t": m + 1, "t_prev": m + 1, "prev_x": m + 1, "x_start": m + 1, "t_start": m + 1,
              "su": m, "groups": m}
    bad = [k for k, n in shapes.items() if np.shape(state[k]) != (n,) or not np.all(np.isfinite(state[k]))]
    if state["points"] != len(branch):
        bad.append("points")
    if bad:
        raise CheckpointError(f"the engine state of branch {j} does not fit its {len(branch)} points "
                              f"({m} unknowns): {', '.join(bad)}")
    # the steps the engine goes on with: a step that is not a positive finite number would never end the branch
    steps = {k: state.get(k) for k in ("ds", "ds_free", "sl")}
    steps.update({f"recent[{i}]": v for i, v in enumerate(state["recent"] if isinstance(state["recent"], list) else [])})
    wrong = [f"{k} = {v!r}" for k, v in steps.items() if not _positive(v, finite=True)]
    if not _positive(state.get("event_cap"), finite=False):  # inf: no event ahead
        wrong.append(f"event_cap = {state.get('event_cap')!r}")
    if not isinstance(state["recent"], list):
        wrong.append(f"recent = {state['recent']!r}")
    if wrong:
        raise CheckpointError(f"the engine state of branch {j}: steps that are positive finite numbers, found "
                              + ", ".join(wrong))
    return state


def _positive(v, finite: bool) -> bool:
    """``v`` is a number > 0 (and finite when ``finite``); NaN is not."""
    if isinstance(v, bool) or not isinstance(v, (int, float)) or math.isnan(v) or v <= 0:
        return False
    return math.isfinite(v) or not finite
