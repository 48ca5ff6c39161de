"""Whirl components of a rotor's disc along a speed sweep of time simulations.

What the rotor paper's Fig. 3 shows (Inagaki, Ishida & Hayashi, Trans. JSME C
71 (2005), section 3): the rotor is integrated at one speed ``w`` after the
other, each run started from the last state of the previous one (a slow
up or down sweep), and the steady motion of the disc is split into its whirl
components. With the complex displacement of the disc ``z = x1 + i y1 =
sum_f c_f exp(i f t)`` a spectral line at a frequency ``f > 0`` is a forward
whirl of radius ``|c_f|``, at ``f < 0`` a backward one. Each line is one of

- the **forced** (harmonic) whirl, forward at ``+w`` (the unbalance);
- the **subharmonic** whirl, forward at ``+w/2`` (the 1/2-order subharmonic);
- the **self-excited** forward whirl at ``p_f``, the strongest forward line
  that is not at a rational multiple of ``w`` (neither ``k w/2`` nor ``j w/q``,
  ``q <= max_denominator``);
- the **combination** oscillation, backward at ``p_f - w`` (the paper's
  ``p_f - p_b = w`` with the backward frequency ``p_b = p_f - w < 0``);
- **other**: every other line (harmonics ``k w`` and ``k w/2`` of higher order,
  backward whirls at ``-w`` and ``-w/2``, further combinations ``m p_f + k w``).

The verdict at a speed:

- ``"quasi-periodic"``: a self-excited forward whirl ``p_f`` is present;
- ``"entrained (w/2)"``: no ``p_f``, a ``+w/2`` whirl is present and every
  present line is at a multiple of ``w/2``;
- ``"harmonic"``: every present line (if any) is at a multiple of ``w``;
- ``"other"``: anything else (a backward or other-order subharmonic, a
  response locked at ``j w/q``, a backward self-excited whirl).

Tolerances (:class:`WhirlOptions`)
----------------------------------
A line is **present** when its radius is at least ``presence`` (1 %) of the
strongest line's (the mean, the static deflection by ``f0``, excluded); weaker
lines are ignored, which keeps the rest of a transient out of the verdict.

A line is **at** ``k w/2`` when its frequency, refined together with the
other lines (:func:`contin.timedomain.spectral_lines.spectral_lines`), is within
``rational`` bins of it (1/100 of a bin; a bin is the resolution
``2 pi / T_rec = w / R`` of a record of ``R`` revolutions). In a settled
periodic (forced or entrained) response the refined lines sit on ``k w/2`` far
closer than that; what moves them is what was not fitted (weak lines, the rest
of the transient), whose bias scales with the bin. A self-excited whirl closer
to ``w/2`` than 1/100 of a bin beats with it over a hundred records: no
record of this length tells the two apart, and a tolerance fixed in units of
``w`` would only make the verdict depend on how long the rest of the
transient biases the line. The combination line is matched to ``p_f - w``
within ``combination`` bins (half a bin): lines closer than three bins (the
main lobe of the window) are not found separately, so no other line can
match.

Record length near locking
--------------------------
Near the ends of the entrainment range the self-excited whirl ``p_f`` lies
close to ``w/2`` and beside its mirror ``w - p_f`` (also forward, a
combination with the forced whirl), ``2 |p_f - w/2|`` apart. Lines are found
separately when they are at least the main lobe of the window, three bins
``w/R``, apart:

    R >= 1.5 / |p_f / w - 1/2|,

300 revolutions for ``p_f = 0.495 w``. A shorter record fits one line for the
two: the verdict is still ``quasi-periodic`` (that line is not at ``w/2``), but
``p_f`` and its radius are biased by the mirror.

The transient matters as much: near the speeds where the harmonic or the
subharmonic solution changes stability its decay rate vanishes, and a
decaying self-excited whirl (or the sidebands of a subharmonic still
settling) stays above ``presence`` for many revolutions and is reported as
``quasi-periodic``. Continuing each speed from the previous one
(``continue_state``) starts every run close to its steady state.
"""

