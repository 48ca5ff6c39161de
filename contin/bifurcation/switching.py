"""Branch switching at period doublings and branch points, and automatic diagrams.

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

:func:`follow` traces a first branch with stability, switches automatically
at the requested special points and returns every branch with its parentage
(:class:`BifurcationDiagram`).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any, Callable, Sequence

import numpy as np

from contin.hb import aft
from contin.engine.branch import Branch, BranchStatus, SpecialKind, SpecialPoint
from contin.engine.continuation import ContinuationOptions, continuation
from contin.hb.grazing import grazing_events
from contin.hb.harmonics import coefficient_blocks, embed
from contin.engine.newton import newton
from contin.stability.floquet import StabilityMethod, StabilityMonitor, StabilityOptions, stability_events
from contin.stability.hill import hill_spectrum

__all__ = [
    "BranchStart",
    "BifurcationDiagram",
    "doubled_problem",
    "odd_indices",
    "period_doubling_direction",
    "hill_vector_to_doubled",
    "branch_point_direction",
    "first_point",
    "switch_at",
    "switch_branch",
    "follow",
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


def _scales(branch: Branch | None, options: ContinuationOptions, u: np.ndarray):
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


def _nullvector(problem, u, lam):
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
            t = _nullvector(problem, u, lam)
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
    su, sl = _scales(branch, options, u_star)
    starts: list[BranchStart] = []
    if kind is SpecialKind.PD:
        factory = _default_factory if problem_factory is None else problem_factory
        hb2 = factory(problem, 2)
        u2 = embed(u_star, problem.n, 2, hb2.H)
        if pd_direction == "hill":
            spec = hill_spectrum(problem, u_star, lam_star, vectors=True)
            j = int(np.argmin(np.abs(spec.multipliers + 1.0)))
            n_hill = getattr(problem, "full", problem).n  # Hill's vectors are full for a condensed problem
            phi = hill_vector_to_doubled(spec.vectors[:, j], spec.exponents[j], spec.Omega, n_hill, hb2.H)
            if np.linalg.norm(phi) < 0.5:
                phi = hill_vector_to_doubled(spec.vectors[:, j], spec.exponents[j], spec.Omega, n_hill, hb2.H, "imag")
            if hasattr(hb2, "restrict"):
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


def _run(start: BranchStart, lam_range, options: ContinuationOptions, stability: StabilityOptions,
         parameter_name: str, su: float, sl: float, callback=None, checkpoint=None, previous: Branch | None = None):
    """Trace the branch from ``start`` (or take up ``previous``, the same branch of an interrupted run)."""
    opts = options.replace(unknown_scale=su, parameter_scale=sl)
    monitor, events, monitors = _stability(start.problem, stability, opts)
    if previous is not None:
        return _resume(previous, start.problem, lam_range, opts, parameter_name, events, monitors, callback,
                       checkpoint), monitor
    tangent = np.concatenate([start.tangent[:-1] / su, [start.tangent[-1] / sl]])
    br = continuation(start.problem, start.u, start.lam, lam_range, opts, parameter_name=parameter_name,
                      events=events, monitors=monitors, tangent=tangent, solve_start=False, callback=callback,
                      checkpoint=checkpoint)
    return br, monitor


def _stability(problem, stability: StabilityOptions, options: ContinuationOptions):
    """The stability monitor, the events and the monitors of a branch of ``problem``.

    The events are the classified stability changes (with a monitor) and
    the grazing of contact laws (for a harmonic balance with switching force
    elements).
    """
    monitor, events, monitors = None, [], []
    if stability.method is not StabilityMethod.NONE:
        monitor = StabilityMonitor(problem, stability)
        events = stability_events(monitor, folds=not options.detect_folds)
        monitors = [monitor]
    return monitor, events + grazing_events(problem), monitors


def _resume(prev: Branch, problem, lam_range, options: ContinuationOptions, name: str, events, monitors, callback,
            checkpoint=None):
    """Take up a branch of an interrupted run (:func:`contin.output.checkpoint.rebuild_branches`).

    An unfinished branch goes on from the engine state of its last point, as
    it would have without the interruption (same options, events and
    monitors as when it was started); a finished one is returned as it is,
    its monitors given back their final states.
    """
    if prev.status is not BranchStatus.INTERRUPTED:
        for mon, st in zip(monitors, prev.info.get("monitor_states") or ()):
            if st is not None and hasattr(mon, "restore"):
                mon.restore(st)
        return prev
    state = prev.info.pop("restart", None)
    if state is None or not len(prev):
        raise ValueError("resume: a branch without the engine state of its last point")
    return continuation(problem, prev.unknowns[0], float(prev.parameter[0]), lam_range, options, parameter_name=name,
                        events=events, monitors=monitors, callback=callback, checkpoint=checkpoint,
                        restart=(prev, state))


def switch_branch(problem, branch: Branch, point: SpecialPoint, lam_range=None, options=None, *,
                  stability: StabilityOptions | None = None, eps: float | None = None,
                  sides: Sequence[int] | None = None, problem_factory: Callable | None = None,
                  pd_direction: str = "svd") -> list[tuple[Branch, Any]]:
    """Switch at one special point and trace the new branch(es).

    Returns
    -------
    list of (Branch, problem)
        ``branch.info["origin"]`` describes the special point. Sides whose
        first point falls outside ``lam_range`` are left out.
    """
    options = ContinuationOptions() if options is None else options
    stability = StabilityOptions() if stability is None else stability
    lam_range = branch.info.get("lam_range", (-math.inf, math.inf)) if lam_range is None else lam_range
    out = []
    su, sl = _scales(branch, options, np.asarray(point.unknowns))
    for st in switch_at(problem, branch, point, options=options, eps=eps, sides=sides,
                        problem_factory=problem_factory, pd_direction=pd_direction):
        if not lam_range[0] <= st.lam <= lam_range[1]:
            continue  # the new branch leaves the range at once
        br, mon = _run(st, lam_range, options, stability, branch.parameter_name, su, sl)
        br.info["origin"] = _origin(point, None, st)
        if mon is not None:
            _record_stability(br, mon)
        _annotate_problem(br, st.problem)
        out.append((br, st.problem))
    return out


def _record_stability(br: Branch, mon) -> None:
    """Store the monitor's statistics; say in the branch message where the monodromy replaced Hill."""
    st = mon.statistics()
    br.info["stability"] = st
    where = sorted(st.get("fallbacks", []) + st.get("disagreements", []))
    if where:
        br.message = (f"{br.message}; stability: Hill's multipliers disagreed with the monodromy's at "
                      f"{len(where)} point(s) (first at {br.parameter_name}={where[0]:.10g}), "
                      "the monodromy's were used there")
    if st.get("unevaluated"):
        lam, why = st["unevaluated"][0]
        br.message = (f"{br.message}; no stability verdict at {len(st['unevaluated'])} point(s) (first at "
                      f"{br.parameter_name}={lam:.10g}: {why})")


