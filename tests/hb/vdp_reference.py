"""Independent references for the forced van der Pol oscillator.

The model::

    x'' - mu (1 - x^2) x' + x = F cos(w t)

with ``mu`` small. Its 1:1 entrained (periodic) response, the boundaries of the
entrainment region and the quasi-periodic response outside it follow from the
first-order averaged (slow-flow) equations, written here in closed form:

- A. H. Nayfeh, D. T. Mook, *Nonlinear Oscillations*, Wiley 1979, the forced
  self-sustaining oscillator (primary resonance, soft excitation; non-resonant
  hard excitation and quenching);
- J. Guckenheimer, P. Holmes, *Nonlinear Oscillations, Dynamical Systems, and
  Bifurcations of Vector Fields*, Springer 1983, sec. 2.1 (the averaged forced
  van der Pol equation, its saddle-node and Hopf curves, the Bogdanov-Takens
  and cusp points);
- R. H. Rand, *Lecture Notes on Nonlinear Vibrations*, Cornell, chapter
  "Forced van der Pol" (slow flow, entrainment, quasi-periodic motion).

Variation of parameters
-----------------------
The detuning is kept exact: the equation is written

    x'' + w^2 x = g(x, x', t),   g = (w^2 - 1) x + mu (1 - x^2) x' + F cos(w t),

and ``x = a cos(w t) + b sin(w t)``, ``x' = w (-a sin(w t) + b cos(w t))`` (the
constraint ``a' cos + b' sin = 0``) turn it, exactly, into

    a' = -(g / w) sin(w t),   b' = (g / w) cos(w t)          (*)

(:func:`variation_of_parameters_rhs`). Averaging (*) over one forcing period
with ``a``, ``b`` frozen is exact here (``g`` is a polynomial in ``cos``,
``sin``) and gives :func:`averaged_field`. The averaged equations approximate
(*) to first order in the small quantities ``mu``, ``w^2 - 1`` and ``F``
(soft excitation near primary resonance).

Scaled variables
----------------
With ``alpha = mu / 2``, ``sigma = (w^2 - 1) / (2 w)``, ``f = F / (2 w)`` and
``R = (a^2 + b^2) / 4``, the closed forms use (Guckenheimer & Holmes' scaling)

    Omega = sigma / alpha = (w^2 - 1) / (mu w),   Gamma = f / (2 alpha) = F / (2 mu w).

The entrained amplitudes solve ``R ((1 - R)^2 + Omega^2) = Gamma^2``; a
saddle-node (fold) has ``(1 - R)(1 - 3 R) + Omega^2 = 0``; a Hopf point of the
slow flow (a Neimark-Sacker point of the full system) has ``R = 1/2`` and
``Omega^2 > 1/4``, i.e. ``Gamma^2 = (1/4 + Omega^2) / 2``.
"""

from __future__ import annotations

import dataclasses
import enum
import math

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

__all__ = ["averaged_field", "variation_of_parameters_rhs", "slow_jacobian", "Equilibrium", "locked_amplitudes",
           "BoundaryKind", "LockingBoundaries", "locking_boundaries", "SlowLine", "SlowCycle", "slow_limit_cycle",
           "HardExcitation", "hard_excitation", "simulated_lines", "scaled", "saddle_node_condition"]

#: a root of the amplitude cubic is real when its imaginary part is below this (relative to its modulus)
_REAL_TOL = 1e-9
#: the entrained branch is followed outwards from w = 1 in steps of |Omega| growing by this ratio
_SCAN_RATIO = 1.01
#: first step of that scan in Omega
_SCAN_FIRST = 1e-4


# ---------------------------------------------------------------- the slow flow
def scaled(mu: float, F: float, w: float) -> tuple[float, float]:
    """``(Omega, Gamma) = ((w^2 - 1) / (mu w), F / (2 mu w))``: detuning and forcing of the scaled slow flow."""
    return (w * w - 1.0) / (mu * w), F / (2.0 * mu * w)