from __future__ import annotations

import dataclasses
import enum
import math
import time
from fractions import Fraction
from typing import Callable, Mapping, Sequence

import numpy as np

from contin.model.base import Model
from contin.timedomain.simulation import simulate
from contin.timedomain.spectral_lines import spectral_lines

__all__ = ["Component", "Verdict", "WhirlOptions", "WhirlState", "WhirlSweep", "classify_whirl", "component_sweep",
           "CSV_COLUMNS"]


class Component(enum.Enum):
    """What a spectral line of the disc's whirl is."""

    FORCED = "forced"  # forward at +w
    SUBHARMONIC = "subharmonic"  # forward at +w/2
    SELF_EXCITED = "self-excited"  # forward at p_f, not a rational multiple of w
    COMBINATION = "combination"  # backward at p_f - w
    OTHER = "other"


class Verdict(str, enum.Enum):
    """Kind of steady motion at one speed (the values are the texts written to the CSV)."""

    HARMONIC = "harmonic"
    ENTRAINED = "entrained (w/2)"
    QUASI_PERIODIC = "quasi-periodic"
    OTHER = "other"


@dataclasses.dataclass(frozen=True)
class WhirlOptions:
    """Tolerances of the line classification (see the module's docstring).

    Attributes
    ----------
    presence : float
        A line counts when its radius is at least this fraction of the strongest line's.
    rational : float
        A line is at ``k w/2`` (or at ``j w/q``) when within ``rational`` bins of it (a bin is the
        resolution ``2 pi / T_rec`` of the record, ``w / R`` for ``R`` revolutions).
    combination : float
        The combination line is within ``combination`` bins of ``p_f - w``.
    max_denominator : int
        A forward line within ``rational * w`` of ``j w/q``, ``q <= max_denominator``, is locked to
        the speed and is not a self-excited whirl.
    count : int
        Strongest spectral lines examined.
    samples_per_period : int
        Recorded samples of the disc per revolution (a divisor of ``steps_per_period``).
    dofs : tuple of int
        The disc's dofs ``(x, y)``: ``z = x + i y``.
    """

    presence: float = 1e-2
    rational: float = 1e-2
    combination: float = 0.5
    max_denominator: int = 8
    count: int = 12
    samples_per_period: int = 32
    dofs: tuple = (0, 1)

    def __post_init__(self):
        if not 0.0 < self.presence < 1.0:
            raise ValueError(f"WhirlOptions.presence must lie in (0, 1), got {self.presence}")
        if not (self.rational > 0.0 and self.combination > 0.0):
            raise ValueError("WhirlOptions.rational and .combination must be positive")
        if self.max_denominator < 2 or self.count < 1 or self.samples_per_period < 8:
            raise ValueError("WhirlOptions: max_denominator >= 2, count >= 1 and samples_per_period >= 8 are needed")
        if len(self.dofs) != 2:
            raise ValueError(f"WhirlOptions.dofs must name two dofs (x, y), got {self.dofs}")


@dataclasses.dataclass(frozen=True)
class WhirlState:
    """The whirl components of the disc at one speed.

    Attributes
    ----------
    w : float
        The speed.
    forced, subharmonic, self_excited, combination : float
        Radii of the forward whirls at ``+w``, ``+w/2`` and ``p_f`` and of the backward whirl at
        ``p_f - w`` (0 where absent).
    other : float
        Radius of the strongest other present line (0 if none).
    other_frequency : float
        Its signed frequency (0 if none).
    pf : float
        The self-excited whirl's frequency ``p_f`` (0 where absent: see ``has_pf``).
    has_pf : bool
        Whether a self-excited forward whirl is present.
    verdict : Verdict
    lines : tuple of (Line, Component)
        The present lines, strongest first, with what each is.
    """

    w: float
    forced: float
    subharmonic: float
    self_excited: float
    combination: float
    other: float
    other_frequency: float
    pf: float
    has_pf: bool
    verdict: Verdict
    lines: tuple


