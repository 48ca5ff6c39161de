"""Spectral lines of a sampled signal: frequency, amplitude and phase, refined far below a bin.

A quasi-periodic response (a harmonic-balance torus, or the rotor of Inagaki,
Ishida & Hayashi with its forced whirl at ``w``, self-excited forward whirl at
``p_f``, combination tone ``w - p_f`` and subharmonic ``w / 2``) is a sum of
lines at frequencies that are not multiples of ``2 pi / T`` for any record
length ``T``. A plain FFT puts each line between bins and reads its amplitude
with a scalloping loss and its frequency to half a bin. This module instead
follows the numerical analysis of fundamental frequencies (NAFF) of Laskar,

    J. Laskar, "Frequency analysis for multi-dimensional systems. Global
    dynamics and diffusion", Physica D 67 (1993) 257-276;
    J. Laskar, C. Froeschle, A. Celletti, Physica D 56 (1992) 253-269,

with a windowed least-squares fit of all lines at the end:

1. The record ``x_n`` at ``t_n = t_0 + n dt`` is weighted by a window ``h_n``
   and its discrete-time Fourier transform
   ``D(f) = sum_n h_n x_n exp(-i f t_n)`` is evaluated at *any* frequency ``f``.
   For a single line ``c exp(i f_0 t)`` ``|D(f)|`` is largest exactly at
   ``f = f_0`` (the window is positive and symmetric about the middle of the
   record), whatever the record length.
2. The strongest peak of the FFT of the residual (the signal minus the lines
   found so far) is located on the bins, then ``|D|`` of the residual is
   maximised by a bounded scalar minimiser (:func:`scipy.optimize.minimize_scalar`)
   in a bin-scaled variable, and a Newton step on ``d|D|^2/df = 0`` (with the
   derivatives of ``D`` in closed form) takes the maximiser to rounding
   precision.
3. The complex amplitudes of all lines found so far, with the mean and, for a
   real signal, the mirror lines at ``-f``, are the window-weighted least-squares
   fit to the record; its Gram matrix ``sum_n h_n exp(i (f_k - f_j) t_n)`` is
   evaluated in closed form (sums of Dirichlet kernels). This is the
   Gram-Schmidt step of NAFF: the leakage of each line into the others is
   accounted for, not ignored.
4. Each frequency is refined again on the record minus all *other* lines and
   the fit repeated, until the frequencies stop moving. For a signal that is
   exactly a sum of the lines found this converges to the exact lines, however
   close they are (a few bins apart); otherwise each line is biased only by
   the leakage of what was not fitted (noise, lines below ``floor``).

Successive subtraction (step 2 on the residual) is what lets a line a thousand
times weaker than its neighbour be found at all: the sidelobes of a strong
line, not its weaker neighbours, would otherwise be the next peaks.

The window is the squared Hann window ``h = sin^4(pi n / (N - 1))``: its
sidelobes fall as the fifth power of the distance (the Hann window's as the
third), so the lines not fitted (the many weak combination tones of a
nonlinear response) disturb the fitted ones much less; the price is a main
lobe of three bins half-width instead of two, which sets the default
closest separation of two lines that are searched for.

Conventions
-----------
A real signal gives lines ``A cos(f t + phase)`` with ``f >= 0``; a complex
signal ``z = x + i y`` (a whirling disc) gives lines ``c exp(i f t)`` with a
signed ``f`` (forward whirl ``f > 0``, backward ``f < 0``), amplitude ``|c|``
(the whirl radius) and ``phase = arg c``. Phases are at ``t = 0``. Frequencies
are in radians per unit time.
"""

from __future__ import annotations

import dataclasses
import functools
import math

import numpy as np
from scipy.optimize import minimize_scalar

__all__ = ["Line", "spectral_lines", "refine_line", "line_amplitude"]

#: the window as a cosine sum about the middle of the record, ``h = sum_m b_m cos(2 pi m s / (N - 1))``,
#: ``s = n - (N - 1) / 2``: the squared Hann window ``(1/2 + 1/2 cos)^2``
_WINDOW = (3.0 / 8.0, 1.0 / 2.0, 1.0 / 8.0)
#: half-width of the window's main lobe, in bins (first zero of its transform)
_MAIN_LOBE = 3.0
#: local maxima of the spectrum weaker than this fraction of the strongest one in the searched interval
#: are taken for sidelobes (twice the window's highest sidelobe, -47 dB, rounded up)
_SIDELOBE = 1e-2
#: fewest samples accepted
MIN_SAMPLES = 16
#: largest departure of the sample times from a uniform grid, relative to the step
_UNIFORM_TOL = 1e-6
#: the refinement stops when no frequency moves by more than this many bins
_FREQ_TOL = 1e-11
#: most refinement sweeps over all lines after each new line
_MAX_SWEEPS = 40