def variation_of_parameters_rhs(a, b, t, mu: float, F: float, w: float):
    """Exact right-hand side (*) of the module docstring, ``(a', b')`` at time ``t``.

    ``a' = -(g / w) sin(w t)``, ``b' = (g / w) cos(w t)`` with
    ``g = (w^2 - 1) x + mu (1 - x^2) x' + F cos(w t)``,
    ``x = a cos(w t) + b sin(w t)``, ``x' = w (-a sin(w t) + b cos(w t))``.

    Parameters
    ----------
    a, b : float or ndarray, broadcastable with t
    t : float or ndarray

    Returns
    -------
    (da, db) : ndarrays of the broadcast shape
    """
    c, s = np.cos(w * t), np.sin(w * t)
    x = a * c + b * s
    v = w * (-a * s + b * c)
    g = (w * w - 1.0) * x + mu * (1.0 - x * x) * v + F * c
    return -g * s / w, g * c / w


def averaged_field(a, b, mu: float, F: float, w: float):
    """First-order averaged (slow-flow) equations of the forced van der Pol oscillator.

    The average of (*) over ``w t`` in ``[0, 2 pi)`` with ``a``, ``b`` frozen
    (Nayfeh & Mook 1979; Rand, forced van der Pol)::

        a' = (mu / 2) (1 - r^2 / 4) a - sigma b
        b' = (mu / 2) (1 - r^2 / 4) b + sigma a + F / (2 w)

    with ``r^2 = a^2 + b^2`` and the exact detuning ``sigma = (w^2 - 1) / (2 w)``
    (``~ w - 1`` near resonance). The terms: ``(w^2 - 1) x`` gives the
    rotation ``sigma``; ``F cos(w t)`` gives ``F / (2 w)`` in ``b'`` only;
    ``mu (1 - x^2) x'`` with ``x = r cos(psi)``, ``<sin^2> = 1/2`` and
    ``<sin^2 cos^2> = 1/8`` gives ``(mu / 2)(1 - r^2 / 4) (a, b)``.

    Parameters
    ----------
    a, b : float or ndarray (same shape)

    Returns
    -------
    (da, db) : floats or ndarrays of the shape of a
    """
    lam = 0.5 * mu * (1.0 - 0.25 * (a * a + b * b))
    sigma = (w * w - 1.0) / (2.0 * w)
    return lam * a - sigma * b, lam * b + sigma * a + F / (2.0 * w)


def slow_jacobian(a: float, b: float, mu: float, F: float, w: float) -> np.ndarray:
    """Jacobian of :func:`averaged_field` with respect to ``(a, b)``, shape (2, 2).

    With ``lam = (mu / 2)(1 - r^2 / 4)``::

        [[lam - mu a^2 / 4,   -sigma - mu a b / 4],
         [sigma - mu a b / 4,  lam - mu b^2 / 4 ]]

    Its trace is ``(mu / 2)(2 - r^2)`` (zero at ``r^2 = 2``: Hopf) and its
    determinant ``(mu / 2)^2 (1 - R)(1 - 3 R) + sigma^2`` with ``R = r^2 / 4``
    (zero: saddle-node).
    """
    lam = 0.5 * mu * (1.0 - 0.25 * (a * a + b * b))
    sigma = (w * w - 1.0) / (2.0 * w)
    q = 0.25 * mu
    return np.array([[lam - q * a * a, -sigma - q * a * b], [sigma - q * a * b, lam - q * b * b]])


@dataclasses.dataclass(frozen=True)
class Equilibrium:
    """An equilibrium of the slow flow: the 1:1 entrained response ``x = a cos(w t) + b sin(w t)``.

    Attributes
    ----------
    a, b : float
        Cosine and sine coefficients.
    amplitude : float
        ``r = sqrt(a^2 + b^2)``.
    eigenvalues : ndarray, shape (2,), complex
        Of :func:`slow_jacobian`, in the original time ``t``; the Floquet
        exponents of the periodic response to first order in ``mu``.
    """

    a: float
    b: float
    amplitude: float
    eigenvalues: np.ndarray

    @property
    def stable(self) -> bool:
        return bool(np.all(self.eigenvalues.real < 0.0))


