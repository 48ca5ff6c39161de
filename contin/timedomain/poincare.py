"""Steady state of a simulation: Poincare section, spectrum and classification.

A forced response is sampled once per forcing period, at ``tau = 0 mod 2 pi``
(the section points :attr:`contin.timedomain.simulation.SimulationResult.section`). A
``period-k`` response (``k = 1``: harmonic; ``k = 2``: the 1/2-order
subharmonic of the rotor paper) repeats its section points every ``k``
revolutions; a quasi-periodic or chaotic one (e.g. a self-excited forward
whirl at a frequency incommensurate with ``w``) never does.

The section alone can be fooled: a transient decaying through a Floquet
multiplier close to ``-1`` alternates between two points that drift together
only slowly, so it passes a two-periodicity test with a loose tolerance. The
classification therefore also requires, for ``k >= 2``,

- that the ``k``-periodic pattern is not decaying: its size (the spread of the
  means of the ``k`` residue classes of section points) is compared between
  the first and second half of the record, and
- that the spectrum (Hann window, many revolutions) of the observed pair of
  dofs has its non-harmonic content on the lines ``j w / k``: the strongest
  such line must dominate every non-harmonic line elsewhere.

A recorded response is *settled* only when it is a steady state of the
equations, not of the integrator or of a transient:

- its amplitude must not grow over the record (:func:`amplitude_growth`:
  the peak deviation from the mean rising in every quarter of the record, by
  more than ``10 tol`` from the first quarter to the last, is growth, without
  bound or still building up);
- the last revolutions integrated again with half the step must end where
  the run ended, to ``tol`` of the motion's range (:func:`step_refinement`);
  an explicit integrator beyond its stability limit (a stiff force that the
  step check before the run cannot see, a law written as an expression)
  gives an answer that depends on the step;
- a ``period-1`` response still converging within the record is not settled
  either.

The spectrum of the disc of a rotor is taken of the complex displacement
``z = x1 + i y1``: a line at ``+f`` is a forward whirl of radius ``|c_f|``, at
``-f`` a backward whirl, with ``z = sum_f c_f exp(i f t)``. The rotor paper
(Inagaki, Ishida & Hayashi, Trans. JSME C 71 (2005), Fig. 5 and 7) shows
these spectra of the disc; its 1/2-order subharmonic is the forward ``+w/2``
component.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Sequence

import numpy as np

from contin.model.base import Model
from contin.timedomain.simulation import SimulationError, simulate

__all__ = [
    "Classification",
    "REFINE_PERIODS",
    "amplitude_growth",
    "step_refinement",
    "section_points",
    "spectrum",
    "dominant_lines",
    "whirl_components",
    "classify",
    "steady_state",
]


@dataclasses.dataclass(eq=False)
class Classification:
    """Steady-state class of a simulated response.

    Attributes
    ----------
    label : str
        ``"period-k"`` (``k = 1..max_period``) or ``"not periodic"``.
    period : int or None
        ``k``, or None when not periodic.
    section : ndarray, shape (R, 2n)
        Section points (state at ``t = m T``) of the recorded window.
    spread : float
        Largest distance of a section point from their mean, relative to the
        amplitude scale (0 for an exact period-1 response).
    mismatch : dict
        ``k -> max_i |P[i+k] - P[i]|`` relative to the amplitude scale.
    pattern_ratio : float or None
        For ``k >= 2``: size of the ``k``-pattern in the second half of the
        record over that in the first half (1 when settled, < 1 when decaying).
    lines : list of (float, float)
        Dominant spectral lines ``(frequency / w, amplitude)`` of the observed
        dofs, strongest first (signed frequencies for a pair: ``+`` forward whirl).
    whirl : dict
        Complex amplitudes of ``z = x_a + i x_b`` at ``"+w/2"``, ``"-w/2"``,
        ``"+w"``, ``"-w"`` (``z = sum c_f exp(i f t)``; ``|c|`` is a whirl radius).
    subharmonic_dominance : float or None
        For ``k >= 2``: strongest line at ``j w/k`` (``j`` not a multiple of
        ``k``) over the strongest other non-harmonic line.
    note : str
        Why the class was chosen (or rejected).
    settled : bool
        False for a response that is not a steady state: a ``period-1``
        response still converging within the record, an amplitude that grows
        over the record, or a result that depends on the step
        (:func:`steady_state`).
    growth : float or None
        Peak deviation from the mean in the last quarter of the record over
        that in the first (:func:`amplitude_growth`).
    step_change : float or None
        The final state's change when the last revolutions are integrated
        again with half the step, relative to the motion's range
        (:func:`step_refinement`; None when not checked).
    unsettled : str
        Why the response is not settled ("" when it is).
    """

    label: str
    period: int | None
    section: np.ndarray
    spread: float
    mismatch: dict
    pattern_ratio: float | None
    lines: list
    whirl: dict
    subharmonic_dominance: float | None
    note: str = ""
    settled: bool = True
    growth: float | None = None
    step_change: float | None = None
    unsettled: str = ""

    def not_settled(self, reason: str) -> None:
        """Mark the response not settled, adding ``reason``."""
        self.settled = False
        self.unsettled = f"{self.unsettled}; {reason}" if self.unsettled else reason

    @property
    def periodic(self) -> bool:
        return self.period is not None


def section_points(result) -> np.ndarray:
    """Section points of the recorded window of a :class:`SimulationResult`, shape (R, 2n)."""
    if result.t.size == 0:
        return result.section[:0]
    m0 = int(math.ceil(result.t[0] / result.period - 1e-9))
    return result.section[m0:]


def _hann(N: int) -> np.ndarray:
    # periodic Hann window: exact for lines on the bins of an integer number of periods
    return 0.5 - 0.5 * np.cos(2.0 * np.pi * np.arange(N) / N)


def spectrum(t: np.ndarray, signal: np.ndarray, w: float):
    """Amplitude spectrum with a Hann window, frequencies in units of ``w``.

    Parameters
    ----------
    t : ndarray, shape (N,)
        Uniform sample times.
    signal : ndarray, shape (N,), real or complex
        A real signal gives a one-sided spectrum of cosine amplitudes; a
        complex one (``x + i y``) a two-sided spectrum of whirl radii, sorted by
        signed frequency.
    w : float

    Returns
    -------
    freq : ndarray, shape (F,)
        Frequency / w.
    amp : ndarray, shape (F,)
        Amplitude of the component at that bin (exact for a line on a bin).
    """
    N = t.size
    if N < 4:
        raise ValueError("spectrum needs at least 4 samples")
    dt = float(t[1] - t[0])
    win = _hann(N)
    z = np.asarray(signal)
    Z = np.fft.fft((z - z.mean()) * win) / win.sum()
    # bins of an integer number of revolutions are exact multiples of w/R: drop the rounding noise
    f = np.round(np.fft.fftfreq(N, dt) * 2.0 * np.pi / w, 10)
    if np.iscomplexobj(z):
        order = np.argsort(f)
        return f[order], np.abs(Z[order])
    half = N // 2 + 1
    amp = np.abs(Z[:half]) * 2.0
    amp[0] /= 2.0
    return np.abs(f[:half]), amp


def dominant_lines(freq: np.ndarray, amp: np.ndarray, count: int = 6, floor: float = 1e-3, exclude_zero: bool = True):
    """Strongest local maxima of a spectrum.

    Parameters
    ----------
    freq, amp : ndarray, shape (F,)
    count : int
    floor : float
        Ignore lines below ``floor * max(amp)``.

    Returns
    -------
    list of (float, float)
        ``(frequency / w, amplitude)``, strongest first.
    """
    a = np.asarray(amp)
    if a.size < 3:
        return []
    peak = np.zeros(a.size, bool)
    peak[1:-1] = (a[1:-1] >= a[:-2]) & (a[1:-1] >= a[2:])
    peak[0] = a[0] >= a[1]
    peak[-1] = a[-1] >= a[-2]
    if exclude_zero:
        df = np.min(np.abs(np.diff(freq))) if freq.size > 1 else 0.0
        peak &= np.abs(freq) > 1.5 * df
    top = a.max() if a.size else 0.0
    idx = [i for i in np.flatnonzero(peak) if a[i] >= floor * top and a[i] > 0]
    idx.sort(key=lambda i: -a[i])
    return [(float(freq[i]), float(a[i])) for i in idx[:count]]


def whirl_components(t: np.ndarray, x: np.ndarray, y: np.ndarray, w: float) -> dict:
    """Complex amplitudes of ``z = x + i y`` at ``+-w/2`` and ``+-w`` (Hann-weighted projection).

    ``c_f = sum_j h_j z_j exp(-i f w t_j) / sum_j h_j``; exact for a periodic
    signal recorded over an even number of revolutions (at least 4).

    Returns
    -------
    dict
        ``{"+w/2": c, "-w/2": c, "+w": c, "-w": c}``; ``|c|`` is the radius of
        the forward (``+``) or backward (``-``) circular whirl.
    """
    win = _hann(t.size)
    z = (np.asarray(x) + 1j * np.asarray(y)) * win
    out = {}
    for key, f in (("+w/2", 0.5), ("-w/2", -0.5), ("+w", 1.0), ("-w", -1.0)):
        out[key] = complex(np.sum(z * np.exp(-1j * f * w * t)) / win.sum())
    return out


def _subharmonic_dominance(freq, amp, k: int, df: float) -> tuple[float, float, float]:
    """(strongest line at j w/k, j not multiple of k; strongest other non-harmonic line; their ratio)."""
    a = np.asarray(amp)
    nearest_h = np.abs(freq - np.round(freq))  # distance to a multiple of w
    nearest_k = np.abs(freq * k - np.round(freq * k)) / k  # distance to a multiple of w/k
    harmonic = nearest_h <= 2.5 * df
    on_k = (nearest_k <= 1.5 * df) & ~harmonic
    near_k = (nearest_k <= 2.5 * df) & ~harmonic  # the Hann main lobe of a w/k line
    sub = float(a[on_k].max()) if np.any(on_k) else 0.0
    rest = a[~harmonic & ~near_k]
    other = float(rest.max()) if rest.size else 0.0
    return sub, other, (sub / other if other > 0 else math.inf)


def classify(result, dofs: Sequence[int] = (0, 1), tol: float = 1e-3, max_period: int = 8,
             dominance: float = 10.0, lines: int = 6, converging_tol: float = 10.0) -> Classification:
    """Classify the recorded window of a simulation as ``period-k`` or ``not periodic``.

    Parameters
    ----------
    result : SimulationResult
        With a recorded window of several revolutions (the transient excluded
        with ``record_from``) and at least 8 samples per revolution.
    dofs : sequence of int
        One dof (real spectrum) or two (complex ``x_a + i x_b``: the disc of a
        rotor) for the spectrum, lines and whirl components.
    tol : float
        Section points repeat when they agree to ``tol`` relative to the
        amplitude scale (the largest peak-to-peak displacement, and velocity,
        of the record).
    max_period : int
        Largest ``k`` tried.
    dominance : float
        For ``k >= 2``, the strongest ``j w/k`` line must exceed every other
        non-harmonic line by this factor.
    lines : int
        Number of dominant lines returned.
    converging_tol : float
        A response whose revolution-to-revolution change shrinks (second half
        of the record below half the first) to within ``converging_tol * tol``
        is reported as ``period-1`` with ``settled = False``.

    Returns
    -------
    Classification
    """
    P = section_points(result)
    R = P.shape[0]
    n = result.x.shape[1]
    dofs = tuple(int(d) for d in dofs)
    if not 1 <= len(dofs) <= 2 or any(not 0 <= d < n for d in dofs):
        raise ValueError(f"classify: dofs must be one or two dof indices below {n}, got {dofs}")
    if R < 4 or result.t.size < 16:
        raise ValueError(f"classify: the record is too short ({R} section points, {result.t.size} samples); "
                         "record at least 4 revolutions")
    # amplitude scales of displacements and velocities (tolerances are relative to the motion)
    xs = max(float(np.ptp(result.x, axis=0).max()), 1e-12)
    vs = max(float(np.ptp(result.v, axis=0).max()), 1e-12)
    scale = np.concatenate([np.full(n, xs), np.full(n, vs)])
    Q = P / scale
    spread = float(np.abs(Q - Q.mean(axis=0)).max())
    mismatch = {}
    for k in range(1, max_period + 1):
        if R > k:
            mismatch[k] = float(np.abs(Q[k:] - Q[:-k]).max())
    # spectrum of the observed dofs
    t = result.t
    w = result.w
    if len(dofs) == 2:
        sig = result.x[:, dofs[0]] + 1j * result.x[:, dofs[1]]
        whirl = whirl_components(t, result.x[:, dofs[0]], result.x[:, dofs[1]], w)
    else:
        sig = result.x[:, dofs[0]]
        whirl = whirl_components(t, result.x[:, dofs[0]], np.zeros_like(t), w)
    freq, amp = spectrum(t, sig, w)
    df = float(np.min(np.abs(np.diff(freq)))) if freq.size > 1 else 1.0
    top = dominant_lines(freq, amp, lines)
    label, period, ratio, dom, note, settled = "not periodic", None, None, None, "", True
    reasons = []
    h = R // 2
    if mismatch.get(1, math.inf) <= tol:
        label, period, note = "period-1", 1, f"section points agree to {mismatch[1]:.1e}"
    for k in range(2, max_period + 1):
        if period is not None:
            break
        if k not in mismatch or mismatch[k] > tol:
            continue
        if R < 3 * k:
            reasons.append(f"period-{k} would need at least {3 * k} section points, got {R}")
            break
        # the k-pattern: spread of the means of the k residue classes, first half against second half
        half = (R // (2 * k)) * k
        sizes = []
        for part in (Q[:half], Q[R - half:]):
            means = np.array([part[j::k].mean(axis=0) for j in range(k)])
            sizes.append(float(np.abs(means - means.mean(axis=0)).max()))
        if sizes[1] < 10.0 * mismatch[k]:
            continue  # no k-pattern above the noise: a (converging) response of a lower period
        ratio_k = sizes[1] / sizes[0] if sizes[0] > 0 else 1.0
        sub, other, dom_k = _subharmonic_dominance(freq, amp, k, df)
        if sizes[0] - sizes[1] > 4.0 * mismatch[k] + 1e-3 * sizes[0]:
            per_rev = ratio_k ** (1.0 / max(R - half, 1)) if ratio_k > 0 else 0.0
            reasons.append(f"period-{k} pattern decays (second half / first half = {ratio_k:.4f}, about "
                           f"{per_rev:.5f} per revolution: a transient with a multiplier near "
                           f"{'-1' if k == 2 else 'a k-th root of 1'}); run a longer transient")
            ratio = ratio_k
            continue
        if dom_k < dominance:
            reasons.append(f"period-{k} on the section but the w/{k} lines ({sub:.3g}) do not dominate the other "
                           f"non-harmonic lines ({other:.3g})")
            continue
        label, period, ratio, dom = f"period-{k}", k, ratio_k, dom_k
        note = (f"section points repeat every {k} revolutions to {mismatch[k]:.1e}; pattern ratio {ratio:.4f}; "
                f"w/{k} lines dominate the other non-harmonic lines by {dom:.3g}")
    if period is None and R >= 8 and 1 in mismatch:
        # a period-1 response still converging: the step-to-step change shrinks and is already small
        m_a = float(np.abs(Q[1:h] - Q[: h - 1]).max())
        m_b = float(np.abs(Q[h + 1:] - Q[h:-1]).max())
        if m_b <= converging_tol * tol and m_b < 0.5 * m_a:
            label, period, settled = "period-1", 1, False
            note = (f"converging to period-1: section mismatch {m_a:.2g} -> {m_b:.2g} between the halves of the "
                    f"record (tolerance {tol:g}); run a longer transient to settle it")
            if reasons:
                note += "; " + "; ".join(reasons)
    if period is None:
        best = min(mismatch.items(), key=lambda kv: kv[1]) if mismatch else (None, math.nan)
        note = "; ".join(reasons) if reasons else (
            f"no k <= {max_period} with repeating section points (best k = {best[0]}: mismatch {best[1]:.2g} > "
            f"tol {tol:g})")
        if top:
            f0 = next((f for f, _ in top if abs(f - round(f)) > 2.5 * df), None)
            if f0 is not None:
                note += f"; strongest non-harmonic line at {f0:+.4f} w"
    cls = Classification(label, period, P, spread, mismatch, ratio if period != 1 else None, top, whirl,
                         dom if period is not None and period >= 2 else None, note, settled,
                         unsettled="" if settled else note)
    cls.growth, rising = amplitude_growth(result)
    if rising and not cls.growth <= 1.0 + 10.0 * tol:
        cls.not_settled(f"its amplitude grows over the record (x{cls.growth:.4g} from the first quarter to the last, "
                        "rising in every quarter): growing without bound, or still building up; run a longer "
                        "transient to tell")
    return cls


def amplitude_growth(result, parts: int = 4) -> tuple[float, bool]:
    """How the amplitude of a record changes over it.

    The record is cut into ``parts`` equal parts; in each, the peak
    deviation of every state component from its mean over the record,
    relative to the component's range over the record, the largest over the
    components (components that do not move are left out).

    Parameters
    ----------
    result : SimulationResult
    parts : int

    Returns
    -------
    ratio : float
        That peak in the last part over that in the first (inf if the first
        is zero or the values overflow).
    rising : bool
        True if the peak rose from each part to the next.
    """
    y = np.concatenate([result.x, result.v], axis=1)
    K = y.shape[0] // parts
    if K < 1:
        return 1.0, False
    with np.errstate(over="ignore", invalid="ignore"):
        span = np.ptp(y, axis=0)
        if not np.all(np.isfinite(span)) or not np.all(np.isfinite(y)):
            return math.inf, True  # too large to measure: nothing bounded is
        moving = span > 1e-12 * max(float(span.max()), 1e-300)
        if not np.any(moving):
            return 1.0, False
        dev = np.abs(y[:, moving] - y[:, moving].mean(axis=0)) / span[moving]
        peaks = np.array([dev[i * K:(i + 1) * K].max() for i in range(parts)])
    ratio = float(peaks[-1] / peaks[0]) if peaks[0] > 0 else math.inf
    return ratio, bool(np.all(np.diff(peaks) > 0))


#: revolutions at the end of a run that :func:`steady_state` integrates again with half the step
REFINE_PERIODS = 8


def step_refinement(model: Model, params, result, periods: int = REFINE_PERIODS, scale=None) -> float:
    """How much the end of a run moves when its last revolutions are integrated with half the step.

    From the section point ``periods`` revolutions before the last one, the
    model is integrated again over those revolutions with
    ``2 * steps_per_period`` steps per period (the same event location) and
    its state compared with the run's last section point.

    Parameters
    ----------
    model : Model
    params : dict or None
        The run's parameter overrides.
    result : SimulationResult
    periods : int
        Revolutions integrated again (at most those of the run).
    scale : ndarray, shape (2n,), optional
        What the change is measured against, per state component (default:
        the range of each over the recorded window, as :func:`classify` does).

    Returns
    -------
    float
        ``max |y_fine - y_run| / scale`` (inf if the finer run blew up).
    """
    n = result.x.shape[1]
    last = result.section.shape[0] - 1
    periods = int(min(periods, last))
    if periods < 1:
        return math.nan
    if scale is None:
        scale = np.concatenate([np.full(n, max(float(np.ptp(result.x, axis=0).max()), 1e-12)),
                                np.full(n, max(float(np.ptp(result.v, axis=0).max()), 1e-12))])
    y0, y1 = result.section[last - periods], result.section[last]
    S = 2 * int(result.steps_per_period)
    try:
        fine = simulate(model, params, y0[:n], y0[n:], periods=periods, steps_per_period=S, record_every=S,
                        locate_events=result.locate_events)
    except SimulationError:
        return math.inf  # blew up with the finer step: the coarse run's answer is the integrator's
    with np.errstate(over="ignore", invalid="ignore"):
        change = float(np.max(np.abs(fine.section[periods] - y1) / scale))
    return change if math.isfinite(change) else math.inf


def steady_state(model: Model, params=None, x0=None, v0=None, *, transient: float = 200, record: int = 64,
                 steps_per_period: int = 4096, samples_per_period: int = 64, locate_events: bool = True,
                 dofs: Sequence[int] = (0, 1), tol: float = 1e-3, max_period: int = 8,
                 refine_periods: int = REFINE_PERIODS, **kwargs):
    """Simulate to steady state, classify, and check that the answer does not depend on the step.

    Parameters
    ----------
    model : Model
    params : dict, optional
    x0, v0 : array_like, shape (n,), optional
    transient : float
        Revolutions discarded before recording.
    record : int
        Revolutions recorded (rounded up to an even number, so that the
        ``w/2`` lines fall on spectral bins).
    steps_per_period : int
    samples_per_period : int
        Recorded samples per revolution (a divisor of ``steps_per_period``).
    locate_events, dofs, tol, max_period
        See :func:`contin.timedomain.simulation.simulate` and :func:`classify`.
    refine_periods : int
        The last ``min(refine_periods, record)`` revolutions are integrated
        again with half the step (:func:`step_refinement`); where the state
        they end at moves by more than ``tol`` of the motion's range the
        response is not settled (numerical instability). 0 skips the check.
    **kwargs
        Passed to :func:`contin.timedomain.simulation.simulate` (``progress``, ``should_stop``, ...).

    Returns
    -------
    result : SimulationResult
    classification : Classification or None
        None when the run was stopped early by ``should_stop``.
    """
    record = int(math.ceil(record / 2.0)) * 2
    S = int(steps_per_period)
    if samples_per_period < 8 or S % samples_per_period:
        raise ValueError(f"samples_per_period must be >= 8 and divide steps_per_period={S}, got {samples_per_period}")
    res = simulate(model, params, x0, v0, periods=transient + record, steps_per_period=S,
                   record_every=S // samples_per_period, record_from=transient, locate_events=locate_events, **kwargs)
    if res.steps < int(math.ceil((transient + record) * S - 1e-9)):
        return res, None  # stopped early (``should_stop``): nothing to classify
    # the last sample (t = end) repeats the phase of the first: drop it so the window spans whole revolutions
    res.t, res.x, res.v = res.t[:-1], res.x[:-1], res.v[:-1]
    cls = classify(res, dofs, tol, max_period)
    if refine_periods > 0:
        periods = min(int(refine_periods), record)
        change = step_refinement(model, params, res, periods)
        cls.step_change = None if math.isnan(change) else change
        if cls.step_change is not None and not change <= tol:
            cls.not_settled(f"the result depends on the step (numerical instability, or a step too coarse for "
                            f"the tolerance): the last {periods} revolutions integrated again with half the step "
                            f"end {change:.3g} of the motion's range away, more than the tolerance {tol:g}; raise "
                            "steps_per_period")
    return res, cls
