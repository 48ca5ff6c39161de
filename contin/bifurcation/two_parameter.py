"""Two-parameter continuation of fold and period-doubling curves: the driver.

A fold (multiplier +1, a jump point) or a period doubling (multiplier -1) of
a branch of periodic solutions traced in a parameter ``p1`` moves when a
second parameter ``p2`` changes. Continuing the bifurcation itself traces a
curve in the ``(p1, p2)`` plane: the boundary of the jump (bistability)
region for folds, the boundary of the region where the ``nu``-periodic
solution is unstable by period doubling and the subharmonic of order
``2 nu`` is born, for period doublings.

:func:`continue_curve` continues the minimally augmented system of
:mod:`contin.bifurcation.curve_system` with the engine, both ways from the
start, lands on the bounds of ``p1``, and joins the halves into a
:class:`~contin.bifurcation.curve.BifurcationCurve`;
:func:`curve_from_point` starts it at a located special point of a
one-parameter branch.

Codimension-two points
----------------------
Located on the curves by the engine's event mechanism:

- ``cusp`` (fold curves): the quadratic coefficient of the fold's normal
  form vanishes, ``c = w^T B(v, v) = 0`` with ``B`` the second derivative of
  ``R`` (Kuznetsov 2004, sec. 8.2; MatCont's CP test). Two fold curves merge
  there; in the ``(p1, p2)`` plane the curve has a cusp, and both
  parameters are extremal along it.
- ``fold_flip`` (fold and period-doubling curves): multipliers +1 and -1 at
  once. On a period-doubling curve ``J`` becomes singular (sign change of
  ``det J``); on a fold curve the flip matrix ``B`` does (sign change of
  ``det B``). Located by bisection (Kuznetsov, Meijer & van Veen, Int. J.
  Bifurcation Chaos 14 (2004) 2253, "fold-flip").
- ``extremum``: the curve turns in ``p1`` or ``p2`` (for example the smallest
  static force at which a period-doubling region exists). Not a bifurcation,
  but where a region begins or ends.

Not detected on harmonic-balance curves: degenerate (generalised) period
doubling, 1:2 resonance on period-doubling curves, Bogdanov-Takens-like points
of fold curves. The systems by shooting
(:mod:`contin.bifurcation.shooting_curve_system`) add Neimark-Sacker curves
and the strong resonances (their ``curve_events``, ``end_kinds``,
``end_note``); :func:`trace_curve` follows either kind of system.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any, Callable

import numpy as np

from contin.bifurcation.curve import BifurcationCurve, CurvePoint
from contin.bifurcation.curve_system import CODIM2_KINDS, CurveKind, SingularityProblem, as_curve_kind
from contin.engine.branch import Branch, BranchStatus, SpecialKind, SpecialPoint
from contin.engine.continuation import ContinuationOptions, continuation
from contin.engine.events import FunctionEvent
from contin.engine.newton import NUMERICAL_ERRORS, newton
from contin.hb.problem import HarmonicBalance
from contin.util.options import from_mapping

__all__ = ["CurveOptions", "continue_curve", "curve_from_point", "special_point_kind"]


@dataclasses.dataclass(frozen=True)
class CurveOptions:
    """Options of :func:`continue_curve` (the step control is a :class:`ContinuationOptions`).

    Attributes
    ----------
    both_ways : bool
        Continue from the start point in both directions and join the two
        halves into one curve (unless the first half closes a loop).
    detect : tuple of str
        Codimension-two points and turning points to locate, among
        ``"cusp"`` (fold curves), ``"fold_flip"``, ``"extremum"`` and
        ``"resonance"`` (curves by shooting: the strong resonances of a
        Neimark-Sacker curve, the 1:2 resonance of a period-doubling curve).
    fd_step : float
        Relative step of the central differences of the second-derivative
        terms (:class:`contin.hb.derivatives.HBDerivatives`), in (0, 1e-2].
    land_on_bounds : bool
        When the curve leaves the range of ``p1``, solve for the point exactly
        on the bound (otherwise the first point beyond it ends the curve).
    """

    both_ways: bool = True
    detect: tuple = CODIM2_KINDS
    fd_step: float = 1e-6
    land_on_bounds: bool = True

    def __post_init__(self):
        if not isinstance(self.both_ways, (bool, np.bool_)):
            raise ValueError(f"CurveOptions.both_ways must be a bool, got {self.both_ways!r}")
        det = tuple(self.detect) if isinstance(self.detect, (list, tuple)) else None
        if det is None or any(d not in CODIM2_KINDS for d in det):
            raise ValueError(f"CurveOptions.detect must be a list of {list(CODIM2_KINDS)}, got {self.detect!r}")
        object.__setattr__(self, "detect", det)
        f = self.fd_step
        if isinstance(f, bool) or not isinstance(f, (int, float)) or not (0 < f <= 1e-2):
            raise ValueError(f"CurveOptions.fd_step must be a number in (0, 1e-2], got {f!r}")
        object.__setattr__(self, "fd_step", float(f))
        if not isinstance(self.land_on_bounds, (bool, np.bool_)):
            raise ValueError(f"CurveOptions.land_on_bounds must be a bool, got {self.land_on_bounds!r}")


    @classmethod
    def from_dict(cls, d: dict) -> "CurveOptions":
        """From a mapping (:func:`contin.util.options.from_mapping`); an unknown key raises ``ValueError``
        naming it and the nearest valid one."""
        return from_mapping(cls, d)



def special_point_kind(point: SpecialPoint) -> SpecialKind:
    """The kind of a one-parameter special point, with stability changes classified."""
    kind = point.kind
    if kind is SpecialKind.STABILITY:
        kind = SpecialKind(point.data.get("classification", "stability"))
    return kind



class _CurveEvent(FunctionEvent):
    """A continuous test on a curve, located by the Illinois method and then checked.

    A test that only *jumps* through zero (the discretised problem of a
    non-smooth force is discontinuous where a time sample crosses a switching
    surface) narrows its bracket to rounding level without a small value:
    such a location is reported as not located, with the reason, instead of
    as a cusp or a turning point.
    """

    def locate(self, component, point_at, h, a, b, ga, gb, *, tol=1e-10, max_iter=60):
        out = super().locate(component, point_at, h, a, b, ga, gb, tol=tol, max_iter=max_iter)
        for loc in out:
            scale = max(abs(ga), abs(gb))
            if loc.located and abs(loc.value) > 1e-3 * scale:
                loc.located = False
                loc.message = (f"the test jumps through zero here (|test| = {abs(loc.value):.1e} against "
                               f"{scale:.1e} at the bracketing points): a discontinuity of the discretised "
                               f"problem, not a {self.kind.value}")
        return out


def _events(problem, detect) -> list:
    m = problem.m
    names = problem.p1, problem.p2
    evs = list(problem.curve_events(detect)) if hasattr(problem, "curve_events") else []
    if "extremum" in detect:
        evs.append(_CurveEvent(lambda pt: float(pt.tangent[-1]), name=f"extremum in {names[1]}",
                               kind=SpecialKind.EXTREMUM, describe=lambda pt: {"parameter": names[1]}))
        evs.append(_CurveEvent(lambda pt: float(pt.tangent[m]), name=f"extremum in {names[0]}",
                               kind=SpecialKind.EXTREMUM, describe=lambda pt: {"parameter": names[0]}))
    if hasattr(problem, "curve_events"):
        return evs
    if "cusp" in detect and problem.kind is CurveKind.FOLD:
        evs.append(_CurveEvent(lambda pt: float(pt.data["cusp_test"]), name="cusp", kind=SpecialKind.CUSP))
    if "fold_flip" in detect:
        evs.append(FunctionEvent(lambda pt: float(pt.data["fold_flip_test"]), name="fold-flip",
                                 kind=SpecialKind.FOLD_FLIP, integer_valued=True))
    return evs


def continue_curve(hb: HarmonicBalance, kind: CurveKind | str, p1: str, p2: str, u0, p1_0: float, p2_0: float,
                   p2_range, p1_range=(-math.inf, math.inf), options: ContinuationOptions | dict | None = None,
                   curve_options: CurveOptions | dict | None = None, *,
                   callback: Callable[[Branch, int], Any] | None = None) -> BifurcationCurve:
    """Continue a fold or a period doubling of ``hb``'s solutions in two parameters.

    Parameters
    ----------
    hb : HarmonicBalance
        Problem of order ``nu`` whose solutions fold or double their period;
        its parameter values are kept fixed except ``p1`` and ``p2``.
    kind : CurveKind or str
        ``"fold"`` or ``"pd"``.
    p1, p2 : str
        Parameter names; ``p1`` is solved for, ``p2`` is the continuation
        parameter.
    u0 : ndarray, shape (hb.size,)
        Harmonic-balance coefficients at (or near) the bifurcation.
    p1_0, p2_0 : float
        The bifurcation's parameters (``p2_0`` inside ``p2_range``).
    p2_range, p1_range : (float, float)
        The curve ends exactly on a bound of ``p2_range``; when it leaves
        ``p1_range`` it ends on that bound (``CurveOptions.land_on_bounds``).
    options : ContinuationOptions or dict, optional
        Step control (``detect_folds`` and ``detect_branch_points`` are
        switched off: the curve's own events replace them).
    curve_options : CurveOptions or dict, optional
    callback : callable, optional
        ``callback(branch, index)`` after each stored point, as for the engine
        (the branch's unknowns are ``z = (u, p1)``); returning False stops.

    Returns
    -------
    BifurcationCurve
        Never raises for numerical reasons: a failure ends a direction with
        its status and message (``ends``); a failed start gives an empty curve.
    """
    if options is None:
        options = ContinuationOptions()
    elif isinstance(options, dict):
        options = ContinuationOptions.from_dict(options)
    if curve_options is None:
        curve_options = CurveOptions()
    elif isinstance(curve_options, dict):
        curve_options = CurveOptions.from_dict(curve_options)
    kind = as_curve_kind(kind)
    lo2, hi2 = (float(v) for v in p2_range)
    lo1, hi1 = (float(v) for v in p1_range)
    if not lo1 < hi1:
        raise ValueError(f"p1_range must satisfy lo < hi, got ({lo1}, {hi1})")
    if not lo1 <= p1_0 <= hi1:
        raise ValueError(f"the start {p1}={p1_0} is outside its range ({lo1}, {hi1})")
    u0 = np.asarray(u0, dtype=float)
    if u0.shape != (hb.size,):
        raise ValueError(f"u0 must have shape ({hb.size},), got {u0.shape}")
    umax = float(np.max(np.abs(u0))) if u0.size else 0.0
    problem = SingularityProblem(hb, kind, p1, p2, curve_options.fd_step, curve_options.detect, u_scale=umax,
                                 p1_scale=(hi1 - lo1) if math.isfinite(hi1 - lo1) else max(abs(p1_0), 1.0))
    z0 = np.concatenate([u0, [float(p1_0)]])
    return trace_curve(problem, z0, p2_0, (lo2, hi2), (lo1, hi1), options, curve_options, callback=callback,
                       nu=hb.nu, harmonics=hb.H)


def trace_curve(problem, z0, p2_0: float, p2_range, p1_range, options: ContinuationOptions,
                curve_options: CurveOptions, *, callback=None, nu: int = 1, harmonics: int = 0) -> BifurcationCurve:
    """Continue an extended system ``problem`` (unknowns ``z = (..., p1)``, parameter ``p2``) both ways from
    ``z0`` and join the halves (:func:`continue_curve`; the systems of
    :mod:`contin.bifurcation.curve_system` and :mod:`contin.bifurcation.shooting_curve_system`)."""
    lo2, hi2 = p2_range
    lo1, hi1 = p1_range
    p1, p2 = problem.p1, problem.p2
    kind = problem.kind

    problem.initialize_borders(z0, p2_0)
    b0, c0 = problem.b.copy(), problem.c.copy()
    opts = options.replace(detect_folds=False, detect_branch_points=False)
    events = _events(problem, curve_options.detect)
    left: dict = {}
    ended: dict = {}  # side -> the located point where the curve ends (a strong resonance)

    def make_callback(side: int):
        def cb(branch: Branch, i: int):
            z = branch.unknowns[i]
            problem.update_borders(z, float(branch.parameter[i]))
            q = float(z[-1])
            if i > 0 and not lo1 <= q <= hi1:
                left[side] = hi1 if q > hi1 else lo1
                return False
            if i > 0 and resonance_end(problem, branch, side, ended):
                return False
            return True if callback is None else callback(branch, i)

        return cb

    def run(d, z, lam, **kw):
        return continuation(problem, z, lam, (lo2, hi2), opts.replace(direction=d), parameter_name=p2,
                            events=events, monitors=[problem.monitor], callback=make_callback(d), **kw)

    runs = []  # (direction, branch)
    ends = []
    directions = (1, -1) if curve_options.both_ways else (options.direction,)
    start_solved = None
    for d in directions:
        problem.set_borders(b0, c0)
        if start_solved is None:
            br = run(d, z0, p2_0)
            if len(br):
                start_solved = (br.unknowns[0].copy(), float(br.parameter[0]), br.tangents[0].copy())
        else:
            # the other way: the reversed start tangent (the sign of dp2 alone is ambiguous where the curve
            # is tangent to p2 = const at the start)
            br = run(d, start_solved[0], start_solved[1], solve_start=False, tangent=-start_solved[2])
        status, message = br.status.value, br.message
        if br.status in (BranchStatus.STEP_TOO_SMALL, BranchStatus.NEWTON_FAILED) and len(br):
            jump = _jump_ahead(problem, br)
            if jump is not None:
                message += (f"; the residual jumps by {jump[0]:.1e} within a step of {jump[1]:g} along the curve: the "
                            f"discretised equations are discontinuous there (a time sample at a switching "
                            f"surface of a non-smooth force, e.g. contact onset), and the curve of the "
                            f"truncated problem does not continue across it")
            elif hasattr(problem, "end_note"):
                message += problem.end_note(br.unknowns[-1], float(br.parameter[-1]))
        if d in left:
            status = BranchStatus.RANGE_END.value
            message = f"reached the end of the {p1} range at {p1}={left[d]:.10g}"
        elif d in ended:
            status, message = BranchStatus.BOUNDARY.value, problem.end_message(ended[d])
        runs.append((d, br))
        ends.append({"side": "forward" if d > 0 else "backward", "status": status, "message": message})
        if not len(br) or br.status is BranchStatus.CLOSED_LOOP or (
                br.status is BranchStatus.INTERRUPTED and d not in left and d not in ended):
            break
    return _assemble(problem, nu, harmonics, kind, (p1, p2), runs, ends, left, ended, curve_options)


def resonance_end(problem, branch: Branch, side: int, ended: dict) -> bool:
    """True (and ``ended[side]`` the point) when the last step located a point where ``problem``'s curves end
    (its ``end_kinds``: the strong resonances 1:1 and 1:2 of a Neimark-Sacker curve)."""
    kinds = getattr(problem, "end_kinds", ())
    for sp in branch.special_points:
        if sp.kind in kinds and sp.located:
            ended[side] = sp
            return True
    return False


def _jump_ahead(problem: SingularityProblem, br: Branch):
    """``(jump, step)``: a residual jump within a tiny step along the tangent past the last point, or None.

    Along the tangent a smooth residual grows only quadratically (below the
    Newton tolerance for steps up to 1e-7 in scaled arclength); a jump above
    ``1e3 * newton_tol`` there is a discontinuity of the equations.
    """
    m1 = problem.m + 1
    su = np.broadcast_to(np.asarray(br.info.get("unknown_scale", 1.0), float), (m1,))
    sl = float(br.info.get("parameter_scale", 1.0))
    z, lam, t = br.unknowns[-1], float(br.parameter[-1]), br.tangents[-1]
    tol = float(br.info.get("options", {}).get("newton_tol", 1e-10))
    try:
        F0 = problem.residual(z, lam)
        for step in (1e-9, 1e-8, 1e-7):
            F1 = problem.residual(z + step * t[:m1] * su, lam + step * t[m1] * sl)
            jump = float(np.max(np.abs(F1 - F0)))
            if jump > 1e3 * tol:
                return jump, step
    except NUMERICAL_ERRORS:
        return None
    return None


def _land(problem: SingularityProblem, za, la, zb, lb, bound: float, tol: float):
    """Solve ``(R, g) = 0`` with ``p1 = bound`` fixed and ``(u, p2)`` free, from the chord."""
    m = problem.m
    t = (bound - za[m]) / (zb[m] - za[m])
    y0 = np.concatenate([(1 - t) * za[:m] + t * zb[:m], [(1 - t) * la + t * lb]])

    def fun(y):
        z = np.concatenate([y[:m], [bound]])
        F, Jz, Jl = problem.linearize(z, y[m])
        A = np.empty((m + 1, m + 1))
        A[:, :m] = Jz[:, :m]
        A[:, m] = Jl
        return F, A

    res = newton(fun, y0, tol, 20)
    if not res.converged:
        return None
    return np.concatenate([res.x[:m], [bound]]), float(res.x[m])


def _halves(problem, runs, ends, left, ended, curve_options):
    """Per traced direction: its points (landed on a p1 bound if asked) and special points."""
    out = []
    m1 = problem.m + 1
    for j, (d, br) in enumerate(runs):
        P = len(br)
        Z = np.array(br.unknowns).reshape(P, m1)
        L = np.array(br.parameter, dtype=float)
        # along the curve's order: the first run is its forward half as traced, the second is reversed
        T = np.array(br.tangents).reshape(P, m1 + 1) * (1.0 if j == 0 else -1.0)
        sps = [sp for sp in br.special_points if sp.kind is not SpecialKind.START]
        if d in left and P >= 2:
            landed = None
            if curve_options.land_on_bounds:
                problem.initialize_borders(Z[-1], L[-1])
                landed = _land(problem, Z[-2], L[-2], Z[-1], L[-1], left[d], 1e-10)
            if landed is not None:
                Z[-1], L[-1] = landed
                ends[j]["message"] += " (landed on the bound)"
            else:
                ends[j]["message"] += " (first point beyond the bound)"
            sps.append(SpecialPoint(SpecialKind.END, float(L[-1]), Z[-1].copy(), (L[-1], L[-1]), P - 1, 0.0,
                                    message=ends[j]["message"], event="end"))
        elif d in ended and P >= 2:
            # the curve ends on the located point: the step past it (the curve folded back onto itself) is dropped
            sp = ended[d]
            Z[-1], L[-1] = sp.unknowns, float(sp.parameter)
            sps = [q for q in sps if q.index < P - 1 or q is sp]
            sps.append(SpecialPoint(SpecialKind.END, float(L[-1]), Z[-1].copy(), (L[-1], L[-1]), P - 1, 0.0,
                                    message=ends[j]["message"], event="end"))
        elif P and not any(sp.kind is SpecialKind.END for sp in sps):
            # a direction that stopped early: its last point, with the reason
            sps.append(SpecialPoint(SpecialKind.END, float(L[-1]), Z[-1].copy(), (L[-1], L[-1]), P - 1, 0.0,
                                    located=False, message=f"{ends[j]['status']}: {ends[j]['message']}",
                                    event="end"))
        out.append((Z, L, T, sps))
    return out


def _assemble(problem, nu, harmonics, kind, names, runs, ends, left, ended, curve_options) -> BifurcationCurve:
    """Join the backward half (reversed) and the forward half into one curve."""
    m = problem.m
    halves = _halves(problem, runs, ends, left, ended, curve_options)
    Zf, Lf, Tf, spf = halves[0]
    Zb, Lb, Tb, spb = (halves[1] if len(halves) > 1 and len(halves[1][1])
                       else (np.zeros((1, m + 1)), np.zeros(1), np.zeros((1, m + 2)), []))
    n_back = len(Lb) - 1
    Z = np.concatenate([Zb[:0:-1], Zf]) if len(Lf) else np.zeros((0, m + 1))
    L = np.concatenate([Lb[:0:-1], Lf]) if len(Lf) else np.zeros(0)
    T = np.concatenate([Tb[:0:-1], Tf]) if len(Lf) else np.zeros((0, m + 2))
    info = runs[0][1].info if runs else {}
    su = np.broadcast_to(np.asarray(info.get("unknown_scale", 1.0), float), (m + 1,)).copy()
    scales = (su, float(info.get("parameter_scale", 1.0)))
    specials: list[CurvePoint] = []
    for sps, forward in ((spf, True), (spb, False)):
        P = len(Lf) if forward else len(Lb)
        for sp in sps:
            at_end = sp.kind is SpecialKind.END
            if forward:
                index = n_back + (P - 1 if at_end else sp.index)
            else:
                index = 0 if at_end else max(n_back - sp.index - 1, 0)
            specials.append(CurvePoint(
                kind=sp.kind, p1=float(sp.unknowns[m]), p2=float(sp.parameter), unknowns=sp.unknowns[:m].copy(),
                index=int(index), located=bool(sp.located), message=sp.message,
                data={k: v for k, v in (sp.data or {}).items() if k == "parameter"},
            ))
    specials = _dedupe(specials, problem)
    if len(L):
        specials.append(CurvePoint(SpecialKind.START, float(Z[n_back, m]), float(L[n_back]), Z[n_back, :m].copy(),
                                   n_back, message="start point"))
    # start and end points sit on their row, the others between their row and the next
    rank = {SpecialKind.START: 0.0, SpecialKind.END: 0.1}
    specials.sort(key=lambda p: p.index + rank.get(p.kind, 0.5))
    return BifurcationCurve(
        kind=kind, parameters=tuple(names), nu=nu, harmonics=harmonics, p1=Z[:, m].copy(), p2=L,
        unknowns=Z[:, :m].copy(), special_points=specials, ends=ends, start_index=n_back, problem=problem,
        branches=[br for _, br in runs], tangents=T, scales=scales,
    )


def _dedupe(points: list, problem) -> list:
    """A cusp is also an extremum of both parameters, and so is a curve's end where it folds back onto itself (a
    Neimark-Sacker curve at a 1:1 or 1:2 resonance): keep the cusp or the resonance only."""
    ends = getattr(problem, "end_kinds", ())
    scale1 = max(problem.p1_scale, 1e-300)
    for r in [p for p in points if p.kind in ends]:
        # the curve folds back at the resonance: its turning point in p2, located by the tangent, is the exact
        # place (the angle's test, a square root of the distance along the curve there, is located less well)
        turn = [p for p in points if p.kind is SpecialKind.EXTREMUM and p.data.get("parameter") == problem.p2
                and abs(p.p1 - r.p1) <= 1e-3 * scale1 and abs(p.p2 - r.p2) <= 1e-3 * max(1.0, abs(r.p2))]
        if turn:
            for q in [p for p in points if p.kind is SpecialKind.END and p.p1 == r.p1 and p.p2 == r.p2] + [r]:
                q.p1, q.p2, q.unknowns = turn[0].p1, turn[0].p2, turn[0].unknowns.copy()
    cusps = [p for p in points if p.kind is SpecialKind.CUSP or p.kind in ends]
    out = []
    for p in points:
        tol = [1e-3 if c.kind in ends else 1e-6 for c in cusps]
        if p.kind is SpecialKind.EXTREMUM and any(abs(p.p1 - c.p1) <= t * scale1 and
                                                  abs(p.p2 - c.p2) <= t * max(1.0, abs(c.p2))
                                                  for c, t in zip(cusps, tol)):
            continue
        out.append(p)
    return out


def curve_from_point(hb: HarmonicBalance, point: SpecialPoint, p2: str, p2_range, p1_range=(-math.inf, math.inf),
                     options=None, curve_options=None, *, kind: CurveKind | str | None = None,
                     callback=None) -> BifurcationCurve:
    """Continue a located fold or period doubling of a one-parameter branch of ``hb``.

    Parameters
    ----------
    hb : HarmonicBalance
        The problem of the branch (its ``parameter`` is ``p1``).
    point : SpecialPoint
        Of kind ``fold`` or ``pd`` (or ``stability`` classified so).
    p2 : str
        The second parameter; its current value is ``hb``'s.
    kind : CurveKind, optional
        Default: from the point.

    Other parameters are those of :func:`continue_curve`.
    """
    if kind is None:
        pk = special_point_kind(point)
        if pk.value not in ("fold", "pd"):
            raise ValueError(f"a curve starts at a 'fold' or 'pd' point, not at {pk.value!r}")
        kind = CurveKind(pk.value)
    p2_0 = float(hb.p0[hb.model.parameter_index(p2)])
    return continue_curve(hb, kind, hb.parameter, p2, point.unknowns, float(point.parameter), p2_0, p2_range,
                          p1_range, options, curve_options, callback=callback)
