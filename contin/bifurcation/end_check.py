"""Whether a harmonic-balance branch that ends at a grazing point ended where the orbit does.

A branch ends with status ``boundary`` at a located grazing point it cannot
pass (:class:`contin.hb.grazing.GrazingEvent`, a barrier of the engine).
That end is an outcome as asked only if two things hold:

1. **The grazing belongs to the solution, not to the truncation.** At the
   end point the orbit is solved again with more harmonics,
   ``H' = H + max(8, H)`` (and proportionally more samples), from its
   coefficients padded with zeros, at the same parameter value, with the
   problem's own residual (:meth:`HarmonicBalance.with_options`). The
   extremum of the switching function that grazes must still lie within
   :data:`RESOLVED` of its range over the period from zero (a grazing that
   the higher truncation puts a little further along the branch is the same
   end; the largest change of the function over the period is reported,
   not judged: where the orbit is in contact it follows the contact
   force's Gibbs oscillations). Where Newton fails at ``H'``, or the
   extremum left zero (the contact region changed), the grazing is made by
   the truncation: the
   series with ``H`` harmonics overshoots or undershoots the contact
   surface where the converged orbit does not (a bearing that stays in
   contact, drawn by three harmonics as bouncing on its casing).
2. **The orbit does not go on past it.** With the branch's own harmonics,
   Newton at fixed parameter marches from the end point past the grazing
   point, over :data:`REACH` of the parameter range in geometric steps (each
   from the last solution, extrapolated). If every step converges and the
   last orbit has a different number of contact switches (it is past the
   grazing), the branch could have gone on: its end is made by the
   continuation's numerics (a stiff stop's contact onset that the corrector
   cannot step across), not by the problem.

Either failure is a shortfall of the run, with the interval beyond the
grazing point that the branch left uncovered. A grazing end that passes both
(the rotor's 1/2-subharmonic, whose bearing starts to bounce on its casing)
stays an end as asked.
"""

from __future__ import annotations

import collections
import dataclasses
import math
import re

import numpy as np

from contin.engine.branch import Branch, BranchStatus, SpecialKind, SpecialPoint
from contin.engine.newton import NUMERICAL_ERRORS, newton
from contin.hb.crossings import series_at
from contin.hb.grazing import orbit_contacts
from contin.hb.harmonics import coefficient_blocks
from contin.hb.problem import HarmonicBalance

__all__ = ["GrazingEnd", "EndCheckOptions", "RESOLVED", "REACH", "barrier_point", "branch_end_checks",
           "check_grazing_end", "grazing_end", "higher_harmonics"]

#: the grazing switching function's extremum at ``H'`` is zero to this fraction of its range over the period
RESOLVED = 0.05
#: the march past the grazing point covers this fraction of the parameter range
REACH = 1e-2
#: phases at which the switching functions are compared along the two orbits
_PHASES = 2048

_Failed = collections.namedtuple("_Failed", "converged message x")