def _cubic_roots(Omega: float, Gamma: float) -> np.ndarray:
    """Real positive roots ``R`` of ``R ((1 - R)^2 + Omega^2) = Gamma^2``, ascending."""
    roots = np.roots([1.0, -2.0, 1.0 + Omega * Omega, -Gamma * Gamma])
    keep = np.abs(roots.imag) <= _REAL_TOL * np.maximum(np.abs(roots), 1.0)
    return np.sort(roots.real[keep & (roots.real > 0.0)])


def locked_amplitudes(mu: float, F: float, w: float) -> list[Equilibrium]:
    """Equilibria of the slow flow (the 1:1 entrained periodic responses), by increasing amplitude.

    From :func:`averaged_field` = 0: with ``lam = (mu / 2)(1 - r^2 / 4)``,
    ``(lam^2 + sigma^2) r^2 = (F / (2 w))^2``, the cubic in ``rho = r^2``::

        rho ((mu / 2)^2 (1 - rho / 4)^2 + sigma^2) = (F / (2 w))^2,

    in scaled form ``R ((1 - R)^2 + Omega^2) = Gamma^2`` with ``R = rho / 4``
    (Guckenheimer & Holmes 1983 sec. 2.1; Nayfeh & Mook 1979), and
    ``a = -sigma f / (lam^2 + sigma^2)``, ``b = -lam f / (lam^2 + sigma^2)``,
    ``f = F / (2 w)``. One root, or three when ``Gamma^2`` lies between the
    values of the left side at ``R = (2 -+ sqrt(1 - 3 Omega^2)) / 3``.

    Parameters
    ----------
    mu, F, w : float
        ``mu > 0``, ``F > 0``.

    Returns
    -------
    list of Equilibrium
        One or three.
    """
    Omega, Gamma = scaled(mu, F, w)
    sigma, f = (w * w - 1.0) / (2.0 * w), F / (2.0 * w)
    out = []
    for R in _cubic_roots(Omega, Gamma):
        lam = 0.5 * mu * (1.0 - R)
        d = lam * lam + sigma * sigma
        a, b = -sigma * f / d, -lam * f / d
        out.append(Equilibrium(float(a), float(b), float(2.0 * math.sqrt(R)),
                               np.linalg.eigvals(slow_jacobian(a, b, mu, F, w))))
    return out


# ---------------------------------------------------------------- the entrainment region
class BoundaryKind(enum.Enum):
    """How the stable entrained response ends at a boundary of the entrainment region."""

    SADDLE_NODE = "saddle-node"  # fold of the periodic response (a SNIC of the slow flow for small Gamma)
    HOPF = "hopf"  # Hopf of the slow flow: a Neimark-Sacker point of the periodic response


@dataclasses.dataclass(frozen=True)
class LockingBoundaries:
    """The 1:1 entrainment region ``low < w < high`` of :func:`locking_boundaries`.

    Attributes
    ----------
    low, high : float
        The forcing frequencies below and above ``w = 1`` where the last
        stable equilibrium of the slow flow disappears or loses stability.
    low_kind, high_kind : BoundaryKind
    low_Gamma, high_Gamma : float
        ``Gamma = F / (2 mu w)`` at each boundary (which regime applies).
    """

    low: float
    high: float
    low_kind: BoundaryKind
    high_kind: BoundaryKind
    low_Gamma: float
    high_Gamma: float


def saddle_node_condition(R: float, Omega: float) -> float:
    """``(1 - R)(1 - 3 R) + Omega^2``: the slow-flow determinant over ``alpha^2``; zero at a fold."""
    return (1.0 - R) * (1.0 - 3.0 * R) + Omega * Omega


def _fold_residual(w: float, mu: float, F: float, outer: bool) -> float:
    """``m(Omega(w)) - Gamma(w)^2``: the amplitude equation's left side at its local minimum
    (``outer``, ``R = (2 + s) / 3``) or maximum (``R = (2 - s) / 3``), ``s = sqrt(1 - 3 Omega^2)``,
    minus the right side; zero where two equilibria meet (Guckenheimer & Holmes 1983 sec. 2.1)."""
    Omega, Gamma = scaled(mu, F, w)
    s = math.sqrt(max(1.0 - 3.0 * Omega * Omega, 0.0))
    R = (2.0 + s) / 3.0 if outer else (2.0 - s) / 3.0
    return R * ((1.0 - R) ** 2 + Omega * Omega) - Gamma * Gamma


