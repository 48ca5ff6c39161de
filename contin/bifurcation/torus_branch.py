"""Following a quasi-periodic (torus) branch from its first point, with stability and its ends told.

The branch is traced by the same continuation engine as the periodic ones
(the problem is :class:`contin.hb.torus.QuasiPeriodicBalance`). Its stability
comes from a time simulation started on each point
(:func:`contin.timedomain.torus_check.check_torus`), reported in the
columns of the periodic branches (``stable``; ``max_multiplier`` is the
distance's growth over one forcing period; ``n_unstable`` is 1 where the
trajectory left the torus).

A torus branch ends where its parametrisation by two frequencies breaks
down, and the engine's step control meets that as steps that fail:

- **locking**: the ratio ``w2 / (w/nu)`` reaches a rational ``p/q`` of small
  ``q`` (for the rotor ``1/2``: the self-excited whirl entrained into the
  ``+w/2`` subharmonic). The two frequencies then generate the same
  spectrum and the torus carries periodic orbits (Arnold tongue); the
  branch ends with status ``boundary`` and a ``locking`` special point.
- **collapse**: the self-excited line shrinks to zero at another
  Neimark-Sacker point of the periodic branch (``w2`` is no longer
  determined); status ``boundary`` and an ``ns`` special point.

Any other failure keeps the engine's status and message.
"""

from __future__ import annotations

import dataclasses
import enum
from fractions import Fraction
from typing import Mapping

import numpy as np

from contin.engine.branch import Branch, BranchStatus, SpecialKind, SpecialPoint
from contin.engine.continuation import ContinuationOptions, continuation
from contin.hb.torus import TorusOptions
from contin.timedomain.integrator import SimulationError
from contin.timedomain.torus_check import check_torus
from contin.util.options import check_keys, field_names, from_mapping

__all__ = ["TorusContinuation", "TorusSettings", "TorusStabilityMonitor", "run_torus", "classify_end",
           "end_as_boundary"]

#: a branch ending with the self-excited line below this fraction of its largest size has collapsed
COLLAPSED = 1e-2


class TorusContinuation(str, enum.Enum):
    """How a circle branch is followed (:class:`TorusSettings`)."""

    ARCLENGTH = "arclength"
    NATURAL = "natural"


