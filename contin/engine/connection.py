"""A check, from the problem alone, that a finished branch is one connected curve (no silent jumps)."""

from __future__ import annotations

import math

import numpy as np

from contin.engine.branch import Branch, SpecialKind
from contin.engine.newton import newton
from contin.engine.problem import Problem

__all__ = ["connection_report"]

#: Hyperplanes from a stored point to the chord's midpoint when the direct solve fails.
CONNECTION_SUBSTEPS = 4


def connection_report(problem: Problem, branch: Branch, *, max_angle_deg: float = 45.0, midpoint: bool = True,
                      max_offset: float = 0.5, newton_tol: float | None = None, skip_kinks: bool = True) -> dict:
    """Check that consecutive stored points of a branch lie on one connected curve.

    An invariant against silent branch jumping, computed from the problem
    alone (not from the engine's own tangents):

    - at each stored point the tangent is the null vector of the scaled
      ``[Ju su, Jlam sl]`` (oriented along the secant); the angle between
      the secant to the next point and the tangents at both ends must stay
      below ``max_angle_deg`` (a smooth arc of curvature ``k`` and length
      ``L`` gives about ``k L / 2``);
    - with ``midpoint``, the problem is solved again on the hyperplane
      through the chord's midpoint normal to the chord; the solution must
      lie within ``max_offset * L`` of the midpoint, i.e. between the two
      points, not on another sheet. Newton starts from the cubic Hermite
      midpoint; where that lies outside the basin (contact orbits with many
      harmonics), the midpoint hyperplane is reached from point ``index``
      over ``CONNECTION_SUBSTEPS`` hyperplanes parallel to it, each solve
      started on the previous solution's tangent.

    Steps across a recorded corner (``kink`` special point) are skipped with
    ``skip_kinks``: the tangent jumps there by construction.

    Parameters
    ----------
    problem : Problem
    branch : Branch
        Traced with ``problem``; its ``info`` holds the scales.
    max_angle_deg, max_offset : float
    midpoint : bool
    newton_tol : float, optional
        Tolerance of the midpoint solves (default: the branch's
        ``newton_tol`` times 10, or 1e-9).
    skip_kinks : bool

    Returns
    -------
    dict
        ``ok`` (bool), ``max_angle_deg``, ``max_offset`` (midpoint distance
        over chord length), ``checked`` (number of steps checked) and
        ``failures``: list of ``(index, reason)`` for the step from point
        ``index`` to ``index + 1``.
    """
    n = len(branch)
    m = branch.unknowns.shape[1] if n else 0
    su = np.broadcast_to(np.asarray(branch.info.get("unknown_scale", 1.0), dtype=float), (m,))
    sl = float(branch.info.get("parameter_scale", 1.0))
    opts = branch.info.get("options") or {}
    tol = newton_tol if newton_tol is not None else 10.0 * float(opts.get("newton_tol", 1e-10))
    kinks = {sp.index for sp in branch.special_points if sp.kind == SpecialKind.KINK} if skip_kinks else set()
    X = np.column_stack([branch.unknowns / su, branch.parameter / sl]) if n else np.zeros((0, m + 1))
    failures: list = []
    worst_angle, worst_offset, checked = 0.0, 0.0, 0

    def jac(x):
        R, Ju, Jlam = problem.linearize(x[:m] * su, float(x[m] * sl))
        return np.asarray(R, dtype=float), np.column_stack([np.asarray(Ju, float) * su, np.asarray(Jlam, float) * sl])

    def tangent(x, d):
        _, Jh = jac(x)
        A = np.vstack([Jh, d])
        rhs = np.zeros(m + 1)
        rhs[-1] = 1.0
        try:
            z = np.linalg.solve(A, rhs)
        except np.linalg.LinAlgError:
            return None
        return z / np.linalg.norm(z)

    def angle(a, b):
        return math.degrees(math.acos(float(np.clip(abs(a @ b), -1.0, 1.0))))

    def on_plane(xm, d):
        def fun(x):  # the residual bordered by the hyperplane through xm normal to d
            R, Jh = jac(x)
            return np.concatenate([R, [d @ (x - xm)]]), np.vstack([Jh, d])
        return fun

    def march(x, d, L, tol, substeps=CONNECTION_SUBSTEPS):
        # a contact orbit's basin can be narrower than the Hermite midpoint's distance to the curve: reach the
        # midpoint hyperplane from point i over hyperplanes normal to the chord, with the tangent's predictor
        x0, s_prev, res = x, 0.0, None
        for k in range(1, substeps + 1):
            s = 0.5 * L * k / substeps
            t = tangent(x, d)
            if t is None:
                break
            res = newton(on_plane(x0 + s * d, d), x + (s - s_prev) * t / (t @ d), tol, 30)
            if not res.converged:
                break
            x, s_prev = res.x, s
        return res

    for i in range(n - 1):
        if i in kinks or (i + 1) in kinks:
            continue
        d = X[i + 1] - X[i]
        L = float(np.linalg.norm(d))
        if L == 0.0:
            continue
        d = d / L
        checked += 1
        ends = [tangent(X[i], d), tangent(X[i + 1], d)]
        if any(t is None for t in ends):
            failures.append((i, "singular Jacobian at a stored point"))
            continue
        a = max(angle(d, t) for t in ends)
        worst_angle = max(worst_angle, a)
        if a > max_angle_deg:
            failures.append((i, f"secant and tangent differ by {a:.1f} deg"))
            continue
        if not midpoint:
            continue
        xm = 0.5 * (X[i] + X[i + 1])
        # Newton starts from the cubic Hermite midpoint of the two ends and their tangents (O(L^3) off the
        # curve, where the chord midpoint is O(L^2) off: small basins, a stiff contact, need the former)
        res = newton(on_plane(xm, d), xm + 0.125 * L * (ends[0] - ends[1]), tol, 30)
        if not res.converged:
            res = march(X[i], d, L, tol)
        if not res.converged:
            failures.append((i, f"no solution on the midpoint hyperplane ({res.message})"))
            continue
        off = float(np.linalg.norm(res.x - xm)) / L
        worst_offset = max(worst_offset, off)
        if off > max_offset:
            failures.append((i, f"the midpoint solution lies {off:.2g} chord lengths away from the chord"))
    return {"ok": not failures, "max_angle_deg": worst_angle, "max_offset": worst_offset, "checked": checked,
            "failures": failures}