def _hopf_residual(w: float, mu: float, F: float) -> float:
    """``Omega^2 + 1/4 - 2 Gamma^2``: zero where the equilibrium with ``R = 1/2`` exists (trace zero)."""
    Omega, Gamma = scaled(mu, F, w)
    return Omega * Omega + 0.25 - 2.0 * Gamma * Gamma


def _w_of_Omega(Omega: float, mu: float) -> float:
    """The ``w > 0`` with ``(w^2 - 1) / (mu w) = Omega`` (monotone increasing)."""
    m = mu * Omega
    return 0.5 * (m + math.sqrt(m * m + 4.0))


def _stable_roots(mu: float, F: float, w: float) -> list[float]:
    """The roots ``R`` of stable equilibria: trace ``mu (1 - 2 R) < 0`` and determinant
    ``alpha^2 ((1 - R)(1 - 3 R) + Omega^2) > 0`` (:func:`slow_jacobian`)."""
    Omega, Gamma = scaled(mu, F, w)
    return [R for R in _cubic_roots(Omega, Gamma) if R > 0.5 and saddle_node_condition(R, Omega) > 0.0]


def locking_boundaries(mu: float, F: float, max_detuning: float = 0.5) -> LockingBoundaries:
    """The 1:1 entrainment region of the averaged equations: where the quasi-periodic response starts.

    At ``w = 1`` (``Omega = 0``) the largest root ``R > 1`` is always stable.
    On each side the entrained response is followed outwards (steps growing
    geometrically in ``Omega``) to the first ``w`` where no stable equilibrium
    is left; the bracket is classified and refined by ``brentq`` on the
    closed-form condition:

    - ``SADDLE_NODE``: the stable node meets the saddle, ``Gamma^2 = m(Omega)``
      with ``m`` the local minimum of ``R ((1 - R)^2 + Omega^2)`` at
      ``R = (2 + sqrt(1 - 3 Omega^2)) / 3``. For ``Gamma^2 < 4/27`` this is the
      boundary, on the slow flow's invariant circle (a SNIC): a limit cycle
      of the slow flow (a quasi-periodic response) is born with infinite period.
      For ``Gamma -> 0``, ``R -> 1`` and ``Omega -> +-Gamma``, i.e.
      ``|w^2 - 1| = F / 2``, ``w ~ 1 +- F / 4`` (Adler's locking band).
    - ``HOPF``: the stable focus loses stability at ``R = 1/2``,
      ``Omega^2 = 2 Gamma^2 - 1/4``. For ``Gamma^2 > 8/27`` (above the cusp,
      a single equilibrium for every ``Omega``) this is the boundary, and a
      small slow limit cycle (a torus of the full system) grows from it.

    Between (``4/27 < Gamma^2 < 8/27``, around the Bogdanov-Takens point
    ``Omega^2 = Gamma^2 = 1/4``) both kinds occur and the region where a
    stable slow limit cycle exists can overlap the entrained one (global
    bifurcations, Guckenheimer & Holmes sec. 2.1); the boundary returned is
    still where the last stable equilibrium ends.

    Parameters
    ----------
    mu, F : float
        ``mu > 0``, ``F > 0``.
    max_detuning : float
        Largest ``|w - 1|`` searched.

    Returns
    -------
    LockingBoundaries

    Raises
    ------
    RuntimeError
        No boundary within ``max_detuning`` on a side.
    """
    out = {}
    for side in (-1.0, 1.0):
        lo_Om, last, Om = 0.0, _stable_roots(mu, F, 1.0), _SCAN_FIRST
        while True:
            w = _w_of_Omega(side * Om, mu)
            if abs(w - 1.0) > max_detuning:
                raise RuntimeError(f"no end of the entrained response within |w - 1| <= {max_detuning}")
            now = _stable_roots(mu, F, w)
            if not now:
                break
            lo_Om, last, Om = Om, now, Om * _SCAN_RATIO
        w_in, w_out = _w_of_Omega(side * lo_Om, mu), w
        # the count of equilibria drops where the stable one meets the saddle; otherwise it lost stability
        if len(_cubic_roots(*scaled(mu, F, w_out))) < len(_cubic_roots(*scaled(mu, F, w_in))):
            kind = BoundaryKind.SADDLE_NODE
            outer = max(last) > 2.0 / 3.0  # R_+ >= 2/3 >= R_-
            residual = lambda x: _fold_residual(x, mu, F, outer)  # noqa: E731
        else:
            kind = BoundaryKind.HOPF
            residual = lambda x: _hopf_residual(x, mu, F)  # noqa: E731
        if residual(w_in) * residual(w_out) <= 0.0:
            wb = brentq(residual, w_in, w_out, xtol=1e-15, rtol=4 * np.finfo(float).eps)
        else:  # two events in one step: bisect on "a stable equilibrium exists"
            for _ in range(80):
                mid = 0.5 * (w_in + w_out)
                w_in, w_out = (mid, w_out) if _stable_roots(mu, F, mid) else (w_in, mid)
            wb = 0.5 * (w_in + w_out)
        out[side] = (wb, kind, scaled(mu, F, wb)[1])
    (lo, lk, lg), (hi, hk, hg) = out[-1.0], out[1.0]
    return LockingBoundaries(lo, hi, lk, hk, lg, hg)


