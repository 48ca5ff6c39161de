"""Result objects of a continuation run: :class:`Branch` and :class:`SpecialPoint`.

A :class:`Branch` holds converged points only and never stores a non-finite
value. It is filled incrementally by :class:`BranchBuilder` (used by the
engine); its arrays are exposed as read-only numpy views.
"""

from __future__ import annotations

import dataclasses
import enum
from typing import Any

import numpy as np

__all__ = ["Branch", "BranchBuilder", "BranchStatus", "PointRejected", "SpecialKind", "SpecialPoint"]


class BranchStatus(str, enum.Enum):
    """Why a branch ended (``RUNNING`` while it is being computed)."""

    RUNNING = "running"
    #: reached an end of the parameter range
    RANGE_END = "range_end"
    #: ``max_points`` points stored, a cap the caller set
    MAX_POINTS = "max_points"
    #: the default cap on stored points reached (``max_points`` was not set): the rest is not covered
    DEFAULT_MAX_POINTS = "default_max_points"
    #: the step size fell below ``ds_min``
    STEP_TOO_SMALL = "step_too_small"
    #: Newton did not converge at the start (the branch has no points)
    START_FAILED = "start_failed"
    #: a point could not be stored (non-finite values) or evaluated
    NEWTON_FAILED = "newton_failed"
    #: the bordered Jacobian became numerically singular where Newton failed
    ILL_CONDITIONED = "ill_conditioned"
    #: KeyboardInterrupt, or the callback asked to stop
    INTERRUPTED = "interrupted"
    #: the branch came back to its start point
    CLOSED_LOOP = "closed_loop"
    #: the branch reached a located point it cannot pass (a boundary of the problem's smooth
    #: domain, such as grazing: a contact arc appearing or vanishing tangentially)
    BOUNDARY = "boundary"
    #: reached the end of the parameter range opposite to the one it set out towards (it turned
    #: back at a fold): the part of the range beyond its furthest point is not covered by it
    TURNED_BACK = "turned_back"
    #: passed again through one of its earlier points (not its start), in the same direction: a smooth
    #: branch cannot, so a step jumped back onto an earlier part of it (or onto another branch through it)
    RETRACED = "retraced"

    def __str__(self) -> str:
        return self.value

    @property
    def as_asked(self) -> bool:
        """True if the branch ended where the problem or the options end it, False if the numerics gave up.

        A branch ends as asked at a range end (also after turning back), at
        a closed loop, at a located point it cannot pass (``BOUNDARY``) or
        after the ``max_points`` points the caller set; it falls short when
        its start, Newton, the step size or the conditioning failed, when a
        step jumped back onto an earlier part of it (``RETRACED``), when it
        reached the default cap on points that nobody set
        (``DEFAULT_MAX_POINTS``), or when it was interrupted.
        """
        return self in _AS_ASKED


_AS_ASKED = frozenset({BranchStatus.RANGE_END, BranchStatus.TURNED_BACK, BranchStatus.CLOSED_LOOP,
                       BranchStatus.BOUNDARY, BranchStatus.MAX_POINTS})


class SpecialKind(str, enum.Enum):
    """Kind of a :class:`SpecialPoint`."""

    FOLD = "fold"
    BP = "bp"
    PD = "pd"
    NS = "ns"
    #: generic, unclassified stability change
    STABILITY = "stability"
    #: a corner of the branch: the tangent jumps (non-smooth problems, e.g. contact onset/grazing)
    KINK = "kink"
    #: a contact arc appears or vanishes tangentially (an extremum of a switching function reaches zero)
    GRAZING = "grazing"
    #: codimension two, on a fold curve: two folds merge (Kuznetsov 2004, sec. 8.2)
    CUSP = "cusp"
    #: codimension two: multipliers +1 and -1 at once (a fold curve meets a period-doubling curve)
    FOLD_FLIP = "fold_flip"
    #: codimension two, on a Neimark-Sacker curve: the critical multipliers reach exp(2 pi i p/q), strong
    #: resonances 1:1 (a fold curve), 1:2 (a period-doubling curve), 1:3, 1:4 (Kuznetsov 2004, sec. 9.5)
    R1 = "r1"
    R2 = "r2"
    R3 = "r3"
    R4 = "r4"
    #: codimension two, on a Neimark-Sacker curve: a real multiplier crosses -1 (+1) as well
    FLIP_NS = "flip_ns"
    FOLD_NS = "fold_ns"
    #: a two-parameter curve turns in one of its parameters (not a bifurcation)
    EXTREMUM = "extremum"
    #: a quasi-periodic branch's second frequency reaches a low-order rational ratio to the first (entrainment)
    LOCKING = "locking"
    END = "end"
    START = "start"
    USER = "user"

    def __str__(self) -> str:
        return self.value