@dataclasses.dataclass(frozen=True)
class EndCheckOptions:
    """Settings of :func:`grazing_end`.

    Parameters
    ----------
    resolved : float
        Tolerance of the truncation check, relative to the range of the
        switching function over the period (``0 < resolved < 1``).
    reach : float
        Length of the march past the grazing point, relative to the
        parameter range (``0 < reach <= 1``).
    first_step : int
        The march's first step is ``2**-first_step`` of its reach: a stiff
        stop's contact arc must open gradually for Newton to follow it.
    max_iter : int
        Newton updates per solve (a solve stops early when three updates in
        a row make no progress; one that converges slowly, next to the
        tangential touch, is let run).
    """

    resolved: float = RESOLVED
    reach: float = REACH
    first_step: int = 20
    max_iter: int = 30

    def __post_init__(self):
        for name, lo, hi in (("resolved", 0.0, 1.0), ("reach", 0.0, 1.0)):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not (lo < v <= hi) or not math.isfinite(v):
                raise ValueError(f"EndCheckOptions.{name} must be a number in ({lo:g}, {hi:g}], got {v!r}")
        for name in ("first_step", "max_iter"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
                raise ValueError(f"EndCheckOptions.{name} must be an integer >= 1, got {v!r}")


@dataclasses.dataclass(frozen=True)
class GrazingEnd:
    """The verdict on a branch end at a grazing point.

    Attributes
    ----------
    verdict : str
        ``"grazing"`` (an end as asked), ``"truncation"`` (made by the
        harmonics) or ``"numerics"`` (the orbit goes on past it).
    parameter : float
        The grazing point.
    direction : int
        ``+1`` if the branch ran towards larger parameter values at its end.
    harmonics, check_harmonics : int
        ``H`` and ``H'``.
    switches : int
        Contact switches per period of the end point at ``H``.
    check_switches : int or None
        At ``H'`` (None if Newton failed there).
    extremum : float or None
        The grazing switching function's extremum nearest to zero at ``H'``.
    change : float or None
        Largest change of that switching function from ``H`` to ``H'`` over
        the period, relative to its range.
    newton : str
        Newton's message at ``H'``.
    past : float or None
        For ``"numerics"``: the parameter of the last orbit of the march.
    past_switches : int or None
        Its switches per period.
    uncovered : tuple of float or None
        The interval beyond the grazing point the branch left (for a verdict
        other than ``"grazing"``).
    reason : str
        One sentence saying why.
    """

    verdict: str
    parameter: float
    direction: int
    harmonics: int
    check_harmonics: int
    switches: int
    check_switches: int | None
    extremum: float | None
    change: float | None
    newton: str
    past: float | None = None
    past_switches: int | None = None
    uncovered: tuple | None = None
    reason: str = ""

    @property
    def accepted(self) -> bool:
        """True for a grazing end as asked."""
        return self.verdict == "grazing"

    def as_dict(self) -> dict:
        d = dataclasses.asdict(self)
        d["uncovered"] = None if self.uncovered is None else [float(v) for v in self.uncovered]
        return d


def higher_harmonics(H: int) -> int:
    """``H' = H + max(8, H)``: the truncation the grazing is checked at."""
    return int(H) + max(8, int(H))


def _hb_of(problem):
    hb = problem.full
    return hb if isinstance(hb, HarmonicBalance) else None


def _full(problem, u, lam):
    return np.asarray(problem.expand(u, lam) if problem.condensed else u, dtype=float)


def _reduced(problem, u_full):
    return np.asarray(problem.restrict(u_full) if problem.condensed else u_full, dtype=float)


def _switching_values(hb: HarmonicBalance, u_full, lam: float, function) -> np.ndarray:
    """The switching function ``function = (element, index)`` along the orbit, at :data:`_PHASES` phases."""
    e, i = function
    el = hb.model.forces[e]
    p = hb.params_at(lam)
    phi = 2.0 * np.pi * np.arange(_PHASES) / _PHASES
    x, x1, _ = series_at(np.ascontiguousarray(coefficient_blocks(u_full, hb.n)), phi)
    return el.switching_functions(x, hb.base_frequency(p) * x1, hb.nu * phi, p).value[:, i]


def _solve(problem, u0, lam: float, tol: float, max_iter: int):
    """Newton at fixed ``lam`` (step halving against the contact's kinks; stops when it stalls)."""
    def fun_and_jac(u):
        R, Ju, _ = problem.linearize(u, lam)
        return R, Ju

    try:
        return newton(fun_and_jac, u0, tol, max_iter, backtrack=6, stall=3, divergence_factor=1e12)
    except NUMERICAL_ERRORS as exc:  # an evaluation that failed: no solution here
        return _Failed(False, f"{type(exc).__name__}: {exc}", u0)


def _truncation(problem, hb, u_full, lam, function, tol, opts) -> dict:
    """Solve again at ``H'`` and compare the switching function that grazes."""
    H2 = higher_harmonics(hb.H)
    N2 = int(math.ceil(hb.N * H2 / hb.H))
    N2 += N2 % 2
    p2 = problem.with_options(harmonics=H2, samples=max(N2, 2 * H2 + 1))
    hb2 = _hb_of(p2)
    padded = np.zeros(hb2.size)
    padded[: u_full.size] = u_full  # harmonics 0..H first, the new ones zero (contin.hb.harmonics ordering)
    res = _solve(p2, _reduced(p2, padded), lam, tol, opts.max_iter)
    out = {"check_harmonics": H2, "newton": res.message, "check_switches": None, "extremum": None, "change": None}
    if not res.converged:
        out["why"] = f"Newton did not converge there ({res.message})"
        return out
    u2 = _full(p2, res.x, lam)
    h = _switching_values(hb, u_full, lam, function)
    h2 = _switching_values(hb2, u2, lam, function)
    span = float(np.ptp(h))
    c2 = orbit_contacts(hb2, u2, lam)
    # the extremum of the grazing function itself, nearest to zero (its phase may move a little)
    ext = float(c2.extremum) if c2.function == tuple(function) else float(h2[np.argmin(np.abs(h2))])
    change = float(np.abs(h2 - h).max()) / span if span > 0 else math.inf
    out.update(check_switches=int(c2.switches), extremum=ext, change=change)
    # the grazing itself must persist: the extremum still touches zero (a grazing located a little
    # elsewhere at H' is the same end); the rest of the function may move (the contact force's Gibbs
    # oscillations change with H where the orbit is in contact)
    if not abs(ext) <= opts.resolved * span:
        out["why"] = (f"the contact differs: the switching function's extremum nearest to zero is {ext:.3g}, "
                      f"{abs(ext) / span:.2g} of its range {span:.3g} over the period (it moved by {change:.2g} "
                      f"of that range), with {c2.switches} switches per period")
    return out


def _march(problem, hb, u_end, lam: float, direction: int, lam_range, switches: int, tol, opts):
    """Newton at fixed parameter from the end point past the grazing point; ``(lam, switches)`` reached or None.

    The steps start at ``2**-first_step`` of the reach and grow by 8 after a solve of at most three
    updates, by 2 after a longer one; the first failed solve ends the march.
    """
    lo, hi = lam_range
    room = (hi - lam) if direction > 0 else (lam - lo)
    reach = min(opts.reach * (hi - lo), room)
    if not reach > 1e-12 * max(1.0, abs(lam)):
        return None  # at the range end: nothing beyond to reach
    u_prev, l_prev, u, lam_k = None, None, np.asarray(u_end, dtype=float), lam
    d = reach * 2.0 ** -opts.first_step
    while True:
        l_new = lam + direction * d
        guess = u if u_prev is None else u + (u - u_prev) * (l_new - lam_k) / (lam_k - l_prev)
        res = _solve(problem, guess, l_new, tol, opts.max_iter)
        if not res.converged:
            return None
        u_prev, l_prev, u, lam_k = u, lam_k, np.asarray(res.x, dtype=float), l_new
        if d >= reach:
            break
        d = min(reach, d * (8.0 if res.iterations <= 3 else 2.0))
    c = orbit_contacts(hb, _full(problem, u, lam_k), lam_k)
    return (lam_k, int(c.switches)) if c.switches != switches else None


def grazing_end(problem, point: SpecialPoint, direction: int, lam_range, tol: float = 1e-10,
                options: EndCheckOptions = EndCheckOptions(), name: str = "lambda") -> GrazingEnd | None:
    """The verdict on a branch end at the grazing point ``point`` (see the module docstring).

    Parameters
    ----------
    problem : HarmonicBalance or CondensedHarmonicBalance
        The problem the branch followed (``point.unknowns`` are its unknowns).
    point : SpecialPoint
        The located grazing point the branch could not pass.
    direction : int
        ``+1`` if the branch ran towards larger parameter values there, ``-1`` if smaller.
    lam_range : (float, float)
        The parameter range.
    tol : float
        Newton tolerance (the branch's own).
    options : EndCheckOptions
    name : str
        The parameter's name (in the reason).

    Returns
    -------
    GrazingEnd or None
        None for a problem that is no harmonic balance, or a point without a grazing function.
    """
    hb = _hb_of(problem)
    if hb is None or hb.H < 1:
        return None
    lam = float(point.parameter)
    lo, hi = (float(v) for v in lam_range)
    u_full = _full(problem, point.unknowns, lam)
    contacts = orbit_contacts(hb, u_full, lam)
    if contacts.function is None:
        return None
    direction = 1 if direction > 0 else -1
    uncovered = (lam, hi) if direction > 0 else (lo, lam)
    t = _truncation(problem, hb, u_full, lam, contacts.function, tol, options)
    common = dict(parameter=lam, direction=direction, harmonics=hb.H, switches=int(contacts.switches),
                  check_harmonics=t["check_harmonics"], check_switches=t["check_switches"],
                  extremum=t["extremum"], change=t["change"], newton=t["newton"])
    if "why" in t:
        return GrazingEnd("truncation", **common, uncovered=uncovered,
                          reason=f"at H'={t['check_harmonics']} {t['why']}")
    past = _march(problem, hb, point.unknowns, lam, direction, (lo, hi), int(contacts.switches), tol, options)
    if past is not None:
        return GrazingEnd("numerics", **common, past=past[0], past_switches=past[1], uncovered=uncovered,
                          reason=f"the orbit goes on past it: at the same harmonics Newton at fixed {name} found "
                                 f"it at {name}={past[0]:.10g} with {past[1]} contact switches per period "
                                 f"({contacts.switches} at the grazing point)")
    return GrazingEnd("grazing", **common,
                      reason=f"the grazing is the orbit's own (at H'={t['check_harmonics']} the switching function "
                             f"moves by {t['change']:.2g} of its range) and no orbit past it was found")


_BARRIER = re.compile(r"cannot pass the grazing point at \S+?=(\S+?) \(")


def _end_point(branch: Branch) -> SpecialPoint | None:
    """The grazing point a ``boundary`` branch could not pass (the first of a cascade), or None."""
    if branch.status is not BranchStatus.BOUNDARY:
        return None
    graz = [sp for sp in branch.special_points if sp.kind is SpecialKind.GRAZING]
    if not graz:
        return None
    m = _BARRIER.search(branch.message or "")
    if m is None:
        return graz[-1]
    try:
        at = float(m.group(1))
    except ValueError:
        return graz[-1]
    return min(graz, key=lambda sp: abs(sp.parameter - at))


def _direction(branch: Branch, sp: SpecialPoint) -> int:
    """The branch's running direction in the parameter at ``sp``."""
    if sp.tangent is not None and np.asarray(sp.tangent).size and np.asarray(sp.tangent)[-1] != 0:
        return 1 if np.asarray(sp.tangent)[-1] > 0 else -1
    lam = np.asarray(branch.parameter, dtype=float)
    if lam.size == 0:  # nothing stored to tell: the direction the branch was asked to run
        return -1 if (branch.info.get("options") or {}).get("direction", 1) < 0 else 1
    i = min(max(int(sp.index), 0), lam.size - 1)
    before = lam[i - 1] if i >= 1 else lam[0]
    return 1 if sp.parameter >= before else -1


def barrier_point(branch: Branch) -> tuple[SpecialPoint, int] | None:
    """The grazing point a ``boundary`` branch could not pass (the first of a cascade) and the branch's running
    direction in the parameter as it reached it; None for any other end."""
    sp = _end_point(branch)
    return None if sp is None else (sp, _direction(branch, sp))


def check_grazing_end(problem, branch: Branch, lam_range, tol: float = 1e-10,
                      options: EndCheckOptions = EndCheckOptions(), name: str = "lambda") -> GrazingEnd | None:
    """:func:`grazing_end` at the grazing point a ``boundary`` branch ended at; None for any other end."""
    sp = _end_point(branch)
    if sp is None:
        return None
    return grazing_end(problem, sp, _direction(branch, sp), lam_range, tol, options, name)


def branch_end_checks(results, problems: dict, branches_info: list, lam_range, tol: float, name: str,
                      options: EndCheckOptions = EndCheckOptions()) -> list[str]:
    """Check every branch that ended at a grazing point; the shortfall lines of those that fell short.

    Parameters
    ----------
    results : list of (Branch, dict)
        The branches of a frequency response, by id.
    problems : dict
        Branch id -> the problem it followed (branches without one are not checked).
    branches_info : list of dict
        The branches' entries of ``summary.json``: each checked one gets
        ``end_check`` (:meth:`GrazingEnd.as_dict`), and one that fell short
        ``end`` (``"truncation"`` or ``"numerics"``) and ``uncovered``.
    lam_range : (float, float)
    tol : float
        Newton tolerance.
    name : str
        The continuation parameter.

    Returns
    -------
    list of str
        One line per branch whose grazing end is not an end as asked.
    """
    lines = []
    for bid, ((branch, _), info) in enumerate(zip(results, branches_info)):
        problem = problems.get(bid)
        if problem is None:
            continue
        v = check_grazing_end(problem, branch, lam_range, tol, options, name)
        if v is None:
            continue
        info["end_check"] = v.as_dict()
        if v.accepted:
            continue
        info["end"] = v.verdict
        info["uncovered"] = [float(v.uncovered[0]), float(v.uncovered[1])]
        who = f"branch {info.get('branch', bid)}" + (f" (nu={info['nu']})" if "nu" in info else "")
        at = f"{name}={v.parameter:.10g}"
        gap = f"; {name} in [{v.uncovered[0]:.10g}, {v.uncovered[1]:.10g}] not covered"
        if v.verdict == "truncation" and v.check_switches is None:  # no orbit at H': not confirmed either way
            lines.append(f"{who} ended at a grazing point at {at} that harmonics {v.harmonics} may not resolve "
                         f"({v.reason}); raise analysis.harmonics{gap}")
        elif v.verdict == "truncation":
            lines.append(f"{who} ended at a grazing point at {at} that harmonics {v.harmonics} does not resolve "
                         f"({v.reason}); raise analysis.harmonics{gap}")
        else:
            tip = f"; shooting could not take it over: {info['handover_failed']}" if info.get("handover_failed") else ""
            lines.append(f"{who} ended at a grazing point at {at} that the continuation could not pass ({v.reason})"
                         f"{gap}{tip}")
    return lines