# ---------------------------------------------------------------- the slow limit cycle
@dataclasses.dataclass(frozen=True)
class SlowLine:
    """One spectral line of ``x(t) = Re(z(t) exp(i w t))``, ``z = a - i b``.

    Attributes
    ----------
    order : int
        ``k`` in ``w + k Omega_s``, ``Omega_s = 2 pi / T_s``.
    frequency : float
        ``w + k Omega_s``, rad per unit time.
    amplitude : float
        ``|c_k|``, ``c_k`` the Fourier coefficient of ``z`` over one slow period.
    phase : float
        ``arg c_k`` (time origin: the Poincare section of the cycle).
    """

    order: int
    frequency: float
    amplitude: float
    phase: float


@dataclasses.dataclass(frozen=True)
class SlowCycle:
    """The limit cycle of the slow flow and the quasi-periodic response it predicts.

    Attributes
    ----------
    period : float
        ``T_s`` of the slow cycle, in the original time.
    orientation : int
        +1 when ``(a, b)`` turns counterclockwise (``z = a - i b`` clockwise).
    free_frequency : float
        Frequency of the self-excited line, ``w - orientation * 2 pi / T_s``.
    mean_a, mean_b : float
        Time averages of ``a`` and ``b`` over the slow cycle (the forced line
        at ``w`` is ``mean_a cos(w t) + mean_b sin(w t)``).
    lines : tuple of SlowLine
        Orders ``k = -K..K``.
    """

    period: float
    orientation: int
    free_frequency: float
    mean_a: float
    mean_b: float
    lines: tuple

    def line(self, order: int) -> SlowLine:
        """The line of order ``k`` (``KeyError`` when not computed)."""
        for ln in self.lines:
            if ln.order == order:
                return ln
        raise KeyError(order)

    @property
    def free_order(self) -> int:
        """Order ``k`` of the self-excited line: ``-orientation``."""
        return -self.orientation