def _near(f: float, target: float, tol: float) -> bool:
    return abs(f - target) < tol


def _half_order(f: float, w: float, tol: float) -> int | None:
    """``k`` when ``f`` is within ``tol`` of ``k w/2``, else None."""
    k = round(2.0 * f / w)
    return k if abs(f - 0.5 * k * w) < tol else None


def _locked(f: float, w: float, tol: float, qmax: int) -> bool:
    """Whether ``f`` lies within ``tol`` of ``j w/q`` with ``q <= qmax``."""
    r = Fraction(f / w).limit_denominator(qmax)
    return abs(f - float(r) * w) < tol


def classify_whirl(t: np.ndarray, z: np.ndarray, w: float, options: WhirlOptions | None = None) -> WhirlState:
    """Split a recorded whirl ``z = x + i y`` into its components and give the verdict.

    Parameters
    ----------
    t : ndarray, shape (N,)
        Uniform sample times of a steady record; whole revolutions (an even number of them, so that
        the ``w/2`` line lies on a bin).
    z : ndarray, shape (N,), complex
        The disc's complex displacement ``x1 + i y1``.
    w : float
        The speed.
    options : WhirlOptions, optional

    Returns
    -------
    WhirlState
    """
    opt = options or WhirlOptions()
    t = np.asarray(t, dtype=float)
    z = np.asarray(z, dtype=complex)
    if t.shape != z.shape or t.ndim != 1:
        raise ValueError(f"classify_whirl: t and z must be 1-D of one length, got {t.shape} and {z.shape}")
    if not (math.isfinite(w) and w > 0.0):
        raise ValueError(f"classify_whirl: the speed must be positive, got {w}")
    # refined together (NAFF): each line's frequency free of the leakage of the others found
    lines = spectral_lines(t, z, count=opt.count, floor=opt.presence, exclude_zero=True)
    bin_width = 2.0 * math.pi / (t.size * (t[-1] - t[0]) / (t.size - 1))  # 2 pi / T_rec
    tol_r, tol_c = opt.rational * bin_width, opt.combination * bin_width
    kind: list[Component] = []
    pf = None
    for ln in lines:
        k = _half_order(ln.frequency, w, tol_r)
        if k == 2:
            kind.append(Component.FORCED)
        elif k == 1:
            kind.append(Component.SUBHARMONIC)
        elif (k is None and pf is None and ln.frequency > 0.0
              and not _locked(ln.frequency, w, tol_r, opt.max_denominator)):
            kind.append(Component.SELF_EXCITED)  # the strongest such line (lines are sorted)
            pf = ln.frequency
        else:
            kind.append(Component.OTHER)
    if pf is not None:
        # the combination: the strongest backward line at p_f - w
        for i, ln in enumerate(lines):
            if kind[i] is Component.OTHER and ln.frequency < 0.0 and _near(ln.frequency, pf - w, tol_c):
                kind[i] = Component.COMBINATION
                break

    def radius(c: Component) -> float:
        return next((ln.amplitude for ln, k in zip(lines, kind) if k is c), 0.0)

    others = [ln for ln, k in zip(lines, kind) if k is Component.OTHER]
    at_half = all(_half_order(ln.frequency, w, tol_r) is not None for ln in lines)
    at_one = all((_half_order(ln.frequency, w, tol_r) or 1) % 2 == 0 for ln in lines)
    if pf is not None:
        verdict = Verdict.QUASI_PERIODIC
    elif at_one:  # no line at all (a static equilibrium) is period-1 as well
        verdict = Verdict.HARMONIC
    elif Component.SUBHARMONIC in kind and at_half:
        verdict = Verdict.ENTRAINED
    else:
        verdict = Verdict.OTHER
    return WhirlState(
        w=float(w), forced=radius(Component.FORCED), subharmonic=radius(Component.SUBHARMONIC),
        self_excited=radius(Component.SELF_EXCITED), combination=radius(Component.COMBINATION),
        other=others[0].amplitude if others else 0.0, other_frequency=others[0].frequency if others else 0.0,
        pf=float(pf) if pf is not None else 0.0, has_pf=pf is not None, verdict=verdict,
        lines=tuple(zip(lines, kind)))


