"""Dense output of a branch: solutions between its stored points, for smooth curves in figures.

A branch is stored as points ``(u_j, lam_j)`` with the continuation's unit
tangents. Between two consecutive points the branch is interpolated by a
cubic Hermite arc in the chord-length parameter ``tau`` (the cumulative
length of the chords, measured in the continuation's scales): at each end
the arc leaves along the stored tangent, turned into the unknowns' units,
with the interval's chord length as its speed, which makes the arc exact to
``O(L^4)`` on a smooth branch. Coefficients the tangent does not cover (the
dofs a condensed problem eliminated) take the derivative of the parabola
through the point and its two neighbours (Bessel's derivative). An interval
whose end tangents lean far off its chord (a corner, a jump) is drawn
straight.

Whatever a figure plots is evaluated on the interpolated coefficients with
the function that makes the CSV columns, so the curve between the points is
the measure of a solution, not a line drawn through two values. How many
points an interval gets follows how much the plotted curve turns there: a
straight stretch gets none, a bend up to ``per_interval``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np

from contin.output.checkpoint import decode

__all__ = ["DenseOptions", "HermitePath", "kept_indices", "dense_branch", "checkpoint_solutions", "as_number",
           "value_between"]


@dataclass(frozen=True)
class DenseOptions:
    """How densely a branch is drawn.

    Attributes
    ----------
    per_interval : int
        Most points added between two stored points.
    tolerance : float
        Largest sagitta left between the drawn points, as a fraction of the
        plot's span (the bend of a chord that is not drawn).
    budget : int
        Most points added to one branch (the counts are scaled down to it).
    straight_cosine : float
        An interval whose end tangents make a cosine below this with its
        chord is drawn straight.
    """

    per_interval: int = 8
    tolerance: float = 2e-4
    budget: int = 4000
    straight_cosine: float = 0.3


def kept_indices(dofs: Sequence[int] | None, n_dof: int, H: int) -> np.ndarray | None:
    """Positions in a full coefficient vector (harmonic-major, ``n_dof*(2H+1)``) of the ``dofs``' coefficients.

    None for None (every coefficient kept).
    """
    if dofs is None:
        return None
    d = np.asarray(dofs, dtype=int)
    return (np.arange(2 * H + 1)[:, None] * n_dof + d[None, :]).reshape(-1)


def _bessel(tau: np.ndarray, X: np.ndarray) -> np.ndarray:
    """Derivatives ``dX/dtau`` (P, m) at the nodes from the parabola through each node and its neighbours."""
    P = X.shape[0]
    D = np.zeros_like(X)
    h = np.diff(tau)
    slope = np.diff(X, axis=0) / np.where(h > 0, h, 1.0)[:, None]
    if P == 2:
        return np.vstack([slope, slope])
    w0 = (h[1:] / (h[:-1] + h[1:]))[:, None]
    D[1:-1] = w0 * slope[:-1] + (1.0 - w0) * slope[1:]
    D[0] = 2.0 * slope[0] - D[1] if P > 2 else slope[0]  # the end parabolas
    D[-1] = 2.0 * slope[-1] - D[-2]
    return D


@dataclass(frozen=True)
class HermitePath:
    """Piecewise cubic Hermite interpolation of a branch in its chord-length parameter.

    Attributes
    ----------
    X : ndarray, shape (P, M+1)
        Stored points: full coefficients, then the parameter.
    T : ndarray, shape (P, M+1)
        Derivatives ``dX/dtau`` at the points.
    L : ndarray, shape (P-1,)
        Speeds of the arcs at their ends: the chord lengths (in the continuation's scaled norm of
        the tangent's components) over ``cos^2(theta/4)``, ``theta`` the turn of the tangent over
        the interval (which makes the arc of a circle exact to ``O(theta^6)``).
    straight : ndarray of bool, shape (P-1,)
        Intervals drawn straight.
    """

    X: np.ndarray
    T: np.ndarray
    L: np.ndarray
    straight: np.ndarray

    @classmethod
    def build(cls, lam, U, directions=None, kept=None, scale=None,
              options: DenseOptions = DenseOptions()) -> "HermitePath":
        """The path through the points ``(U[j], lam[j])``.

        Parameters
        ----------
        lam : array_like, shape (P,)
        U : array_like, shape (P, M)
            Full coefficients.
        directions : array_like, shape (P, K+1), optional
            Tangents in the units of the unknowns, their parameter component
            last, over the coefficients ``kept`` (rows of NaN or missing: none
            known at that point).
        kept : array_like of int, shape (K,), optional
            Positions in ``U``'s columns that ``directions`` covers (all by default).
        scale : array_like, shape (K+1,), optional
            The norm's scales of those components and the parameter
            (the continuation's ``unknown_scale`` and ``parameter_scale``).
        """
        lam = np.asarray(lam, dtype=float)
        U = np.asarray(U, dtype=float).reshape(lam.size, -1)
        X = np.column_stack([U, lam])
        P, m = X.shape
        cols = np.arange(m) if kept is None else np.append(np.asarray(kept, dtype=int), m - 1)
        if scale is None or np.size(scale) != cols.size:
            # one scale for the coefficients, one for the parameter
            su = max(float(np.abs(U).max(initial=0.0)), 1e-300)
            sl = max(float(np.ptp(lam)) if P > 1 else 0.0, 1e-12 * max(1.0, float(np.abs(lam).max(initial=0.0))))
            scale = np.append(np.full(cols.size - 1, su), sl)
        w = 1.0 / np.maximum(np.abs(np.asarray(scale, dtype=float)), 1e-300)
        chords = np.diff(X[:, cols], axis=0) * w
        L = np.linalg.norm(chords, axis=1)
        tau = np.concatenate([[0.0], np.cumsum(L)])
        T = _bessel(tau, X) if P > 1 else np.zeros_like(X)
        if directions is not None and P > 1:
            Dk = np.asarray(directions, dtype=float).reshape(P, -1)
            for j in range(P):
                d = Dk[j]
                if d.size != cols.size or not np.all(np.isfinite(d)):
                    continue
                n = np.linalg.norm(d * w)
                if n == 0.0:
                    continue
                d = d / n
                if np.dot(d * w, T[j, cols] * w) < 0.0:  # oriented along the branch
                    d = -d
                T[j, cols] = d
        straight = np.zeros(max(P - 1, 0), dtype=bool)
        speed = L.copy()
        for i in range(P - 1):
            if L[i] == 0.0:
                straight[i] = True
                continue
            c = chords[i] / L[i]
            ends = [T[j, cols] * w for j in (i, i + 1)]
            norms = [np.linalg.norm(t) for t in ends]
            if min(norms) == 0.0 or any(np.dot(t, c) < options.straight_cosine * n for t, n in zip(ends, norms)):
                straight[i] = True
                continue
            turn = np.arccos(np.clip(np.dot(ends[0], ends[1]) / (norms[0] * norms[1]), -1.0, 1.0))
            speed[i] = L[i] / np.cos(turn / 4.0) ** 2
        return cls(X, T, speed, straight)

    def at(self, i: np.ndarray, sigma: np.ndarray) -> np.ndarray:
        """Points at the fractions ``sigma`` (K,) of the intervals ``i`` (K,): (K, M+1)."""
        i = np.asarray(i, dtype=int)
        s = np.asarray(sigma, dtype=float)[:, None]
        x0, x1 = self.X[i], self.X[i + 1]
        L = self.L[i][:, None]
        m0, m1 = L * self.T[i], L * self.T[i + 1]
        line = ~self.straight[i]
        m0 = np.where(line[:, None], m0, x1 - x0)
        m1 = np.where(line[:, None], m1, x1 - x0)
        s2, s3 = s * s, s * s * s
        return ((2 * s3 - 3 * s2 + 1) * x0 + (s3 - 2 * s2 + s) * m0 + (-2 * s3 + 3 * s2) * x1
                + (s3 - s2) * m1)


def _sub_counts(x, y, log_x, log_y, options: DenseOptions) -> np.ndarray:
    """Points to add in each interval of the stored points' plotted polyline (x, y) (P,)."""
    px = np.log10(np.where(x > 0, x, np.nan)) if log_x else np.asarray(x, dtype=float)
    py = np.log10(np.where(y > 0, y, np.nan)) if log_y else np.asarray(y, dtype=float)
    span = [np.nanmax(v) - np.nanmin(v) if np.any(np.isfinite(v)) else 0.0 for v in (px, py)]
    p = np.column_stack([px / (span[0] or 1.0), py / (span[1] or 1.0)])
    seg = np.diff(p, axis=0)
    L = np.hypot(seg[:, 0], seg[:, 1])
    ang = np.arctan2(seg[:, 1], seg[:, 0])
    turn = np.abs((np.diff(ang) + np.pi) % (2 * np.pi) - np.pi)  # (P-2,) at the inner points
    turn = np.concatenate([[0.0], turn, [0.0]])
    bend = np.maximum(turn[:-1], turn[1:])
    bend = np.where(np.isfinite(bend), bend, np.pi)
    sagitta = np.where(np.isfinite(L), L, 0.0) * bend / 8.0
    k = np.ceil(np.sqrt(sagitta / options.tolerance)) - 1.0
    n = np.clip(k, 0, options.per_interval).astype(int)
    if n.sum() > options.budget:
        n = np.floor(n * (options.budget / n.sum())).astype(int)
    return n


def dense_branch(lam, U, evaluate: Callable | None, *, directions=None, kept=None, scale=None, stable=None,
                 special=(), node_xy=None, log_x: bool = False, log_y: bool = False,
                 options: DenseOptions = DenseOptions()) -> dict:
    """The plotted curve of a branch with points between the stored ones, and its special points on it.

    Parameters
    ----------
    lam : array_like, shape (P,)
    U : array_like, shape (P, M)
        Full coefficients of the stored points.
    evaluate : callable or None
        ``evaluate(lam (K,), U (K, M)) -> (x (K,), y (K,))``: the plotted
        coordinates of solutions. None: only ``node_xy`` is drawn (a column
        that is no function of the solution, such as a multiplier).
    directions, kept, scale
        As :meth:`HermitePath.build`.
    stable : sequence of (bool or None), length P, optional
        Stability of the stored points.
    special : sequence of dict
        Points to put on the curve: ``x``, ``y``, ``index`` (the stored
        point at or before it) and ``changes`` (True where the stability
        changes there). Each is inserted into the nearest segment near its
        index; where it changes the stability, the new style starts there.
    node_xy : (array (P,), array (P,)), optional
        Plotted coordinates of the stored points (evaluated if omitted).
    log_x, log_y : bool
        Logarithmic axes (the spacing of the added points follows them).

    Returns
    -------
    dict
        ``x`` (Q,), ``y`` (Q,), ``stable`` (list of Q flags, or None).
    """
    lam = np.asarray(lam, dtype=float)
    P = lam.size
    U = np.asarray(U, dtype=float).reshape(P, -1) if P else np.zeros((0, 0))
    if node_xy is None:
        node_xy = evaluate(lam, U) if P else (np.zeros(0), np.zeros(0))
    nx, ny = (np.asarray(v, dtype=float) for v in node_xy)
    flags = None if stable is None else list(stable)
    counts = (_sub_counts(nx, ny, log_x, log_y, options) if evaluate is not None and P > 1
              else np.zeros(max(P - 1, 0), dtype=int))
    sub_xy = (np.zeros(0), np.zeros(0))
    owner = np.repeat(np.arange(max(P - 1, 0)), counts)
    if owner.size:
        sigma = np.concatenate([np.arange(1, n + 1) / (n + 1.0) for n in counts if n > 0])
        path = HermitePath.build(lam, U, directions, kept, scale, options)
        Xd = path.at(owner, sigma)
        sub_xy = tuple(np.asarray(v, dtype=float) for v in evaluate(Xd[:, -1], Xd[:, :-1]))
    # the polyline: each stored point, then the points added after it; ``where`` is the interval of each vertex
    first = np.concatenate([[0], np.cumsum(counts + 1)])[:P]  # position of each stored point
    where = np.repeat(np.arange(P), np.append(counts + 1, 1)[:P]) if P else np.zeros(0, dtype=int)
    xs, ys = np.empty(where.size), np.empty(where.size)
    xs[first], ys[first] = nx, ny
    added = np.ones(where.size, dtype=bool)
    added[first] = False
    xs[added], ys[added] = sub_xy
    xs, ys, where = list(xs), list(ys), [int(w) for w in where]
    vflags = None if flags is None else [flags[w] for w in where]
    changes_at: dict[int, int] = {}  # interval -> position of the inserted change in the polyline
    for sp in sorted(special, key=lambda s: (int(s.get("index", 0)), float(s["x"]))):
        if not (np.isfinite(sp["x"]) and np.isfinite(sp["y"])) or len(xs) < 2:
            continue
        pos = _nearest_segment(xs, ys, where, sp, log_x, log_y)
        xs.insert(pos + 1, float(sp["x"]))
        ys.insert(pos + 1, float(sp["y"]))
        w = where[pos]
        where.insert(pos + 1, w)
        for key in list(changes_at):
            if changes_at[key] > pos:
                changes_at[key] += 1
        if vflags is not None:
            vflags.insert(pos + 1, vflags[pos])
            if sp.get("changes") and w + 1 < P and flags[w] != flags[w + 1] and w not in changes_at:
                changes_at[w] = pos + 1
    if vflags is not None:
        for w, pos in changes_at.items():  # the new style starts at the located change
            q = pos
            while q < len(xs) and where[q] == w:
                vflags[q] = flags[w + 1]
                q += 1
    return {"x": np.asarray(xs), "y": np.asarray(ys), "stable": vflags}


def _nearest_segment(xs, ys, where, sp, log_x, log_y) -> int:
    """Start of the polyline segment nearest to the special point, among those near its stored index."""
    x = np.asarray(xs, dtype=float)
    y = np.asarray(ys, dtype=float)
    if log_x:
        x = np.log10(np.where(x > 0, x, np.nan))
    if log_y:
        y = np.log10(np.where(y > 0, y, np.nan))
    sx = np.nanmax(x) - np.nanmin(x) or 1.0
    sy = np.nanmax(y) - np.nanmin(y) or 1.0
    px = np.log10(sp["x"]) if log_x and sp["x"] > 0 else sp["x"]
    py = np.log10(sp["y"]) if log_y and sp["y"] > 0 else sp["y"]
    w = np.asarray(where)
    idx = int(sp.get("index", 0))
    near = np.flatnonzero((w[:-1] >= idx - 2) & (w[:-1] <= idx + 1))
    if near.size == 0:
        near = np.arange(len(xs) - 1)
    a = np.column_stack([x[near] / sx, y[near] / sy])
    b = np.column_stack([x[near + 1] / sx, y[near + 1] / sy])
    p = np.array([px / sx, py / sy])
    d = b - a
    dd = np.maximum(np.einsum("ij,ij->i", d, d), 1e-300)
    t = np.clip(np.einsum("ij,ij->i", p - a, d) / dd, 0.0, 1.0)
    dist = np.linalg.norm(a + t[:, None] * d - p, axis=1)
    dist = np.where(np.isfinite(dist), dist, np.inf)
    return int(near[int(np.argmin(dist))])


def checkpoint_solutions(records) -> dict:
    """Row -> ``(u, tangent, su, sl, kept dofs, H, branch record, lam)`` of every point record of a checkpoint
    (:mod:`contin.output.checkpoint`), for the dense curves of a resumed run.

    ``u`` is as stored: the kept dofs' coefficients when the branch record says
    so (:func:`contin.output.expansion.stores_kept`). A point's tangent is in
    the scales the engine had when it stored the point: the point record's
    ``scale``; in a checkpoint of an earlier contin, those of its branch
    record, then of the engine record after each step.
    """
    scales, headers, out = {}, {}, {}
    for rec in records:
        j = rec["branch"]
        if rec["type"] == "branch":
            scales[j] = (rec.get("unknown_scale"), rec.get("parameter_scale"))
            headers[j] = rec
        elif rec["type"] == "engine" and not rec.get("stale"):
            st = rec["state"]
            scales[j] = (st.get("su"), st.get("sl"))
        elif rec["type"] == "point":
            if isinstance(rec.get("scale"), list) and len(rec["scale"]) == 2:  # the scales it was stored in
                scales[j] = tuple(rec["scale"])
            su, sl = (decode(v) for v in scales.get(j, (None, None)))
            h = headers.get(j, {})
            out[rec["row"]] = (rec["u"], rec["tangent"], su, sl, h.get("dofs"), rec.get("H") or h.get("H"), h,
                               rec["lam"])
    return out


def as_number(v) -> float:
    """A table cell as a float (NaN where empty or not a number)."""
    try:
        return float(v) if v is not None and v != "" else np.nan
    except (TypeError, ValueError):
        return np.nan


def value_between(x, y, j: int, at: float) -> float:
    """``y`` at ``x = at`` between the stored points ``j`` and ``j + 1``, linearly (x, y: (P,))."""
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    if x.size == 0:
        return np.nan
    j = min(max(int(j), 0), max(x.size - 2, 0))
    if x.size < 2 or x[j + 1] == x[j]:
        return float(y[j])
    return float(y[j] + (y[j + 1] - y[j]) * (at - x[j]) / (x[j + 1] - x[j]))