def slow_limit_cycle(mu: float, F: float, w: float, orders: int = 4, samples: int = 512,
                     rtol: float = 1e-12, atol: float = 1e-12, max_revolutions: int = 400) -> SlowCycle:
    """Limit cycle of the averaged equations outside the entrainment region, and its spectral lines.

    The slow flow (:func:`averaged_field`) is integrated (``solve_ivp``,
    DOP853) from next to its unstable equilibrium (the one of smallest
    amplitude) until the time between successive upward crossings of the
    Poincare section ``a = a_eq`` (``da/dt > 0``) repeats to ``1e-9``
    relative; that time is ``T_s``. One more period is sampled at ``samples``
    uniform points and the Fourier coefficients ``c_k`` of ``z = a - i b``
    (``z(t) = sum_k c_k exp(i k Omega_s t)``, ``Omega_s = 2 pi / T_s``) give

        x(t) = Re(z(t) exp(i w t)) = sum_k |c_k| cos((w + k Omega_s) t + arg c_k):

    a forced line at ``w`` (``k = 0``, amplitude ``|<a> - i <b>|``), the
    self-excited line and combination lines ``w + k Omega_s``.

    Which sign: for ``w > 1`` (``sigma > 0``) the rotation ``a' ~ -sigma b``,
    ``b' ~ sigma a`` turns ``(a, b)`` counterclockwise, ``z = a - i b``
    clockwise, so the free line is ``k = -1``, at ``w - 2 pi / T_s``, below
    ``w`` and near the natural frequency 1; for ``w < 1`` it is at
    ``w + 2 pi / T_s``. The orientation is measured (sign of the area
    enclosed), not assumed. In the Adler limit (``Gamma`` small),
    ``2 pi / T_s = alpha sqrt(Omega^2 - Gamma^2)`` (Rand, forced van der Pol).

    Accuracy: first order. The exact detuning ``sigma`` turns the free part
    at ``sigma`` instead of the linear oscillator's ``w - 1``, so with
    negligible forcing the free line is predicted at
    ``(w^2 + 1) / (2 w) = 1 + (w - 1)^2 / (2 w)`` instead of 1 (second order
    in the detuning; the unforced oscillator's own shift is ``-mu^2 / 16``).

    Parameters
    ----------
    mu, F, w : float
        Outside the entrainment region (:func:`locking_boundaries`).
    orders : int
        Lines ``k = -orders..orders`` are returned.
    samples : int
        Samples of the slow period for the Fourier coefficients.

    Returns
    -------
    SlowCycle

    Raises
    ------
    ValueError
        A stable equilibrium exists at ``w`` (inside the entrainment region).
    RuntimeError
        The period does not settle within ``max_revolutions`` crossings.
    """
    eqs = locked_amplitudes(mu, F, w)
    if any(e.stable for e in eqs):
        raise ValueError(f"w = {w} is inside the entrainment region: the slow flow has a stable equilibrium")
    e0 = eqs[0]

    def rhs(t, y):
        return averaged_field(y[0], y[1], mu, F, w)

    def section(t, y):
        return y[0] - e0.a

    section.direction = 1.0
    chunk = 50.0 / (0.5 * mu)  # fifty times the slow flow's time scale 2 / mu
    t0, y = 0.0, np.array([e0.a + 0.05, e0.b])
    times, start = [], None
    while len(times) < max_revolutions:
        sol = solve_ivp(rhs, (t0, t0 + chunk), y, method="DOP853", rtol=rtol, atol=atol, events=section)
        if sol.t_events[0].size:
            times += list(sol.t_events[0])
            start = sol.y_events[0][-1]
        t0, y = sol.t[-1], sol.y[:, -1]
        if len(times) >= 3 and abs((times[-1] - times[-2]) - (times[-2] - times[-3])) <= 1e-9 * (times[-1] - times[-2]):
            break
    else:
        raise RuntimeError(f"the slow flow's period did not settle in {max_revolutions} revolutions")
    period = times[-1] - times[-2]
    ts = np.arange(samples) * (period / samples)
    sol = solve_ivp(rhs, (0.0, period), start, method="DOP853", rtol=rtol, atol=atol, t_eval=ts)
    a, b = sol.y
    z = a - 1j * b
    c = np.fft.fft(z) / samples  # c[k] multiplies exp(+i k Omega_s t)
    # signed area of the (a, b) loop (shoelace): > 0 counterclockwise
    area = 0.5 * float(np.sum(a * np.roll(b, -1) - np.roll(a, -1) * b))
    orientation = 1 if area > 0.0 else -1
    om = 2.0 * math.pi / period
    lines = tuple(SlowLine(k, w + k * om, float(abs(c[k % samples])), float(np.angle(c[k % samples])))
                  for k in range(-orders, orders + 1))
    return SlowCycle(period=float(period), orientation=orientation, free_frequency=w - orientation * om,
                     mean_a=float(a.mean()), mean_b=float(b.mean()), lines=lines)


