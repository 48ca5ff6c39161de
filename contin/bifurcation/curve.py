"""A fold or period-doubling curve in the plane of two parameters, as traced: points, special points, ends.

:class:`BifurcationCurve` holds the curve traced by
:func:`contin.bifurcation.two_parameter.continue_curve`, in order along it,
with its codimension-two and end points (:class:`CurvePoint`), and solves
exactly for its points at a value of the second parameter
(:meth:`BifurcationCurve.crossings`).
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from contin.bifurcation.curve_system import CurveKind
from contin.engine.branch import BranchStatus, SpecialKind
from contin.engine.continuation import ContinuationOptions, continuation

__all__ = ["BifurcationCurve", "CurvePoint"]


@dataclasses.dataclass
class CurvePoint:
    """A special point of a curve (codimension two, turning point, start or end).

    Attributes
    ----------
    kind : SpecialKind
        ``cusp``, ``fold_flip``, ``extremum``, ``start`` or ``end``.
    p1, p2 : float
        Both parameters.
    unknowns : ndarray, shape (m,)
        Harmonic-balance coefficients there.
    index : int
        Row of the curve just before the point.
    located : bool
    message : str
    data : dict
        For ``extremum``: ``{"parameter": name}`` of the parameter that turns.
    """

    kind: SpecialKind
    p1: float
    p2: float
    unknowns: np.ndarray
    index: int
    located: bool = True
    message: str = ""
    data: dict = dataclasses.field(default_factory=dict)


@dataclasses.dataclass(eq=False)
class BifurcationCurve:
    """A fold or period-doubling curve in the plane of two parameters.

    Attributes
    ----------
    kind : CurveKind
    parameters : tuple of str
        ``(p1, p2)``.
    nu, harmonics : int
        Order and harmonic count of the periodic solutions on the curve.
    p1, p2 : ndarray, shape (P,)
        The curve, in order along it.
    unknowns : ndarray, shape (P, m)
        Harmonic-balance coefficients at each point.
    special_points : list of CurvePoint
        In order along the curve.
    ends : list of dict
        ``{"side", "status", "message"}`` for each traced direction.
    start_index : int
        Row of the start point.
    problem : SingularityProblem
        For :meth:`crossings`.
    branches : list of Branch
        The engine's branches (diagnostics).
    tangents : ndarray, shape (P, m+2)
        Unit tangents in the engine's scaled coordinates ``(u/su, p1/s1, p2/s2)``,
        oriented along the curve.
    scales : tuple
        ``(su, s2)``: scales of ``z = (u, p1)`` (shape (m+1,)) and of ``p2``.
    """

    kind: CurveKind
    parameters: tuple
    nu: int
    harmonics: int
    p1: np.ndarray
    p2: np.ndarray
    unknowns: np.ndarray
    special_points: list
    ends: list
    start_index: int
    problem: Any = None
    branches: list = dataclasses.field(default_factory=list)
    tangents: np.ndarray | None = None
    scales: tuple = (None, 1.0)

    def __len__(self) -> int:
        return int(self.p1.size)

    @property
    def closed(self) -> bool:
        return any(e["status"] == BranchStatus.CLOSED_LOOP.value for e in self.ends)

    @property
    def complete(self) -> bool:
        """Every traced direction ended at a range bound (also after turning back) or closed the loop."""
        ok = (BranchStatus.RANGE_END.value, BranchStatus.TURNED_BACK.value, BranchStatus.CLOSED_LOOP.value)
        return bool(self.ends) and all(e["status"] in ok for e in self.ends)

    def points_of_kind(self, kind) -> list:
        kind = SpecialKind(kind)
        return [p for p in self.special_points if p.kind is kind]

    def crossings(self, p2_value: float, options: ContinuationOptions | None = None) -> list[tuple[float, np.ndarray]]:
        """Points of the curve at ``p2 = p2_value``, solved exactly (not interpolated).

        From the first point of every stored segment whose ends bracket
        ``p2_value``, the curve is continued with the engine (same scaling,
        oriented along the curve) until it lands exactly on ``p2_value``.

        Parameters
        ----------
        p2_value : float
        options : ContinuationOptions, optional
            Step control (default: steps of at most the segment's length).

        Returns
        -------
        list of (p1, u)
            ``u`` of shape (m,); segments whose solve fails are left out.
        """
        out = []
        p2 = self.p2
        m = self.problem.m
        su, sl = self.scales
        for i in range(len(self) - 1):
            a, b = p2[i] - p2_value, p2[i + 1] - p2_value
            if a == 0.0:
                out.append((float(self.p1[i]), self.unknowns[i].copy()))
                continue
            if a * b >= 0:
                continue
            z0 = np.concatenate([self.unknowns[i], [self.p1[i]]])
            x0 = np.concatenate([z0 / su, [p2[i] / sl]])
            x1 = np.concatenate([self.unknowns[i + 1] / su[:m], [self.p1[i + 1] / su[m], p2[i + 1] / sl]])
            h = float(np.linalg.norm(x1 - x0))
            opts = options or ContinuationOptions(ds=max(0.25 * h, 1e-6), ds_max=max(0.5 * h, 1e-6), max_points=200)
            opts = opts.replace(detect_folds=False, detect_branch_points=False, parameter_scale=sl,
                                direction=1 if p2_value > p2[i] else -1)
            self.problem.initialize_borders(z0, float(p2[i]))
            br = continuation(self.problem, z0, float(p2[i]), sorted((float(p2[i]), p2_value)), opts,
                              tangent=self.tangents[i], solve_start=False,
                              callback=lambda b, j: self.problem.update_borders(b.unknowns[j], b.parameter[j]))
            if len(br) > 1 and br.parameter[-1] == p2_value:
                out.append((float(br.unknowns[-1][m]), br.unknowns[-1][:m].copy()))
        if len(self) and p2[-1] == p2_value:
            out.append((float(self.p1[-1]), self.unknowns[-1].copy()))
        return out

    def summary(self) -> str:
        a, b = self.parameters
        lines = [f"{self.kind.value} curve in ({a}, {b}): {len(self)} points, nu={self.nu}, H={self.harmonics}"
                 + (", closed" if self.closed else "")]
        if len(self):
            lines.append(f"  {a} in [{self.p1.min():.8g}, {self.p1.max():.8g}], {b} in [{self.p2.min():.8g}, "
                         f"{self.p2.max():.8g}]")
        for e in self.ends:
            lines.append(f"  {e['side']}: {e['status']} ({e['message']})")
        for p in self.special_points:
            flag = "" if p.located else "  [not located]"
            extra = f" in {p.data['parameter']}" if p.kind is SpecialKind.EXTREMUM else ""
            lines.append(f"  {p.kind.value:9s}{extra} {a}={p.p1:.10g} {b}={p.p2:.10g}{flag}")
        return "\n".join(lines)