#: columns of :meth:`WhirlSweep.to_rows`, in order
CSV_COLUMNS = ("w", "verdict", "forced_radius", "subharmonic_radius", "self_excited_radius", "combination_radius",
               "other_radius", "other_frequency", "has_pf", "pf", "pf_over_w", "events", "wall_time")


@dataclasses.dataclass(frozen=True, eq=False)
class WhirlSweep:
    """Whirl components of the disc along a sweep of the speed, in the order the speeds were run.

    Attributes
    ----------
    w : ndarray, shape (N,)
        The speeds.
    forced : ndarray, shape (N,)
        Radius of the forward whirl at ``+w`` (0 where absent).
    subharmonic : ndarray, shape (N,)
        Radius of the forward whirl at ``+w/2`` (0 where absent).
    self_excited : ndarray, shape (N,)
        Radius of the self-excited forward whirl at ``p_f`` (0 where absent).
    combination : ndarray, shape (N,)
        Radius of the backward whirl at ``p_f - w`` (0 where absent).
    other : ndarray, shape (N,)
        Radius of the strongest other present line (0 if none).
    other_frequency : ndarray, shape (N,)
        Its signed frequency (0 if none).
    pf : ndarray, shape (N,)
        Frequency ``p_f`` of the self-excited whirl; 0 where ``has_pf`` is false (no NaN is stored).
    has_pf : ndarray of bool, shape (N,)
        Where a self-excited forward whirl is present.
    verdict : ndarray of str, shape (N,)
        :class:`Verdict` values.
    events : ndarray of int, shape (N,)
        Contact switching events located in each run.
    wall_time : ndarray, shape (N,)
        Seconds spent integrating each speed.
    final_state : ndarray, shape (2n,)
        State ``(x, x')`` at the end of the last run (to continue the sweep).
    params : dict
        Parameter values of the model (the speed: its first value).
    transient_periods, record_periods : float, int
        Revolutions dropped and recorded at each speed.
    steps_per_period : int
    options : WhirlOptions
    """

    w: np.ndarray
    forced: np.ndarray
    subharmonic: np.ndarray
    self_excited: np.ndarray
    combination: np.ndarray
    other: np.ndarray
    other_frequency: np.ndarray
    pf: np.ndarray
    has_pf: np.ndarray
    verdict: np.ndarray
    events: np.ndarray
    wall_time: np.ndarray
    final_state: np.ndarray
    params: dict
    transient_periods: float
    record_periods: int
    steps_per_period: int
    options: WhirlOptions

    def __len__(self) -> int:
        return int(self.w.size)

    def speeds_with(self, verdict: Verdict | str) -> np.ndarray:
        """The speeds with one verdict, shape (M,)."""
        return self.w[self.verdict == Verdict(verdict).value]

    def to_rows(self) -> list[dict]:
        """One dict per speed, keys :data:`CSV_COLUMNS` (``pf`` and ``pf_over_w`` None where absent,
        an empty cell in a CSV)."""
        rows = []
        for i in range(len(self)):
            pf = float(self.pf[i]) if self.has_pf[i] else None
            rows.append({
                "w": float(self.w[i]), "verdict": str(self.verdict[i]), "forced_radius": float(self.forced[i]),
                "subharmonic_radius": float(self.subharmonic[i]), "self_excited_radius": float(self.self_excited[i]),
                "combination_radius": float(self.combination[i]), "other_radius": float(self.other[i]),
                "other_frequency": float(self.other_frequency[i]), "has_pf": bool(self.has_pf[i]), "pf": pf,
                "pf_over_w": None if pf is None else pf / float(self.w[i]), "events": int(self.events[i]),
                "wall_time": float(self.wall_time[i])})
        return rows