def _origin(point: SpecialPoint, parent: int | None, st: BranchStart) -> dict:
    return {
        "kind": SpecialKind(st.kind).value,
        "parameter": float(point.parameter),
        "parent": parent,
        "special_point_index": point.index,
        "event": point.event,
        "side": st.side,
        "eps": st.eps,
        "first_point_parameter": st.lam,
    }


def _annotate_problem(br: Branch, problem) -> None:
    for attr, key in (("nu", "subharmonic"), ("H", "harmonics"), ("N", "samples")):
        if hasattr(problem, attr):
            br.info[key] = int(getattr(problem, attr))


@dataclasses.dataclass
class BifurcationDiagram:
    """Branches traced by :func:`follow`, with their parentage.

    Attributes
    ----------
    branches : list of Branch
        ``branches[0]`` is the first branch.
    problems : list
        The problem of each branch (its ``nu`` and ``H`` interpret the
        unknowns).
    parents : list of int or None
        Index of the parent branch (None for the first).
    origins : list of SpecialPoint or None
        The parent's special point each branch starts from.
    monitors : list of StabilityMonitor or None
    failed_switches : list of dict
        Sides of a switch whose first point could not be found: ``parent``,
        ``kind``, ``parameter``, ``side`` and ``message``.
    """

    branches: list = dataclasses.field(default_factory=list)
    problems: list = dataclasses.field(default_factory=list)
    parents: list = dataclasses.field(default_factory=list)
    origins: list = dataclasses.field(default_factory=list)
    monitors: list = dataclasses.field(default_factory=list)
    failed_switches: list = dataclasses.field(default_factory=list)

    def __len__(self) -> int:
        return len(self.branches)

    def __iter__(self):
        return iter(self.branches)

    def __getitem__(self, i) -> Branch:
        return self.branches[i]

    def children(self, i: int) -> list[int]:
        """Indices of the branches switched from branch ``i``."""
        return [j for j, p in enumerate(self.parents) if p == i]

    def summary(self) -> str:
        lines = []
        for i, br in enumerate(self.branches):
            org = br.info.get("origin")
            head = f"[{i}] nu={br.info.get('subharmonic', '?')} H={br.info.get('harmonics', '?')}"
            if org:
                head += f" from {org['kind']} of [{org['parent']}] at {br.parameter_name}={org['parameter']:.10g}"
            lines.append(head)
            lines.extend("    " + line for line in br.summary().splitlines())
        return "\n".join(lines)