@dataclasses.dataclass(frozen=True)
class Line:
    """One spectral line.

    Attributes
    ----------
    frequency : float
        Radians per unit time. Signed for a complex signal (forward whirl
        ``> 0``, backward ``< 0``), ``>= 0`` for a real one.
    amplitude : float
        Real signal: ``A`` in ``A cos(f t + phase)``. Complex signal
        ``z = x + i y``: ``|c|`` in ``c exp(i f t)`` (the whirl radius).
    phase : float
        Radians, at ``t = 0``, in ``(-pi, pi]``; for a complex signal
        ``c = amplitude * exp(i phase)``.
    """

    frequency: float
    amplitude: float
    phase: float


@dataclasses.dataclass(frozen=True, eq=False)
class _Record:
    """A validated, uniformly sampled record and its window."""

    x: np.ndarray  # (N,) float or complex
    t0: float
    dt: float
    h: np.ndarray  # (N,) window
    complex_signal: bool

    @property
    def n(self) -> int:
        return self.x.size

    @property
    def tc(self) -> float:
        """Time of the middle of the record."""
        return self.t0 + 0.5 * (self.n - 1) * self.dt

    @property
    def bin(self) -> float:
        """Frequency resolution ``2 pi / (N dt)``."""
        return 2.0 * math.pi / (self.n * self.dt)

    @property
    def nyquist(self) -> float:
        return math.pi / self.dt

    @property
    def weight(self) -> float:
        """``sum_n h_n``: the transform of the window at zero frequency."""
        return float(self.h.sum())

    @functools.cached_property
    def windowed(self) -> np.ndarray:
        """``h x`` in the blocked form of :func:`_blocked`, shape (A, B)."""
        return _blocked(self, self.h * self.x)


def _record(t, signal) -> _Record:
    """Check ``t`` and ``signal`` and build the record (see the module docstring)."""
    t = np.asarray(t, dtype=float)
    x = np.asarray(signal)
    if t.ndim != 1 or x.ndim != 1:
        raise ValueError(f"t and signal must be 1-D arrays, got shapes {t.shape} and {x.shape}")
    if t.size != x.size:
        raise ValueError(f"t and signal must have the same length, got {t.size} and {x.size}")
    if t.size < MIN_SAMPLES:
        raise ValueError(f"a spectral line needs at least {MIN_SAMPLES} samples, got {t.size}")
    if not np.issubdtype(x.dtype, np.number) or np.issubdtype(x.dtype, np.bool_):
        raise ValueError(f"signal must be numeric, got dtype {x.dtype}")
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(x))):
        raise ValueError("t and signal must be finite (no nan or inf)")
    n = t.size
    dt = (t[-1] - t[0]) / (n - 1)
    if not dt > 0.0:
        raise ValueError("t must increase")
    idx = np.arange(n, dtype=float)
    dev = float(np.max(np.abs(t - (t[0] + idx * dt))))
    if dev > _UNIFORM_TOL * dt:
        raise ValueError(f"t must be uniformly sampled: it departs from a uniform grid by {dev / dt:.3g} steps")
    complex_signal = bool(np.iscomplexobj(x))
    x = x.astype(complex if complex_signal else float)
    s = idx - 0.5 * (n - 1)
    arg = 2.0 * math.pi * s / (n - 1)
    h = sum(b * np.cos(m * arg) for m, b in enumerate(_WINDOW))
    return _Record(x=x, t0=float(t[0]), dt=float(dt), h=h, complex_signal=complex_signal)


# ---------------------------------------------------------------- transforms in closed form
def _dirichlet(theta: np.ndarray, n: int) -> np.ndarray:
    """``sum_s exp(-i theta s)`` over ``s = k - (n - 1) / 2``, ``k = 0..n-1``: ``sin(n theta / 2) / sin(theta / 2)``.

    Parameters
    ----------
    theta : ndarray, any shape
    n : int

    Returns
    -------
    ndarray, shape of theta, real
    """
    k = np.round(theta / (2.0 * math.pi))
    r = theta - 2.0 * math.pi * k  # the kernel has period 2 pi up to the sign (-1)^(k (n - 1))
    sign = np.where((k.astype(np.int64) * (n - 1)) % 2 == 0, 1.0, -1.0)
    den = np.sin(0.5 * r)
    small = np.abs(r) < 1e-300
    val = np.sin(0.5 * n * r) / np.where(small, 1.0, den)
    return sign * np.where(small, float(n), val)


