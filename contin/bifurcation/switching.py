"""Branch switching at period doublings and branch points: the directions and the first points of new branches.

Period doubling (``pd``)
------------------------
At a period doubling of a branch of order ``nu`` a multiplier crosses -1: a
``2T``-periodic perturbation becomes neutral. In the harmonic-balance problem
of order ``2 nu`` (base phase ``theta' = theta/2``, ``2H`` harmonics by
default) the located solution is re-expressed with
:func:`contin.hb.harmonics.embed` (odd harmonics zero). Because it is
``T``-periodic, the order-``2nu`` Jacobian maps even harmonics to even and odd
to odd: it is block diagonal in the (even, odd) splitting, and the PD point is
where the *odd* block is singular (the even block is the order-``nu``
Jacobian, regular there). Its null vector ``phi`` (smallest right singular
vector of the odd block, :func:`period_doubling_direction`; or Hill's critical
eigenvector mapped to the doubled representation,
:func:`hill_vector_to_doubled`) is the direction of the new branch. The
symmetry ``theta' -> theta' + pi`` (odd harmonics change sign) makes the
bifurcation a pitchfork in the order-``2nu`` problem; ``+phi`` and ``-phi``
give the same periodic motion shifted by ``T``, so one side is enough.

The first point solves the bordered system (``lambda`` free)

    R(u, lambda) = 0,      phi . (u - u*) = eps,

by Newton from ``(u* + eps phi, lambda*)`` (Seydel, *Practical Bifurcation
and Stability Analysis*, 3rd ed., Springer 2010, sec. 5.6 and 7.6;
Doedel, Keller & Kernevez, Int. J. Bifurcation Chaos 1 (1991) 745-772).

Branch point (``bp``)
---------------------
At a simple branch point the augmented Jacobian ``[Ju Jlam]`` has a
two-dimensional null space; the second tangent is the null vector orthogonal
(in the engine's scaled coordinates) to the tangent of the traced branch. The
first point solves ``R = 0, t1 . (x - x*) = eps`` and both sides
(``+-eps``) are continued.

:func:`switch_at` gives the first points of the new branches at a located
special point; :mod:`contin.bifurcation.diagram` traces them and builds whole
diagrams.
"""

from __future__ import annotations

import dataclasses
from typing import Any, Callable, Sequence

import numpy as np

from contin.engine.branch import Branch, SpecialKind, SpecialPoint
from contin.engine.continuation import ContinuationOptions
from contin.engine.newton import newton
from contin.hb import aft
from contin.hb.harmonics import coefficient_blocks, embed
from contin.stability.hill import hill_spectrum

__all__ = [
    "BranchStart",
    "doubled_problem",
    "odd_indices",
    "period_doubling_direction",
    "hill_vector_to_doubled",
    "branch_point_direction",
    "first_point",
    "switch_at",
    "continuation_scales",
    "extended_nullvector",
]


@dataclasses.dataclass(eq=False)
class BranchStart:
    """A converged first point on a new branch and how it was found.

    Attributes
    ----------
    problem : object
        The problem of the new branch (the order-``2nu`` HB for a ``pd``).
    u : ndarray, shape (m,)
    lam : float
    tangent : ndarray, shape (m+1,)
        Unscaled unit tangent at the first point, pointing away from the
        bifurcation.
    kind : SpecialKind
        ``pd`` or ``bp``.
    direction : ndarray
        Predictor direction at the bifurcation: ``phi`` (shape (m,)) for a
        ``pd``, the scaled second tangent ``t1`` (shape (m+1,)) for a ``bp``.
    eps : float
        Offset actually used.
    side : int
        +1 or -1 (sign of ``eps``).
    bifurcation : tuple
        ``(u*, lam*)`` in the new problem's unknowns.
    newton_iterations : int
    residual_norm : float
    """

    problem: Any
    u: np.ndarray
    lam: float
    tangent: np.ndarray
    kind: SpecialKind
    direction: np.ndarray
    eps: float
    side: int
    bifurcation: tuple
    newton_iterations: int = 0
    residual_norm: float = float("nan")


def doubled_problem(hb, factor: int = 2, harmonics: int | None = None):
    """The HB problem of order ``factor*nu`` (``factor*H`` harmonics by default).

    The default keeps the discretisation of the original problem: ``factor*H``
    harmonics of ``w/(factor nu)`` and ``factor*N`` samples over the longer
    period (the same time step).
    """
    if harmonics is None:
        return hb.with_options(subharmonic=factor * hb.nu, harmonics=factor * hb.H, samples=factor * hb.N)
    return hb.with_options(subharmonic=factor * hb.nu, harmonics=int(harmonics))