def _switch_candidates(br: Branch, kinds: set, origin_lam: float | None, tol: float) -> list[SpecialPoint]:
    """Special points to switch at, one per bifurcation.

    The engine's determinant test and the ``+1`` multiplier event report the
    same branch point; they are merged by kind and bracketing interval,
    keeping the determinant one: it is located exactly, whereas the
    multiplier count is biased by ``tolerance / |d|mu|/dlam|``.
    """
    chosen: dict[tuple, SpecialPoint] = {}
    for sp in br.special_points:
        kind = sp.kind
        if kind is SpecialKind.STABILITY:
            kind = SpecialKind(sp.data.get("classification", "stability"))
        if kind.value not in kinds or not sp.located:
            continue
        scale = tol * max(1.0, abs(sp.parameter))
        if origin_lam is not None and abs(sp.parameter - origin_lam) <= 1e3 * scale and sp.index <= 1:
            continue  # the bifurcation the branch starts from
        key = (kind, sp.index)
        if key not in chosen or (kind is SpecialKind.BP and not sp.event.startswith("stability")):
            chosen[key] = sp
    return sorted(chosen.values(), key=lambda p: (p.s, p.index))


def follow(problem, u0, lam0: float, lam_range, options: ContinuationOptions | dict | None = None, *,
           stability: StabilityOptions | dict | None = None, switch: Sequence[str] = ("pd", "bp"),
           max_depth: int = 1, parameter_name: str | None = None, problem_factory: Callable | None = None,
           eps: float | None = None, max_branches: int = 16, pd_direction: str = "svd",
           callback: Callable | None = None, callback_factory: Callable | None = None,
           checkpoint_factory: Callable | None = None, previous: dict | None = None) -> BifurcationDiagram:
    """Trace a branch with stability, then switch automatically at its bifurcations.

    Parameters
    ----------
    problem : HarmonicBalance
        Problem of the first branch (any engine problem if ``switch``
        contains only ``"bp"``).
    u0 : ndarray, shape (m,)
        Start guess.
    lam0 : float
    lam_range : (float, float)
        Range of every branch.
    options : ContinuationOptions or dict, optional
    stability : StabilityOptions or dict, optional
        Method ``none`` disables stability (then only the engine's ``bp``
        points can be switched at).
    switch : sequence of {'pd', 'bp'}
        Kinds of special points to switch at.
    max_depth : int
        Switching generations (1: the first branch's bifurcations only).
    parameter_name : str, optional
        Default: the problem's ``parameter`` attribute.
    problem_factory : callable, optional
        ``problem_factory(problem, factor)`` -> problem of order ``factor*nu``.
    eps : float, optional
        Offset of first points (see :func:`switch_at`).
    max_branches : int
        Stop after this many branches.
    pd_direction : {'svd', 'hill'}
    callback : callable, optional
        Passed to the engine for every branch.
    callback_factory : callable, optional
        ``callback_factory(index, problem) -> callback`` gives each branch its
        own engine callback (for example to record rows with the branch id
        and its order nu); it overrides ``callback``.
    checkpoint_factory : callable, optional
        ``checkpoint_factory(index, problem) -> checkpoint``: each branch's
        engine ``checkpoint`` (see :func:`contin.engine.continuation.continuation`),
        what ``previous`` is rebuilt from.
    previous : dict of int to Branch, optional
        Branches of an earlier, interrupted run of the same diagram, by index
        (see :mod:`contin.output.checkpoint`). A finished one is reused as it is; an
        unfinished one is continued from its last point with its own scales,
        and its callback is not called again for that point.

    Returns
    -------
    BifurcationDiagram
        Each branch's ``info`` holds ``parent`` (index or None), ``origin``
        (dict: kind, parameter, parent, event, side, eps), ``depth``,
        ``subharmonic``, ``harmonics``, and ``stability`` (monitor
        statistics).
    """
    if options is None:
        options = ContinuationOptions()
    elif isinstance(options, dict):
        options = ContinuationOptions.from_dict(options)
    if stability is None:
        stability = StabilityOptions()
    elif isinstance(stability, dict):
        stability = StabilityOptions.from_dict(stability)
    kinds = set()
    for k in switch:
        k = SpecialKind(k).value
        if k not in ("pd", "bp"):
            raise ValueError(f"follow: can switch at 'pd' and 'bp' points, not {k!r}")
        kinds.add(k)
    if isinstance(max_depth, bool) or not isinstance(max_depth, int) or max_depth < 0:
        raise ValueError(f"follow: max_depth must be an integer >= 0, got {max_depth!r}")
    name = parameter_name or getattr(problem, "parameter", "lambda")
    lam_range = tuple(float(v) for v in lam_range)
    diagram = BifurcationDiagram()

    # the first branch
    monitor, events, monitors = _stability(problem, stability, options)

    def cb_for(index, prob):
        return callback_factory(index, prob) if callback_factory is not None else callback

    def ck_for(index, prob):
        return None if checkpoint_factory is None else checkpoint_factory(index, prob)

    previous = previous or {}
    if 0 in previous:
        root = _resume(previous[0], problem, lam_range, options, name, events, monitors, cb_for(0, problem),
                       ck_for(0, problem))
    else:
        root = continuation(problem, u0, lam0, lam_range, options, parameter_name=name, events=events,
                            monitors=monitors, callback=cb_for(0, problem), checkpoint=ck_for(0, problem))
    root.info.update(parent=None, origin=None, depth=0)
    if monitor is not None:
        _record_stability(root, monitor)
    _annotate_problem(root, problem)
    diagram.branches.append(root)
    diagram.problems.append(problem)
    diagram.parents.append(None)
    diagram.origins.append(None)
    diagram.monitors.append(monitor)

    queue = [0]
    while queue:
        i = queue.pop(0)
        br, prob = diagram.branches[i], diagram.problems[i]
        if br.status is BranchStatus.INTERRUPTED:
            return diagram  # the user asked to stop: no new branches
        depth = br.info.get("depth", 0)
        if depth >= max_depth or not len(br):
            continue
        org = br.info.get("origin")
        origin_lam = org["first_point_parameter"] if org else None
        su, sl = _scales(br, options, br.unknowns[0])
        for sp in _switch_candidates(br, kinds, origin_lam, options.locate_tol):
            if sp.kind is SpecialKind.PD and not hasattr(prob, "with_options") and problem_factory is None:
                continue
            failed: list = []
            found = switch_at(prob, br, sp, options=options, eps=eps, problem_factory=problem_factory,
                              pd_direction=pd_direction, failures=failed)
            diagram.failed_switches.extend({"parent": i, **f} for f in failed)
            for st in found:
                if len(diagram) >= max_branches:
                    return diagram
                if not lam_range[0] <= st.lam <= lam_range[1]:
                    continue  # the new branch leaves the range at once
                j = len(diagram)
                child, mon = _run(st, lam_range, options, stability, name, su, sl, cb_for(j, st.problem),
                                  ck_for(j, st.problem), previous.get(j))
                child.info.update(parent=i, origin=_origin(sp, i, st), depth=depth + 1)
                if mon is not None:
                    _record_stability(child, mon)
                _annotate_problem(child, st.problem)
                diagram.branches.append(child)
                diagram.problems.append(st.problem)
                diagram.parents.append(i)
                diagram.origins.append(sp)
                diagram.monitors.append(mon)
                queue.append(j)
    return diagram
