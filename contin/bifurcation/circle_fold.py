"""Turning a fold of a torus: steps of an invariant circle at a fixed size, the parameter free.

Steps in the parameter (:mod:`contin.bifurcation.circle_steps`) cannot pass a
fold of the torus: beyond it there is no circle at the next ``lam``. Near the
fold the branch is a graph over the circle's size instead (the two halves that
meet there are a larger and a smaller torus). A size step fixes the circle's
extent along its own shape and solves for the points, ``rho`` and ``lam``
together:

    l(U) = sum_j u_j . d_j = 1 + delta,      d_j = (a_j - abar) / sum_l |a_l - abar|^2,

with ``a`` the last circle and ``abar`` its mean point (``sum_j d_j = 0``, so
``l`` measures the extent about any centre; ``l(a) = 1``, and a circle
shrunk about its centre by ``1 + delta`` has ``l = 1 + delta``). Newton's
matrix is the circle's Jacobian bordered by the ``lam`` column and the row
``d``:

    [ R_u   R_lam ] [ du   ]      [ R              ]
    [ d^T   0     ] [ dlam ]  = - [ l(U) - 1 - delta ],

the same linearisation as a step in ``lam``. This is pseudo-arclength
continuation with the circle's shape in place of the branch's tangent: it
reads no tangent, so the corners that the contact puts into a discretised
circle branch do not throw it, and at a smooth fold ``lam`` turns while the
size goes on. The fold itself is the extremum of ``lam`` over the size,
found by successive parabolic interpolation through solved circles (Brent,
*Algorithms for Minimization without Derivatives*, 1973, ch. 5).
"""

from __future__ import annotations

import numpy as np

from contin.engine.newton import NUMERICAL_ERRORS, newton

__all__ = ["circle_size", "fold_vertex", "refine_fold", "scaled", "shape_direction", "size_step"]

#: most circles solved to locate a fold's parameter between the circles around the turn
REFINE_ITER = 6


def circle_size(problem, u) -> float:
    """The circle's RMS distance of its points from their mean (a size that scales with the circle)."""
    U, _ = problem.blocks(u)
    return float(np.sqrt(np.mean(np.sum((U - U.mean(axis=0)) ** 2, axis=1))))


def shape_direction(problem, u) -> np.ndarray:
    """``d`` (module docstring) of the circle ``u``, shape (N, 2n)."""
    U, _ = problem.blocks(u)
    D = U - U.mean(axis=0)
    return D / float(np.sum(D * D))


def size_step(problem, x_from, delta: float, guess, options, *, divergence_factor: float = 1e6):
    """The circle ``1 + delta`` times the size of ``x_from`` along its shape, ``lam`` free (module docstring).

    Parameters
    ----------
    problem : InvariantCircleProblem
    x_from : array_like, shape (problem.size + 1,)
        The circle the step starts from and its parameter, ``(u, lam)``.
    delta : float
        The relative change of the size.
    guess : array_like, shape (problem.size + 1,)
        Newton's initial ``(u, lam)``.
    options : ContinuationOptions
        ``newton_tol`` and ``newton_max_iter``.

    Returns
    -------
    NewtonResult
        ``x`` is ``(u, lam)``; a lazy Jacobian (chord updates by plain flows), as for the steps in ``lam``.
    """
    m = problem.size
    d = shape_direction(problem, np.asarray(x_from, dtype=float)[:m]).ravel()
    target = 1.0 + float(delta)

    def residual(x):
        return np.r_[problem.residual(x[:m], x[m]), np.dot(x[:m - 1], d) - target]

    def fun_and_jac(x):
        R, Ju, Jlam = problem.linearize(x[:m], x[m])
        J = np.zeros((m + 1, m + 1))
        J[:m, :m], J[:m, m], J[m, :m - 1] = Ju, Jlam, d
        return np.r_[R, np.dot(x[:m - 1], d) - target], J

    return newton(fun_and_jac, np.array(guess, dtype=float), float(options.newton_tol),
                  int(options.newton_max_iter), residual=residual, divergence_factor=divergence_factor)


def scaled(problem, x, delta: float) -> np.ndarray:
    """``(u, lam)`` with the circle of ``x`` scaled by ``1 + delta`` about its mean point (a size step's first
    guess)."""
    m = problem.size
    x = np.asarray(x, dtype=float)
    U = x[:m - 1].reshape(problem.points, -1)
    c = U.mean(axis=0)
    return np.r_[(c + (1.0 + delta) * (U - c)).ravel(), x[m - 1:]]


def fold_vertex(s, lam) -> float:
    """The abscissa of the vertex of the parabola through three points ``(s_k, lam_k)`` (nan if they are on a
    line)."""
    (s0, s1, s2), (l0, l1, l2) = s, lam
    num = (s1 - s0) ** 2 * (l1 - l2) - (s1 - s2) ** 2 * (l1 - l0)
    den = (s1 - s0) * (l1 - l2) - (s1 - s2) * (l1 - l0)
    return s1 - 0.5 * num / den if den != 0.0 else float("nan")


def refine_fold(problem, xs, tol: float, options, *, divergence_factor: float = 1e6):
    """The fold between three circles around a turn of ``lam`` (the middle one the extreme), by successive
    parabolic interpolation of ``lam`` over the size.

    Parameters
    ----------
    xs : sequence of three arrays (problem.size + 1,)
        ``(u, lam)`` of the circles, in order along the branch.
    tol : float
        The fold is located once a circle solved at the vertex of the parabola through the three circles
        about the extreme ``lam`` differs from that extreme by at most this.

    Returns
    -------
    (x, located, interval)
        The circle with the extreme ``lam`` found, whether ``tol`` was met, and the interval from its ``lam``
        beyond it by the last circle's change of the extreme (low first).
    """
    m = problem.size
    pts = [(circle_size(problem, x[:m]), float(x[m]), np.asarray(x, dtype=float)) for x in xs]
    way = 1.0 if pts[1][1] >= max(pts[0][1], pts[2][1]) else -1.0  # a maximum of lam or a minimum
    located = False
    change = abs(pts[1][1] - max(pts[0][1], pts[2][1], key=lambda v: way * v))  # the turn's depth, to begin
    for _ in range(REFINE_ITER):
        pts.sort(key=lambda p: p[0])
        best = max(pts, key=lambda p: way * p[1])
        s_new = fold_vertex([p[0] for p in pts], [p[1] for p in pts])
        if not (pts[0][0] < s_new < pts[2][0]) or abs(s_new - best[0]) <= 1e-12 * best[0]:
            break
        near = min(pts, key=lambda p: abs(p[0] - s_new))
        delta = s_new / near[0] - 1.0
        try:
            r = size_step(problem, near[2], delta, scaled(problem, near[2], delta), options,
                          divergence_factor=divergence_factor)
        except NUMERICAL_ERRORS:
            break
        if not r.converged:
            break
        new = (circle_size(problem, r.x[:m]), float(r.x[m]), r.x)
        change = abs(new[1] - best[1])
        # the three points about the extreme lam among them
        pts = sorted(pts + [new], key=lambda p: p[0])
        k = min(max(max(range(len(pts)), key=lambda i: way * pts[i][1]), 1), len(pts) - 2)
        pts = pts[k - 1:k + 2]
        if change <= tol:
            located = True
            break
    best = max(pts, key=lambda p: way * p[1])
    # beyond the extreme circle by at most the last refinement's change (where a corner of the discretised
    # branch, not a parabola, shapes the turn, the vertices are no closer)
    far = best[1] + way * change
    return best[2], located, (min(best[1], far), max(best[1], far))