def odd_indices(n: int, harmonics: int) -> np.ndarray:
    """Positions in ``u`` of the odd-harmonic coefficients (cos and sin), shape (2 n ceil(H/2),)."""
    idx = []
    for k in range(1, harmonics + 1, 2):
        idx.extend(range((2 * k - 1) * n, (2 * k + 1) * n))
    return np.array(idx, dtype=int)


def period_doubling_direction(hb2, u2: np.ndarray, lam: float, Ju: np.ndarray | None = None):
    """Null vector of the odd-harmonic block of the order-``2nu`` Jacobian.

    Parameters
    ----------
    hb2 : HarmonicBalance
        Problem of order ``2nu``.
    u2 : ndarray, shape (hb2.size,)
        The period-``T`` solution embedded (odd harmonics zero).
    lam : float
    Ju : ndarray, shape (hb2.size, hb2.size), optional

    Returns
    -------
    phi : ndarray, shape (hb2.size,)
        Unit vector with only odd-harmonic entries.
    sigma : ndarray, shape (2,)
        The two smallest singular values of the odd block, relative to the
        largest (a clear PD has ``sigma[0] << sigma[1]``).
    """
    if Ju is None:
        _, Ju, _ = hb2.linearize(u2, lam)
    odd = odd_indices(hb2.n, hb2.H)
    B = Ju[np.ix_(odd, odd)]
    _, sv, vt = np.linalg.svd(B)
    phi = np.zeros(hb2.size)
    phi[odd] = vt[-1]
    # a sign convention, so that repeated calls agree
    j = int(np.argmax(np.abs(phi)))
    phi *= np.sign(phi[j])
    return phi, np.array([sv[-1], sv[-2] if sv.size > 1 else np.inf]) / sv[0]


def hill_vector_to_doubled(q: np.ndarray, exponent: complex, Omega: float, n: int, harmonics: int,
                           part: str = "real") -> np.ndarray:
    """Map Hill's critical eigenvector at a PD to the order-``2nu`` coefficients.

    The perturbation is ``e^{s t} y(theta)`` with ``Im s = rho Omega``, ``rho``
    a half-integer at a PD, so on the doubled base phase ``theta' = theta/2``
    it is ``e^{2 i rho theta'} y(2 theta')``: odd harmonics of ``theta'`` only.
    Its real (or imaginary) part is projected on ``harmonics`` harmonics.

    Parameters
    ----------
    q : ndarray, shape (n(2H+1),) complex
        Hill eigenvector (coefficients of ``y``, complex).
    exponent : complex
        Its eigenvalue ``s``.
    Omega : float
        Base frequency ``w/nu`` of the original problem.
    n : int
    harmonics : int
        ``H2`` of the doubled problem.
    part : {'real', 'imag'}

    Returns
    -------
    ndarray, shape (n(2 H2 + 1),)
        Unit 2-norm.
    """
    Q = coefficient_blocks(np.asarray(q, dtype=complex), n)
    H = (Q.shape[0] - 1) // 2
    N = max(4 * max(H, harmonics) + 4, 2 * harmonics + 1)
    N += N % 2
    thp = 2.0 * np.pi * np.arange(N) / N
    rho = float(np.imag(exponent)) / Omega
    th = 2.0 * thp
    y = np.tile(Q[0], (N, 1)).astype(complex)
    for k in range(1, H + 1):
        y += np.outer(np.cos(k * th), Q[2 * k - 1]) + np.outer(np.sin(k * th), Q[2 * k])
    z = np.exp(2j * rho * thp)[:, None] * y
    zr = np.ascontiguousarray(z.real if part == "real" else z.imag)
    v = aft.project(zr, harmonics).reshape(-1)
    nv = np.linalg.norm(v)
    return v / nv if nv > 0 else v


def continuation_scales(branch: Branch | None, options: ContinuationOptions, u: np.ndarray):
    info = {} if branch is None else branch.info
    su = info.get("unknown_scale")
    su = float(np.max(su)) if su is not None else (float(np.max(np.abs(u))) if np.any(u) else 1.0)
    sl = info.get("parameter_scale")
    sl = float(sl) if sl is not None else 1.0
    if options.unknown_scale is not None:
        su = float(np.max(np.atleast_1d(options.unknown_scale)))
    if options.parameter_scale is not None:
        sl = float(options.parameter_scale)
    return su, sl