def _to_builtin(value: Any) -> Any:
    if isinstance(value, np.ndarray):
        return value.copy()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, dict):
        return {k: _to_builtin(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return type(value)(_to_builtin(v) for v in value)
    if isinstance(value, enum.Enum):
        return value.value
    return value


@dataclasses.dataclass
class SpecialPoint:
    """A located special point (fold, branch point, stability change, ...).

    Attributes
    ----------
    kind : SpecialKind
    parameter : float
        Located parameter value (best estimate if ``located`` is False).
    unknowns : ndarray, shape (m,)
        Unknowns at the located point (a converged solution).
    interval : tuple of float
        ``(lam_a, lam_b)``: parameters of the two stored points bracketing it.
    index : int
        Index of the stored point just before it on the branch.
    s : float
        Arclength (scaled pseudo-arclength) of the located point.
    test_values : tuple
        Test-function values at the two bracketing stored points.
    located : bool
        True if located to tolerance.
    data : dict
        Free data supplied by the event (``Event.describe``).
    message : str
    event : str
        Name of the event that produced it.
    tangent : ndarray or None, shape (m+1,)
        Unit tangent (scaled coordinates) at the located point.
    point_data : dict
        Monitor values at the located point.
    """

    kind: SpecialKind
    parameter: float
    unknowns: np.ndarray
    interval: tuple
    index: int
    s: float
    test_values: tuple = ()
    located: bool = True
    data: dict = dataclasses.field(default_factory=dict)
    message: str = ""
    event: str = ""
    tangent: np.ndarray | None = None
    point_data: dict = dataclasses.field(default_factory=dict)

    def __post_init__(self):
        self.kind = SpecialKind(self.kind)

    @property
    def bracket(self) -> tuple:
        """``(lo, hi)``: :attr:`interval` in increasing order (a branch may run towards smaller values)."""
        a, b = (float(v) for v in self.interval)
        return (a, b) if a <= b else (b, a)

    def to_dict(self) -> dict:
        """Plain-python/numpy representation (enums as strings)."""
        return {f.name: _to_builtin(getattr(self, f.name)) for f in dataclasses.fields(self)}

    @classmethod
    def from_dict(cls, d: dict) -> "SpecialPoint":
        d = dict(d)
        d["unknowns"] = np.asarray(d["unknowns"], dtype=float)
        if d.get("tangent") is not None:
            d["tangent"] = np.asarray(d["tangent"], dtype=float)
        d["interval"] = tuple(d["interval"])
        d["test_values"] = tuple(d.get("test_values", ()))
        return cls(**d)

    def __repr__(self) -> str:
        state = "" if self.located else ", not located"
        return (
            f"SpecialPoint({self.kind.value}, parameter={self.parameter:.10g}, index={self.index}"
            f"{state}{', ' + self.event if self.event else ''})"
        )


class PointRejected(ValueError):
    """A point could not be stored (non-finite or inconsistent values)."""


class _Growable:
    """Append-only array with amortised doubling; ``view()`` is read-only."""

    __slots__ = ("_buf", "_n")

    def __init__(self, shape: tuple, dtype):
        self._buf = np.empty((16,) + tuple(shape), dtype=dtype)
        self._n = 0

    def append(self, value) -> None:
        if self._n == self._buf.shape[0]:
            new = np.empty((2 * self._n,) + self._buf.shape[1:], dtype=self._buf.dtype)
            new[: self._n] = self._buf[: self._n]
            self._buf = new
        self._buf[self._n] = value
        self._n += 1

    def view(self) -> np.ndarray:
        v = self._buf[: self._n]
        v.flags.writeable = False
        return v


class Branch:
    """A computed solution branch of ``R(u, lam) = 0`` (converged points only).

    Attributes
    ----------
    parameter_name : str
    parameter : ndarray, shape (P,)
    unknowns : ndarray, shape (P, m)
    tangents : ndarray, shape (P, m+1)
        Unit tangents in scaled coordinates ``(u / su, lam / sl)``; the scales
        are ``info["unknown_scale"]`` and ``info["parameter_scale"]``.
    arclength : ndarray, shape (P,)
        Scaled pseudo-arclength, 0 at the start.
    newton_iterations : ndarray of int, shape (P,)
    step_sizes : ndarray, shape (P,)
        Step (scaled arclength) that produced each point; 0 for the start.
    residual_norms : ndarray, shape (P,)
        ``||R(u, lam)||_inf`` at each point.
    point_data : dict of str to ndarray of shape (P, ...)
        Per-point monitored quantities.
    special_points : list of SpecialPoint
    status : BranchStatus
    message : str
    info : dict
        Free-form: scales, counters, condition estimates, ...

    The array attributes are read-only views; copy them to modify.
    """

    def __init__(self, parameter_name: str, n_unknowns: int):
        self.parameter_name = str(parameter_name)
        self.n_unknowns = int(n_unknowns)
        m = self.n_unknowns
        self._parameter = _Growable((), float)
        self._unknowns = _Growable((m,), float)
        self._tangents = _Growable((m + 1,), float)
        self._arclength = _Growable((), float)
        self._iterations = _Growable((), np.int64)
        self._steps = _Growable((), float)
        self._residuals = _Growable((), float)
        self._data_lists: dict[str, list] = {}
        self._data_cache: dict[str, np.ndarray] = {}
        self._data_cache_len = -1
        self.special_points: list[SpecialPoint] = []
        self.status = BranchStatus.RUNNING
        self.message = ""
        self.info: dict[str, Any] = {}

    # -- arrays ------------------------------------------------------------
    @property
    def parameter(self) -> np.ndarray:
        return self._parameter.view()

    @property
    def unknowns(self) -> np.ndarray:
        return self._unknowns.view()

    @property
    def tangents(self) -> np.ndarray:
        return self._tangents.view()

    @property
    def arclength(self) -> np.ndarray:
        return self._arclength.view()

    @property
    def newton_iterations(self) -> np.ndarray:
        return self._iterations.view()

    @property
    def step_sizes(self) -> np.ndarray:
        return self._steps.view()

    @property
    def residual_norms(self) -> np.ndarray:
        return self._residuals.view()

    @property
    def point_data(self) -> dict[str, np.ndarray]:
        n = len(self)
        if self._data_cache_len != n:
            cache = {}
            for name, values in self._data_lists.items():
                arr = np.stack(values) if values else np.empty((0,))
                arr.flags.writeable = False
                cache[name] = arr
            self._data_cache = cache
            self._data_cache_len = n
        return dict(self._data_cache)

    def __len__(self) -> int:
        return self._parameter._n

    # -- queries -----------------------------------------------------------
    def points_of_kind(self, kind: SpecialKind | str) -> list[SpecialPoint]:
        """Special points of one kind, in order along the branch."""
        kind = SpecialKind(kind)
        return [p for p in self.special_points if p.kind is kind]

    def point(self, index: int) -> tuple[np.ndarray, float]:
        """``(u, lam)`` of stored point ``index`` (copies)."""
        return self.unknowns[index].copy(), float(self.parameter[index])

    def resume_arguments(self, index: int = -1) -> dict:
        """Keyword arguments to restart :func:`contin.engine.continuation.continuation`
        from stored point ``index`` in the same direction:
        ``{"u0": ..., "lam0": ..., "tangent": ...}``."""
        return {
            "u0": self.unknowns[index].copy(),
            "lam0": float(self.parameter[index]),
            "tangent": self.tangents[index].copy(),
        }

    def to_dict(self) -> dict:
        """Plain representation (numpy arrays, strings) for saving."""
        return {
            "parameter_name": self.parameter_name,
            "parameter": self.parameter.copy(),
            "unknowns": self.unknowns.copy(),
            "tangents": self.tangents.copy(),
            "arclength": self.arclength.copy(),
            "newton_iterations": self.newton_iterations.copy(),
            "step_sizes": self.step_sizes.copy(),
            "residual_norms": self.residual_norms.copy(),
            "point_data": {k: v.copy() for k, v in self.point_data.items()},
            "special_points": [p.to_dict() for p in self.special_points],
            "status": self.status.value,
            "message": self.message,
            "info": _to_builtin(self.info),
        }

    @classmethod
    def from_dict(cls, d: dict) -> "Branch":
        """Inverse of :meth:`to_dict`."""
        unknowns = np.asarray(d["unknowns"], dtype=float)
        branch = cls(d["parameter_name"], unknowns.shape[1])
        builder = BranchBuilder(branch=branch)
        data = d.get("point_data", {})
        for i in range(unknowns.shape[0]):
            builder.append_point(
                u=unknowns[i],
                lam=float(d["parameter"][i]),
                tangent=np.asarray(d["tangents"][i]),
                s=float(d["arclength"][i]),
                newton_iterations=int(d["newton_iterations"][i]),
                step_size=float(d["step_sizes"][i]),
                residual_norm=float(d["residual_norms"][i]),
                data={k: np.asarray(v)[i] for k, v in data.items()},
            )
        for sp in d.get("special_points", []):
            branch.special_points.append(sp if isinstance(sp, SpecialPoint) else SpecialPoint.from_dict(sp))
        branch.status = BranchStatus(d.get("status", "running"))
        branch.message = d.get("message", "")
        branch.info = dict(d.get("info", {}))
        return branch

    def summary(self) -> str:
        """One line per special point, preceded by the status line."""
        lines = [
            f"branch in {self.parameter_name}: {len(self)} points, status {self.status.value}"
            + (f" ({self.message})" if self.message else "")
        ]
        for p in self.special_points:
            flag = "" if p.located else "  [not located]"
            lines.append(f"  {p.kind.value:9s} {self.parameter_name}={p.parameter:.10g}  after point {p.index}{flag}")
        return "\n".join(lines)

    def __repr__(self) -> str:
        if len(self):
            rng = f", {self.parameter_name} in [{self.parameter.min():.6g}, {self.parameter.max():.6g}]"
        else:
            rng = ""
        return (
            f"Branch({len(self)} points{rng}, {len(self.special_points)} special points, "
            f"status={self.status.value})"
        )


class BranchBuilder:
    """Incremental construction of a :class:`Branch` (used by the engine).

    Parameters
    ----------
    parameter_name : str
    n_unknowns : int
    branch : Branch, optional
        Existing (empty or partial) branch to append to instead.
    """

    def __init__(self, parameter_name: str = "lambda", n_unknowns: int = 0, *, branch: Branch | None = None):
        self.branch = branch if branch is not None else Branch(parameter_name, n_unknowns)

    def append_point(
        self,
        u: np.ndarray,
        lam: float,
        tangent: np.ndarray,
        s: float,
        newton_iterations: int,
        step_size: float,
        residual_norm: float,
        data: dict | None = None,
    ) -> int:
        """Validate and store one converged point; return its index.

        Raises
        ------
        PointRejected
            If any value is non-finite, a shape is wrong, or the monitored
            names differ from those of the previous points. Nothing is stored
            in that case.
        """
        b = self.branch
        m = b.n_unknowns
        u = np.asarray(u, dtype=float).reshape(-1)
        tangent = np.asarray(tangent, dtype=float).reshape(-1)
        if u.shape != (m,):
            raise PointRejected(f"unknowns have shape {u.shape}, expected ({m},)")
        if tangent.shape != (m + 1,):
            raise PointRejected(f"tangent has shape {tangent.shape}, expected ({m + 1},)")
        scalars = {"parameter": lam, "arclength": s, "step_size": step_size, "residual_norm": residual_norm}
        for name, value in scalars.items():
            if not np.isfinite(value):
                raise PointRejected(f"non-finite {name} ({value})")
        if not np.all(np.isfinite(u)):
            raise PointRejected("non-finite unknowns")
        if not np.all(np.isfinite(tangent)):
            raise PointRejected("non-finite tangent")
        data = {} if data is None else data
        values = {}
        for name, value in data.items():
            arr = np.array(value, copy=True)
            if arr.dtype == object or not np.all(np.isfinite(arr)):
                raise PointRejected(f"non-finite or non-numeric monitored value {name!r}")
            values[name] = arr
        if len(b) and set(values) != set(b._data_lists):
            raise PointRejected(
                f"monitored names changed from {sorted(b._data_lists)} to {sorted(values)}"
            )
        for name, arr in values.items():
            prev = b._data_lists.get(name)
            if prev and prev[0].shape != arr.shape:
                raise PointRejected(
                    f"monitored value {name!r} changed shape from {prev[0].shape} to {arr.shape}"
                )
        b._parameter.append(float(lam))
        b._unknowns.append(u)
        b._tangents.append(tangent)
        b._arclength.append(float(s))
        b._iterations.append(int(newton_iterations))
        b._steps.append(float(step_size))
        b._residuals.append(float(residual_norm))
        for name, arr in values.items():
            b._data_lists.setdefault(name, []).append(arr)
        return len(b) - 1

    def add_special(self, point: SpecialPoint) -> None:
        """Append a special point (kept sorted by position along the branch)."""
        sp = self.branch.special_points
        sp.append(point)
        sp.sort(key=lambda p: (p.s, p.index))

    def finish(self, status: BranchStatus, message: str = "") -> Branch:
        self.branch.status = BranchStatus(status)
        self.branch.message = message
        return self.branch