@dataclasses.dataclass(frozen=True)
class TorusSettings:
    """How torus branches are discretised, checked and ended.

    A torus started on a harmonic-balance branch is a two-frequency balance (``options``); one started on a
    shooting branch an invariant circle of ``points`` points (:mod:`contin.bifurcation.circle_branch`), its
    stability from its Lyapunov exponents unless ``stability`` is ``none``.

    Parameters
    ----------
    options : TorusOptions or None
        Harmonics and grid; None: ``H1`` = the periodic branch's ``H``, ``H2 = 3``.
    stability : {'simulation', 'none'}
    periods : float
        Forcing periods simulated by the stability check.
    steps_per_period : int
        RK4 steps per forcing period of the check.
    locking_tol : float
        ``|w2/(w/nu) - p/q|`` below which a branch that stops is said to lock (a torus of harmonic balance;
        a circle's locking: :mod:`contin.bifurcation.circle_branch`).
    max_denominator : int
        Largest ``q`` of the locking ratios (harmonic balance).
    points : int
        ``N``, points of the invariant circle of a torus started on a shooting branch (odd, >= 3).
    continuation : TorusContinuation or str
        How a circle branch is followed: pseudo-arclength (the engine's, through folds) or natural steps in
        the parameter (:mod:`contin.bifurcation.circle_natural`: no folds, but no crawl at the corners of a
        system with contact either).
    """

    options: TorusOptions | None = None
    stability: str = "simulation"
    periods: float = 200.0
    steps_per_period: int = 256
    locking_tol: float = 0.02
    max_denominator: int = 4
    points: int = 15
    continuation: TorusContinuation = None

    def __post_init__(self):
        value = TorusContinuation.ARCLENGTH if self.continuation is None else self.continuation
        try:
            object.__setattr__(self, "continuation", TorusContinuation(value))
        except ValueError:
            raise ValueError(f"TorusSettings.continuation must be one of "
                             f"{[c.value for c in TorusContinuation]}, got {value!r}") from None
        if isinstance(self.points, bool) or not isinstance(self.points, int) or self.points < 3 or self.points % 2 == 0:
            raise ValueError(f"TorusSettings.points must be an odd integer >= 3 (the circle's points), "
                             f"got {self.points!r}")
        if self.stability not in ("simulation", "none"):
            raise ValueError(f"TorusSettings.stability must be 'simulation' or 'none', got {self.stability!r}")
        if not self.periods > 0:
            raise ValueError(f"TorusSettings.periods must be > 0, got {self.periods!r}")
        if not (isinstance(self.steps_per_period, int) and self.steps_per_period >= 4):
            raise ValueError(f"TorusSettings.steps_per_period must be an integer >= 4, got {self.steps_per_period!r}")
        if not 0 < self.locking_tol < 0.25:
            raise ValueError(f"TorusSettings.locking_tol must be in (0, 0.25), got {self.locking_tol!r}")

    @classmethod
    def from_dict(cls, d: dict, harmonics: int) -> "TorusSettings":
        """From a scene's ``analysis.torus`` mapping; ``harmonics`` is the periodic branch's ``H``.

        The grid's keys (``harmonics``, ``harmonics2``, ``samples``, ``samples2``) sit in the mapping itself
        and make :attr:`options`; a None value keeps a default. Built by
        :func:`contin.util.options.from_mapping`: an unknown key raises ``ValueError`` naming the nearest
        valid one, a refused grid value is named ``TorusSettings.options``.
        """
        d = {} if d is None else d
        if not isinstance(d, Mapping):
            raise TypeError(f"TorusSettings.from_dict: expected a mapping of option names to values, "
                            f"got {type(d).__name__}")
        grid = ("harmonics", "harmonics2", "samples", "samples2")
        check_keys(cls, d, [*grid, *(f for f in field_names(cls) if f != "options")])
        nested = {"harmonics": d.get("harmonics") or harmonics, "harmonics2": d.get("harmonics2") or 3,
                  "samples": d.get("samples"), "samples2": d.get("samples2")}
        rest = {k: v for k, v in d.items() if k not in grid and v is not None}
        return from_mapping(cls, {**rest, "options": nested},
                            converters={"options": lambda m: from_mapping(TorusOptions, m)})

    def torus_options(self, harmonics: int) -> TorusOptions:
        return self.options if self.options is not None else TorusOptions(harmonics=harmonics)


class TorusStabilityMonitor:
    """Engine monitor: the verdict of a simulation started on each point (see :mod:`contin.timedomain.torus_check`)."""

    def __init__(self, problem, settings: TorusSettings):
        self.problem = problem
        self.settings = settings
        self.failures: list[tuple[float, str]] = []  # (lambda, why) of the points without a verdict

    def __call__(self, u, lam, Ju=None, Jlam=None) -> dict:
        s = self.settings
        try:
            v = check_torus(self.problem, u, lam, periods=s.periods, steps_per_period=s.steps_per_period)
        except SimulationError as exc:
            self.failures.append((float(lam), f"simulation failed: {exc}"))
            return {"evaluated": False, "stable": False, "n_unstable": 0, "max_multiplier": 0.0}
        if v.stable is None:
            self.failures.append((float(lam), v.message))
            return {"evaluated": False, "stable": False, "n_unstable": 0, "max_multiplier": 0.0}
        return {"evaluated": True, "stable": bool(v.stable), "n_unstable": 0 if v.stable else 1,
                "max_multiplier": float(v.multiplier)}


def _ratio(problem, u, lam) -> float:
    return float(u[-1]) / problem.base_frequency(problem.params_at(lam))


def _nearest_rational(r: float, qmax: int) -> Fraction:
    return min((Fraction(p, q) for q in range(1, qmax + 1) for p in range(0, int(r * q) + 2)),
               key=lambda f: abs(r - float(f)))