def branch_point_direction(problem, u: np.ndarray, lam: float, tangent: np.ndarray, su, sl: float):
    """Second tangent at a simple branch point (scaled coordinates).

    Parameters
    ----------
    problem : object with ``linearize``
    u, lam : the located branch point
    tangent : ndarray, shape (m+1,)
        Tangent of the traced branch, scaled coordinates ``(u/su, lam/sl)``.
    su : float or ndarray (m,)
    sl : float

    Returns
    -------
    t1 : ndarray, shape (m+1,)
        Unit vector in the two-dimensional null space of ``[Ju su, Jlam sl]``
        orthogonal to ``tangent``.
    sigma : ndarray, shape (3,)
        The three smallest singular values of the scaled augmented Jacobian
        relative to the largest (a clear simple branch point has two tiny
        ones and a third of order one).
    """
    _, Ju, Jlam = problem.linearize(u, lam)
    m = u.size
    Jh = np.empty((m, m + 1))
    Jh[:, :m] = Ju * su
    Jh[:, m] = Jlam * sl
    _, sv, vt = np.linalg.svd(Jh, full_matrices=True)
    V = vt[-2:].T  # null space (m+1, 2): the last right singular vectors
    t0 = np.asarray(tangent, dtype=float)
    c = V.T @ t0
    c = c / np.linalg.norm(c) if np.linalg.norm(c) > 0 else np.array([1.0, 0.0])
    t1 = V @ np.array([-c[1], c[0]])
    t1 /= np.linalg.norm(t1)
    j = int(np.argmax(np.abs(t1)))
    t1 *= np.sign(t1[j])
    svp = np.concatenate([sv, np.zeros(max(0, m + 1 - sv.size))])
    return t1, svp[-3:][::-1] / sv[0]


def extended_nullvector(problem, u, lam):
    R, Ju, Jlam = problem.linearize(u, lam)
    Jh = np.column_stack([Ju, Jlam])
    _, _, vt = np.linalg.svd(Jh, full_matrices=True)
    t = vt[-1]
    return t / np.linalg.norm(t)


def first_point(problem, u_star: np.ndarray, lam_star: float, direction: np.ndarray, eps: float, *,
                kind: SpecialKind | str = SpecialKind.PD, su=1.0, sl: float = 1.0, tol: float = 1e-10,
                max_iter: int = 20, retries: int = 3) -> BranchStart | None:
    """First point of a new branch from a bifurcation.

    ``pd``: Newton on ``[R(u, lam) = 0; phi . (u - u*) = eps]``, ``direction = phi``
    (shape (m,)). ``bp``: Newton on ``[R = 0; t1 . (x - x*) = eps]`` in the scaled
    coordinates ``x = (u/su, lam/sl)``, ``direction = t1`` (shape (m+1,)).
    On failure ``eps`` is halved up to ``retries`` times.

    Returns
    -------
    BranchStart or None
        None when Newton failed for every ``eps`` tried.
    """
    kind = SpecialKind(kind)
    m = u_star.size
    su_v = np.broadcast_to(np.asarray(su, dtype=float), (m,))
    d = np.asarray(direction, dtype=float)
    x_star = np.concatenate([u_star / su_v, [lam_star / sl]])
    e = float(eps)
    for _ in range(retries + 1):
        A = np.zeros((m + 1, m + 1))
        F = np.zeros(m + 1)
        if kind is SpecialKind.PD:
            def fun(x, e=e):
                u, lam = x[:m], x[m]
                R, Ju, Jlam = problem.linearize(u, lam)
                F[:m] = R
                F[m] = d @ (u - u_star) - e
                A[:m, :m] = Ju
                A[:m, m] = Jlam
                A[m, :m] = d
                A[m, m] = 0.0
                return F, A

            x0 = np.concatenate([u_star + e * d, [lam_star]])
        else:
            def fun(x, e=e):
                R, Ju, Jlam = problem.linearize(x[:m] * su_v, x[m] * sl)
                F[:m] = R
                F[m] = d @ (x - x_star) - e
                A[:m, :m] = Ju * su_v
                A[:m, m] = Jlam * sl
                A[m] = d
                return F, A

            x0 = x_star + e * d
        res = newton(fun, x0, tol, max_iter)
        if res.converged:
            if kind is SpecialKind.PD:
                u, lam = res.x[:m].copy(), float(res.x[m])
                step = np.concatenate([u - u_star, [lam - lam_star]])
            else:
                u, lam = res.x[:m] * su_v, float(res.x[m] * sl)
                step = np.concatenate([u - u_star, [lam - lam_star]])
            t = extended_nullvector(problem, u, lam)
            if t @ step < 0:
                t = -t
            return BranchStart(
                problem=problem, u=u, lam=lam, tangent=t, kind=kind, direction=d.copy(), eps=e,
                side=1 if e > 0 else -1, bifurcation=(u_star.copy(), float(lam_star)),
                newton_iterations=res.iterations, residual_norm=res.residual_norm,
            )
        e *= 0.5
    return None