def _kernel(rec: _Record, nu) -> np.ndarray:
    """Transform of the window, ``K(nu) = sum_n h_n exp(-i nu t_n)``, in closed form.

    Parameters
    ----------
    nu : array_like, any shape
        Frequencies, rad per unit time.

    Returns
    -------
    ndarray, shape of nu, complex
    """
    nu = np.asarray(nu, dtype=float)
    theta = nu * rec.dt
    step = 2.0 * math.pi / (rec.n - 1)
    total = _WINDOW[0] * _dirichlet(theta, rec.n)
    for m, b in enumerate(_WINDOW[1:], start=1):
        total = total + 0.5 * b * (_dirichlet(theta - m * step, rec.n) + _dirichlet(theta + m * step, rec.n))
    return np.exp(-1j * nu * rec.tc) * total


def _blocks(rec: _Record) -> tuple[int, int]:
    """``(A, B)``, ``A B >= N``: sample ``n = a B + b`` is entry ``(a, b)`` of an ``A x B`` array."""
    b = max(1, math.isqrt(rec.n - 1) + 1)
    return -(-rec.n // b), b


def _blocked(rec: _Record, y: np.ndarray) -> np.ndarray:
    """``y``, shape (N,), zero-padded and reshaped to ``(A, B)``."""
    a, b = _blocks(rec)
    out = np.zeros(a * b, complex)
    out[:rec.n] = y
    return out.reshape(a, b)


def _transform(rec: _Record, y: np.ndarray, f: float, derivatives: bool = False):
    """``P(f) = sum_n y_n exp(-i f dt s_n)`` of a windowed record ``y`` (``|P| = |D|``).

    ``exp(-i theta n) = exp(-i theta B a) exp(-i theta b)`` turns the sum into
    a matrix-vector product of the ``(A, B)`` blocked record with two short
    phasor vectors: ``O(N)`` multiply-adds and ``O(sqrt N)`` exponentials.

    Parameters
    ----------
    y : ndarray, shape (N,) or (A, B)
        The windowed record, or its :func:`_blocked` form.
    f : float

    Returns
    -------
    complex, or (complex, complex, complex)
        ``P``, or ``P`` and its first two derivatives with respect to ``f``.
    """
    yb = y if y.ndim == 2 else _blocked(rec, y)
    na, nb = yb.shape
    theta = f * rec.dt
    a = np.arange(na, dtype=float)
    b = np.arange(nb, dtype=float)
    u = np.exp(-1j * theta * nb * a)
    v = np.exp(-1j * theta * b)
    centre = 0.5 * (rec.n - 1)
    shift = complex(np.exp(1j * theta * centre))
    if not derivatives:
        return shift * complex(u @ (yb @ v))
    # s = n - centre = q + b with q = a B - centre: the moments sum y s^k e over (a, b)
    z = yb @ np.stack([v, v * b, v * b * b], axis=1)  # (A, 3)
    q = nb * a - centre
    m0 = u @ z[:, 0]
    m1 = (u * q) @ z[:, 0] + u @ z[:, 1]
    m2 = (u * q * q) @ z[:, 0] + 2.0 * ((u * q) @ z[:, 1]) + u @ z[:, 2]
    return shift * complex(m0), -1j * rec.dt * shift * complex(m1), -rec.dt ** 2 * shift * complex(m2)


def _fit(rec: _Record, freqs: np.ndarray) -> np.ndarray:
    """Window-weighted least-squares amplitudes ``c_k`` of ``x ~ sum_k c_k exp(i f_k t)``.

    Parameters
    ----------
    freqs : ndarray, shape (K,)
        Distinct frequencies; for a real signal they must come with their
        mirrors ``-f`` (the fit is then conjugate-symmetric).

    Returns
    -------
    ndarray, shape (K,), complex
    """
    gram = _kernel(rec, freqs[:, None] - freqs[None, :])  # sum h exp(-i f_j t) exp(i f_k t)
    rhs = np.array([np.exp(-1j * f * rec.tc) * _transform(rec, rec.windowed, f) for f in freqs])
    return np.linalg.solve(gram, rhs)


def _phasor(rec: _Record, f: float) -> np.ndarray:
    """``exp(i f t_n)``, shape (N,), from the blocked factorisation (see :func:`_transform`)."""
    return _model(rec, np.array([f]), np.ones(1))


def _model(rec: _Record, freqs: np.ndarray, coefs: np.ndarray) -> np.ndarray:
    """``sum_k c_k exp(i f_k t_n)``, shape (N,), complex: an ``(A, K) x (K, B)`` product."""
    na, nb = _blocks(rec)
    theta = np.asarray(freqs, dtype=float) * rec.dt
    u = np.exp(1j * np.outer(nb * np.arange(na), theta)) * (np.asarray(coefs) * np.exp(1j * freqs * rec.t0))
    v = np.exp(1j * np.outer(theta, np.arange(nb)))
    return (u @ v).reshape(-1)[:rec.n]


# ---------------------------------------------------------------- one peak
def _newton(rec: _Record, y: np.ndarray, f: float, lo: float, hi: float) -> float:
    """Newton steps on ``d|P|^2/df = 0`` from ``f``, kept in ``[lo, hi]``, each one raising ``|P|``."""
    y = y if y.ndim == 2 else _blocked(rec, y)
    p, p1, p2 = _transform(rec, y, f, derivatives=True)
    for _ in range(6):
        slope = (p.conjugate() * p1).real
        curvature = abs(p1) ** 2 + (p.conjugate() * p2).real
        if not curvature < 0.0:  # not near a maximum of |P|: a Newton step would not go up
            break
        step = -slope / curvature
        g = f + step
        if not (lo <= g <= hi) or abs(step) > 0.25 * rec.bin:
            break
        q, q1, q2 = _transform(rec, y, g, derivatives=True)
        if abs(q) < abs(p) * (1.0 - 4.0 * np.finfo(float).eps):
            break
        f, p, p1, p2 = g, q, q1, q2
        if abs(step) <= _FREQ_TOL * 1e-2 * rec.bin:
            break
    return f


def _peak(rec: _Record, y: np.ndarray, lo: float, hi: float, guess: float) -> float:
    """Frequency of the largest ``|P|`` of the windowed record ``y`` in ``[lo, hi]``, near ``guess``."""
    y = y if y.ndim == 2 else _blocked(rec, y)
    scale = rec.bin
    # the bin-scaled variable keeps the minimiser's relative tolerance (sqrt(eps) |u|) far below a bin
    res = minimize_scalar(lambda u: -abs(_transform(rec, y, guess + u * scale)), method="bounded",
                          bounds=((lo - guess) / scale, (hi - guess) / scale), options={"xatol": 1e-12})
    return _newton(rec, y, guess + float(res.x) * scale, lo, hi)


# ---------------------------------------------------------------- sets of lines
def _basis(rec: _Record, lines: np.ndarray) -> np.ndarray:
    """The fitted frequencies: the mean, the lines and, for a real signal, their mirrors; shape (1 + K or 1 + 2K,)."""
    parts = [np.zeros(1), lines] if rec.complex_signal else [np.zeros(1), lines, -lines]
    return np.concatenate(parts)


def _polish(rec: _Record, lines: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Refine every line on the record minus all the other fitted lines, refit, until no frequency moves.

    Returns
    -------
    lines : ndarray, shape (K,)
    coefs : ndarray, shape of :func:`_basis`, complex
    """
    lines = np.array(lines, dtype=float)
    coefs = _fit(rec, _basis(rec, lines))
    for _ in range(_MAX_SWEEPS):
        if lines.size == 0:
            break
        residual = rec.x - _model(rec, _basis(rec, lines), coefs)
        new = lines.copy()
        for j, f in enumerate(lines):
            # the record minus the other lines, the mean and (real signal) its own mirror
            y = _blocked(rec, rec.h * (residual + coefs[1 + j] * _phasor(rec, f)))
            new[j] = _newton(rec, y, f, f - rec.bin, f + rec.bin)
        moved = float(np.max(np.abs(new - lines))) / rec.bin
        lines = new
        coefs = _fit(rec, _basis(rec, lines))
        if moved <= _FREQ_TOL:
            break
    return lines, coefs


def _line(rec: _Record, frequency: float, coef: complex, mean: bool = False) -> Line:
    if mean and not rec.complex_signal:  # a real mean d = |d| cos(0 t + phase)
        d = coef.real
        return Line(0.0, abs(d), 0.0 if d >= 0 else math.pi)
    amplitude = abs(coef) if (rec.complex_signal or mean) else 2.0 * abs(coef)
    return Line(float(frequency), float(amplitude), float(np.angle(coef)))


def _check_frequency(rec: _Record, frequency) -> float:
    f = float(frequency)
    if not math.isfinite(f):
        raise ValueError(f"frequency must be finite, got {frequency}")
    if not rec.complex_signal:
        f = abs(f)  # cos is even: a real signal has its lines at f >= 0
    if abs(f) >= rec.nyquist:
        raise ValueError(f"frequency {f:.6g} is at or above the Nyquist frequency pi / dt = {rec.nyquist:.6g}")
    return f


# ---------------------------------------------------------------- public API
def spectral_lines(t, signal, count=8, floor=1e-4, exclude_zero=True, min_separation=None) -> list[Line]:
    """Strongest lines of a uniformly sampled signal, strongest first, each refined.

    Lines are found one at a time on the residual (the record minus the lines
    found so far), each maximising the windowed transform of the residual,
    and all of them are refined together (module docstring).

    Parameters
    ----------
    t : array_like, shape (N,)
        Uniform sample times, ``N >= 16``.
    signal : array_like, shape (N,), real or complex
        A complex signal ``x + i y`` gives signed frequencies (whirl).
    count : int
        Most lines returned.
    floor : float
        Lines weaker than ``floor`` times the strongest are not returned (nor
        searched for beyond the first one found below it).
    exclude_zero : bool
        Fit the mean but do not return it. With False, the mean is the line
        at zero frequency (real: ``phase`` 0 or pi) and counts among ``count``.
    min_separation : float, optional
        Closest distance of a new line to a line already found (and to zero
        frequency), rad per unit time. Default: the half-width of the window's
        main lobe, three bins ``3 * 2 pi / (N dt)``.

    Returns
    -------
    list of Line
        At most ``count``, by decreasing amplitude.

    Raises
    ------
    ValueError
        Bad samples (see :func:`line_amplitude`), ``count < 1``, a negative or
        non-finite ``floor`` or a non-positive ``min_separation``.
    """
    rec = _record(t, signal)
    if int(count) != count or count < 1:
        raise ValueError(f"count must be a positive integer, got {count}")
    if not (math.isfinite(floor) and floor >= 0.0):
        raise ValueError(f"floor must be finite and >= 0, got {floor}")
    if min_separation is None:
        sep = _MAIN_LOBE * rec.bin
    elif not (math.isfinite(min_separation) and min_separation > 0.0):
        raise ValueError(f"min_separation must be > 0, got {min_separation}")
    else:
        sep = float(min_separation)

    grid = np.fft.fftfreq(rec.n, rec.dt) * 2.0 * math.pi  # bin frequencies, signed
    usable = np.abs(grid) >= sep  # the mean is always fitted: no line next to it
    if not rec.complex_signal:
        usable &= grid > 0.0
    lines = np.zeros(0)
    lines, coefs = _polish(rec, lines)
    strongest = abs(coefs[0].real if not rec.complex_signal else coefs[0]) if not exclude_zero else 0.0
    while lines.size < count:
        residual = rec.x - _model(rec, _basis(rec, lines), coefs)
        if not rec.complex_signal:
            residual = residual.real
        y = rec.h * residual
        spec = np.abs(np.fft.fft(y))
        free = usable.copy()
        for f in lines:
            free &= np.abs(grid - f) >= sep
        peak = free & (spec >= np.roll(spec, 1)) & (spec >= np.roll(spec, -1)) & (spec > 0.0)
        if not np.any(peak):
            break
        i = int(np.flatnonzero(peak)[np.argmax(spec[peak])])
        guess = float(grid[i])
        lo, hi = guess - rec.bin, guess + rec.bin
        if not rec.complex_signal:
            lo, hi = max(lo, 0.5 * sep), min(hi, rec.nyquist)
        f = _peak(rec, y, lo, hi, guess)
        amplitude = abs(_transform(rec, y, f)) / rec.weight * (1.0 if rec.complex_signal else 2.0)
        if amplitude <= 0.0 or amplitude < floor * strongest:
            break
        strongest = max(strongest, amplitude)
        lines, coefs = _polish(rec, np.append(lines, f))

    found = [_line(rec, f, c) for f, c in zip(lines, coefs[1:1 + lines.size])]
    if not exclude_zero:
        found.append(_line(rec, 0.0, complex(coefs[0]), mean=True))
    found.sort(key=lambda line: -line.amplitude)
    top = found[0].amplitude if found else 0.0
    return [line for line in found if line.amplitude >= floor * top and line.amplitude > 0.0][:int(count)]


def refine_line(t, signal, frequency, width=None) -> Line:
    """The line nearest ``frequency`` (within ``+- width``, default 2 bin widths), refined.

    Local maxima of the spectrum weaker than a hundredth of the strongest
    one within ``+- width`` are taken for sidelobes and passed over. The mean
    and, for a real signal, the line's mirror at ``-f`` are fitted with the
    line; other lines are not (their leakage biases the result; use
    :func:`spectral_lines` when they are close or strong).

    Parameters
    ----------
    t : array_like, shape (N,)
        Uniform sample times, ``N >= 16``.
    signal : array_like, shape (N,), real or complex
    frequency : float
        Where to look, rad per unit time (its absolute value for a real signal).
    width : float, optional
        Half-width of the search interval; default ``2 * 2 pi / (N dt)``.

    Returns
    -------
    Line

    Raises
    ------
    ValueError
        Bad samples, a bad ``frequency`` or ``width``, or no local maximum
        of the spectrum within ``+- width``.
    """
    rec = _record(t, signal)
    f0 = _check_frequency(rec, frequency)
    w = 2.0 * rec.bin if width is None else float(width)
    if not (math.isfinite(w) and w > 0.0):
        raise ValueError(f"width must be > 0, got {width}")
    lo, hi = f0 - w, f0 + w
    lo, hi = max(lo, -rec.nyquist), min(hi, rec.nyquist)
    if not rec.complex_signal:
        lo = max(lo, 0.0)
    mean = _fit(rec, np.zeros(1))[0]
    y = rec.h * (rec.x - mean)
    # |P| on a grid of quarter bins (zero-padded FFT), its local maxima, the nearest one
    pad = 4
    spec = np.abs(np.fft.fft(y, pad * rec.n))
    grid = np.fft.fftfreq(pad * rec.n, rec.dt) * 2.0 * math.pi
    inside = (grid > lo) & (grid < hi)
    peak = (spec >= np.roll(spec, 1)) & (spec >= np.roll(spec, -1)) & inside & (spec > 0.0)
    if np.any(peak):  # sidelobes of the lines in the interval are not lines
        peak &= spec >= _SIDELOBE * spec[peak].max()
    if not np.any(peak):
        raise ValueError(f"no spectral line within {f0:.6g} +- {w:.6g} (the spectrum has no peak there)")
    cand = np.flatnonzero(peak)
    guess = float(grid[cand[np.argmin(np.abs(grid[cand] - f0))]])
    step = rec.bin / pad
    f = _peak(rec, y, max(lo, guess - step), min(hi, guess + step), guess)
    lines, coefs = _polish(rec, np.array([f]))
    return _line(rec, lines[0], complex(coefs[1]))


def line_amplitude(t, signal, frequency) -> Line:
    """Amplitude and phase at a known frequency (no search).

    The window-weighted least-squares fit of the line, the mean and (real
    signal) the mirror line at ``-frequency``.

    Parameters
    ----------
    t : array_like, shape (N,)
        Uniform sample times (``max |t_n - t_0 - n dt|`` at most ``1e-6 dt``), ``N >= 16``.
    signal : array_like, shape (N,), real or complex
        Finite values.
    frequency : float
        Rad per unit time, below the Nyquist frequency ``pi / dt``; zero gives the mean.

    Returns
    -------
    Line
        At ``frequency`` (its absolute value for a real signal).

    Raises
    ------
    ValueError
        Mismatched or non-1-D shapes, fewer than 16 samples, non-finite
        values, non-uniform or decreasing ``t``, ``frequency`` at or above
        the Nyquist frequency.
    """
    rec = _record(t, signal)
    f = _check_frequency(rec, frequency)
    if f == 0.0:
        return _line(rec, 0.0, complex(_fit(rec, np.zeros(1))[0]), mean=True)
    coefs = _fit(rec, _basis(rec, np.array([f])))
    return _line(rec, f, complex(coefs[1]))