def component_sweep(model: Model, params: Mapping[str, float] | None, speeds: Sequence[float], *,
                    transient_periods: float, record_periods: int, steps_per_period: int,
                    continue_state: bool = True, progress: Callable[[int, int], None] | None = None,
                    options: WhirlOptions | None = None, x0=None, v0=None) -> WhirlSweep:
    """Simulate the model at each speed in turn and split the disc's whirl into its components.

    Parameters
    ----------
    model : Model
        A rotor whose ``options.dofs`` are the disc's ``x`` and ``y`` (``bearing_rotor``: x1, y1).
    params : dict, optional
        Parameter overrides (the speed is set from ``speeds``).
    speeds : sequence of float, shape (N,)
        Run in this order (increasing for an up sweep, decreasing for a down sweep).
    transient_periods : float
        Revolutions integrated and dropped at each speed before the record.
    record_periods : int
        Revolutions recorded (rounded up to an even number: the ``w/2`` line then lies on a bin).
        Near locking ``record_periods >= 2 / |p_f/w - 1/2|`` tells ``p_f`` from its mirror ``w - p_f``.
    steps_per_period : int
        RK4 steps per revolution (the paper: 4096); ``simulate`` refuses too few for the contact.
    continue_state : bool
        Start each speed from the last state of the previous one (a slow sweep); otherwise every
        speed starts from ``x0, v0``.
    progress : callable, optional
        ``progress(done, total)`` after each speed.
    options : WhirlOptions, optional
    x0, v0 : array_like, shape (n,), optional
        Initial state of the first speed (default: rest).

    Returns
    -------
    WhirlSweep
    """
    opt = options or WhirlOptions()
    ws = np.asarray(speeds, dtype=float).reshape(-1)
    if ws.size == 0 or not np.all(np.isfinite(ws)) or np.any(ws <= 0.0):
        raise ValueError("component_sweep: speeds must be a non-empty sequence of positive numbers")
    S = int(steps_per_period)
    if S % opt.samples_per_period:
        raise ValueError(f"component_sweep: samples_per_period ({opt.samples_per_period}) must divide "
                         f"steps_per_period ({S})")
    record = 2 * int(math.ceil(record_periods / 2.0))
    if record < 4 or transient_periods < 0:
        raise ValueError("component_sweep: record at least 4 revolutions after a non-negative transient")
    n = model.n_dof
    dx, dy = (int(d) for d in opt.dofs)
    start_x, start_v = x0, v0
    states, events, walls = [], [], []
    y = None
    for i, w in enumerate(ws):
        p = dict(params or {})
        p[model.frequency] = float(w)
        if continue_state and y is not None:
            start_x, start_v = y[:n], y[n:]
        t0 = time.perf_counter()
        res = simulate(model, p, start_x, start_v, periods=transient_periods + record, steps_per_period=S,
                       record_every=S // opt.samples_per_period, record_from=transient_periods)
        y = res.final_state
        # the last sample repeats the phase of the first: whole revolutions without it
        t, x = res.t[:-1], res.x[:-1]
        states.append(classify_whirl(t, x[:, dx] + 1j * x[:, dy], float(w), opt))
        events.append(res.events)
        walls.append(time.perf_counter() - t0)
        if progress is not None:
            progress(i + 1, ws.size)
    def col(name: str) -> np.ndarray:
        return np.array([getattr(s, name) for s in states], dtype=float)

    p = dict(params or {})
    p[model.frequency] = float(ws[0])
    return WhirlSweep(
        w=ws.copy(), forced=col("forced"), subharmonic=col("subharmonic"), self_excited=col("self_excited"),
        combination=col("combination"), other=col("other"), other_frequency=col("other_frequency"), pf=col("pf"),
        has_pf=np.array([s.has_pf for s in states], dtype=bool),
        verdict=np.array([s.verdict.value for s in states], dtype=str), events=np.array(events, dtype=np.int64),
        wall_time=np.array(walls), final_state=np.asarray(y, dtype=float).copy(),
        params=dict(zip(model.param_names, map(float, model.parameter_vector(p)))),
        transient_periods=float(transient_periods), record_periods=record, steps_per_period=S, options=opt)