def _default_factory(problem, factor: int):
    return doubled_problem(problem, factor)


def switch_at(problem, branch: Branch, point: SpecialPoint, *, options: ContinuationOptions | None = None,
              eps: float | None = None, sides: Sequence[int] | None = None,
              problem_factory: Callable | None = None, pd_direction: str = "svd",
              failures: list | None = None) -> list[BranchStart]:
    """First points of the new branches at a ``pd`` or ``bp`` special point.

    Parameters
    ----------
    problem : HarmonicBalance (or any problem for ``bp``)
        The problem of ``branch``.
    branch : Branch
    point : SpecialPoint
        Of kind ``pd`` or ``bp`` (``stability`` points are used with their
        ``classification``).
    options : ContinuationOptions, optional
        Supplies ``newton_tol``, the step ``ds`` (default offset) and scales.
    eps : float, optional
        Offset of the first point: for ``pd`` in units of ``u`` (default
        ``ds * su``), for ``bp`` in scaled arclength (default ``ds``).
    sides : sequence of {+1, -1}, optional
        Default ``(1,)`` for ``pd`` (the other side is the same motion shifted
        by one period) and ``(1, -1)`` for ``bp``.
    problem_factory : callable, optional
        ``problem_factory(problem, factor) -> problem`` for the order
        ``factor*nu`` problem (default :func:`doubled_problem`).
    pd_direction : {'svd', 'hill'}
        Null vector of the odd block, or Hill's critical eigenvector mapped
        by :func:`hill_vector_to_doubled`.
    failures : list, optional
        Receives a dict (``kind``, ``parameter``, ``side``, ``message``) for
        each side whose first point could not be found.

    Returns
    -------
    list of BranchStart
        Empty if the point is of another kind; sides whose Newton failed are
        left out of it and reported in ``failures``.
    """
    options = ContinuationOptions() if options is None else options
    kind = point.kind
    if kind is SpecialKind.STABILITY:
        kind = SpecialKind(point.data.get("classification", "stability"))
    u_star = np.asarray(point.unknowns, dtype=float)
    lam_star = float(point.parameter)
    su, sl = continuation_scales(branch, options, u_star)
    starts: list[BranchStart] = []
    if kind is SpecialKind.PD:
        factory = _default_factory if problem_factory is None else problem_factory
        hb2 = factory(problem, 2)
        u2 = embed(u_star, problem.n, 2, hb2.H)
        if pd_direction == "hill":
            spec = hill_spectrum(problem, u_star, lam_star, vectors=True)
            j = int(np.argmin(np.abs(spec.multipliers + 1.0)))
            n_hill = problem.full.n  # Hill's vectors are full for a condensed problem
            phi = hill_vector_to_doubled(spec.vectors[:, j], spec.exponents[j], spec.Omega, n_hill, hb2.H)
            if np.linalg.norm(phi) < 0.5:
                phi = hill_vector_to_doubled(spec.vectors[:, j], spec.exponents[j], spec.Omega, n_hill, hb2.H, "imag")
            if hb2.condensed:
                phi = hb2.restrict(phi)
                phi /= np.linalg.norm(phi)
        elif pd_direction == "svd":
            phi, _ = period_doubling_direction(hb2, u2, lam_star)
        else:
            raise ValueError(f"pd_direction must be 'svd' or 'hill', got {pd_direction!r}")
        e0 = options.ds * su if eps is None else float(eps)
        for side in (1,) if sides is None else sides:
            st = first_point(hb2, u2, lam_star, phi, side * e0, kind=SpecialKind.PD, tol=options.newton_tol)
            _keep(starts, st, failures, "pd", lam_star, side, e0)
    elif kind is SpecialKind.BP:
        t0 = point.tangent
        if t0 is None:
            raise ValueError("the branch point has no tangent; cannot find the second tangent")
        t1, _ = branch_point_direction(problem, u_star, lam_star, t0, su, sl)
        e0 = options.ds if eps is None else float(eps)
        for side in (1, -1) if sides is None else sides:
            st = first_point(problem, u_star, lam_star, t1, side * e0, kind=SpecialKind.BP, su=su, sl=sl,
                             tol=options.newton_tol)
            _keep(starts, st, failures, "bp", lam_star, side, e0)
    return starts


def _keep(starts: list, st, failures, kind: str, lam: float, side: int, eps: float) -> None:
    if st is not None:
        starts.append(st)
    elif failures is not None:
        failures.append({"kind": kind, "parameter": lam, "side": side,
                         "message": f"no first point of the new branch: Newton failed for offsets {eps:.3g} "
                                    "down to 1/8 of it along the bifurcating direction"})