# ---------------------------------------------------------------- hard excitation
@dataclasses.dataclass(frozen=True)
class HardExcitation:
    """The non-resonant response to hard excitation, ``x ~ A cos(w t) + r cos(t + theta)``.

    Attributes
    ----------
    forced_amplitude : float
        ``A = F / (1 - w^2)`` (signed: negative above resonance).
    free_amplitude : float
        ``r = 2 sqrt(1 - A^2 / 2)``, zero when ``A^2 >= 2`` (quenched).
    free_frequency : float
        1, to first order in ``mu``.
    """

    forced_amplitude: float
    free_amplitude: float
    free_frequency: float

    @property
    def quenched(self) -> bool:
        return self.free_amplitude == 0.0


def hard_excitation(mu: float, F: float, w: float) -> HardExcitation:
    """Hard (``F = O(1)``), non-resonant excitation: the forced part and the surviving free oscillation.

    ``x = A cos(w t) + y`` with ``A = F / (1 - w^2)`` removes the forcing;
    ``y'' + y = mu (1 - (A cos(w t) + y)^2)(y' - A w sin(w t))``. Averaged
    with ``y = r cos(t + theta)`` and ``w`` away from the resonances
    ``1, 3, 1/3`` (where terms of frequency 1 come out of the forcing), only
    ``<A^2 cos^2(w t)> = A^2 / 2`` survives:

        r' = (mu / 2) r (1 - A^2 / 2 - r^2 / 4),   theta' = 0,

    so ``r = 2 sqrt(1 - A^2 / 2)`` and the free oscillation is quenched
    (``r = 0`` is stable) when ``A^2 > 2`` (Nayfeh & Mook 1979;
    Rand, forced van der Pol). Both to first order in ``mu``.

    Parameters
    ----------
    mu, F, w : float
        ``w`` not near 1, 3 or 1/3.

    Returns
    -------
    HardExcitation
    """
    A = F / (1.0 - w * w)
    q = 1.0 - 0.5 * A * A
    return HardExcitation(float(A), 2.0 * math.sqrt(q) if q > 0.0 else 0.0, 1.0)


# ---------------------------------------------------------------- the full equation in time
def simulated_lines(mu: float, F: float, w: float, periods: int, transient: int = 0,
                    samples_per_period: int = 32, initial=(2.0, 0.0), rtol: float = 1e-11,
                    atol: float = 1e-12) -> tuple[np.ndarray, np.ndarray]:
    """A uniformly sampled record of ``x(t)`` of the full equation, for a spectral analysis.

    ``x'' = mu (1 - x^2) x' - x + F cos(w t)`` is integrated by
    ``solve_ivp`` (DOP853, ``rtol``, ``atol``) from ``(x, x') = initial`` at
    ``t = 0`` through ``transient`` forcing periods, then sampled (DOP853's
    dense output) every ``2 pi / (w samples_per_period)`` over ``periods``
    forcing periods.

    Parameters
    ----------
    mu, F, w : float
    periods : int
        Forcing periods recorded.
    transient : int
        Forcing periods discarded first.
    samples_per_period : int
    initial : (float, float)
        ``(x(0), x'(0))``.

    Returns
    -------
    t : ndarray, shape (periods * samples_per_period,)
        Absolute times (the forcing is ``F cos(w t)``), starting at ``transient * 2 pi / w``.
    x : ndarray, same shape
    """
    T = 2.0 * math.pi / w
    n = int(periods) * int(samples_per_period)
    t = transient * T + np.arange(n) * (T / samples_per_period)

    def rhs(tt, z):
        x, v = z
        return [v, mu * (1.0 - x * x) * v - x + F * math.cos(w * tt)]

    sol = solve_ivp(rhs, (0.0, t[-1]), list(initial), method="DOP853", rtol=rtol, atol=atol, t_eval=t)
    if not sol.success:
        raise RuntimeError(f"the simulation failed: {sol.message}")
    return sol.t, sol.y[0]