def classify_end(branch: Branch, problem, settings: TorusSettings) -> None:
    """Tell a torus branch's end: locking or collapse onto the periodic branch (see the module docstring).

    Changes ``branch.status``, ``branch.message`` and appends the special
    point in place; a branch that reached its range end is left as it is.
    """
    if not len(branch) or branch.status in (BranchStatus.RANGE_END, BranchStatus.INTERRUPTED,
                                            BranchStatus.MAX_POINTS, BranchStatus.DEFAULT_MAX_POINTS,
                                            BranchStatus.CLOSED_LOOP, BranchStatus.RETRACED):
        return
    u, lam = branch.unknowns[-1], float(branch.parameter[-1])
    name = branch.parameter_name
    r = _ratio(problem, u, lam)
    f = _nearest_rational(r, settings.max_denominator)
    j, i = problem.pin
    amp = np.array([abs(v[problem.n * (2 * j - 1) + i]) for v in branch.unknowns])
    kind = None
    if f.numerator > 0 and abs(r - float(f)) < settings.locking_tol:
        kind = SpecialKind.LOCKING
        why = (f"the torus locks: w2/(w/nu) = {r:.6g} approaches {f} at {name}={lam:.10g} (entrainment into the "
               f"motion of period {f.denominator} x 2 pi nu/w)")
    elif amp[-1] < COLLAPSED * amp.max():
        kind = SpecialKind.NS
        why = (f"the torus shrinks onto the periodic branch at a Neimark-Sacker point near {name}={lam:.10g} "
               f"(self-excited line {amp[-1]:.3g}, {amp.max():.3g} at most)")
    if kind is None:
        return
    end_as_boundary(branch, kind, lam, u, len(branch) - 1, {"ratio": r, "rational": str(f)}, why, "torus end")


def end_as_boundary(branch: Branch, kind: SpecialKind, lam: float, u, index: int, data: dict, why: str,
                    event: str) -> None:
    """End ``branch`` as ``boundary`` with the unlocated special point ``kind`` at ``lam`` (stored point ``index``,
    unknowns ``u``), its ``event`` name and ``why`` before the engine's message; a resumed branch that holds the
    point already keeps it. A collapse onto the periodic orbit (``kind`` NS) is the torus's end as asked
    (``info["end"] = "collapse"``: no shortfall, :func:`contin.scene.registry.shortfalls`)."""
    if not any(sp.event == event for sp in branch.special_points):
        prev = float(branch.parameter[index - 1]) if index > 0 else lam
        branch.special_points.append(SpecialPoint(
            kind=kind, parameter=lam, unknowns=np.array(u), interval=(prev, lam), index=index,
            s=float(branch.arclength[index]), located=False, data=data, message=why, event=event))
    branch.message = f"{why}; the engine stopped there: {branch.message}"
    branch.status = BranchStatus.BOUNDARY
    if kind is SpecialKind.NS:
        branch.info["end"] = "collapse"  # the torus shrinks onto the orbit it is born from: an end as asked


def run_torus(start, lam_range, options: ContinuationOptions, parameter_name: str, settings: TorusSettings,
              callback=None, checkpoint=None, resume=None) -> Branch:
    """Trace the torus branch from ``start`` (:func:`contin.bifurcation.torus_start.torus_start`).

    ``resume(problem, options, monitors) -> Branch`` takes up the same branch of an interrupted run
    instead (:func:`contin.bifurcation.diagram.follow` passes it).

    Returns
    -------
    Branch
        Its ``info`` holds ``torus`` (harmonics, grid, pin) besides the engine's.
    """
    qp = start.problem
    monitors = [] if settings.stability == "none" else [TorusStabilityMonitor(qp, settings)]
    opts = options.replace(unknown_scale=None, parameter_scale=None)
    if resume is not None:
        br = resume(qp, opts, monitors)
    else:
        br = continuation(qp, start.u, start.lam, lam_range, opts, parameter_name=parameter_name, monitors=monitors,
                          tangent=start.tangent, solve_start=False, callback=callback, checkpoint=checkpoint)
    if br.status is not BranchStatus.BOUNDARY:
        classify_end(br, qp, settings)
    for mon in monitors:
        if mon.failures:
            lam, why = mon.failures[0]
            br.message = (f"{br.message}; no stability verdict at {len(mon.failures)} point(s) (first at "
                          f"{parameter_name}={lam:.10g}: {why})")
    br.info["torus"] = {"harmonics": qp.H1, "harmonics2": qp.H2, "samples": qp.N1, "samples2": qp.N2,
                        "pin": list(qp.pin)}
    return br
