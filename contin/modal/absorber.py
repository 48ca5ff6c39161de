"""The damped dynamic vibration absorber in closed form: response, fixed points, Den Hartog's optimum, true peaks.

A main system ``m1, k1`` (undamped) forced by ``F cos(w t)`` carries an
absorber ``m2`` joined to it by a spring ``k2`` and a damper ``c`` (seed 000,
sec. 7.2-7.3, Fig. 7-3; seed 002, sec. 6.3). With

- ``p = sqrt(k1/m1)``, ``p_a = sqrt(k2/m2)``, ``beta = m2/m1`` (mass ratio),
- ``mu = p_a/p`` (tuning, frequency ratio), ``Omega = w/p``, ``delta_st = F/k1``,

the main mass responds with (seed 000, sec. 7.3)::

    (X1/delta_st)^2 = [(mu^2 - Omega^2)^2 + 4 zeta^2 Omega^2]
                      / [{(1 - Omega^2)(mu^2 - Omega^2) - beta mu^2 Omega^2}^2
                         + 4 zeta^2 Omega^2 {1 - (1 + beta) Omega^2}^2]

**Two damping ratios.** Seed 000 defines both and warns that textbooks mix
them up:

- ``zeta = c / (2 m2 p)``: referred to the *main* system's natural frequency
  (used in the formula above, and by seed 002 as ``c/(2 m2 w1)``);
- ``zeta_a = c / (2 sqrt(m2 k2)) = c / (2 m2 p_a) = zeta / mu``: the absorber's own
  damping ratio.

Den Hartog's design (seed 000, sec. 7.4): every curve passes through two
fixed points P and Q whatever ``c``; their frequencies are the roots of
``(2 + beta) Omega^4 - 2 {1 + mu^2 (1 + beta)} Omega^2 + 2 mu^2 = 0``. Equal
heights give the optimal tuning ``mu_opt = 1/(1 + beta)``, i.e.
``k2 = k1 beta/(1 + beta)^2``; then ``Omega_{P,Q}^2 = (1 -+ sqrt(beta/(2+beta)))/(1+beta)``
and the height is ``sqrt((2 + beta)/beta)``. Horizontal tangents at P and Q
need ``zeta_P^2 = beta (3 - sqrt(beta/(beta+2))) / (8 (1+beta)^3)`` and
``zeta_Q^2`` with ``+``; their mean is the optimal damping
``zeta_opt = sqrt(3 beta / (8 (1 + beta)^3))``, or ``zeta_a,opt = sqrt(3 beta/(8 (1+beta)))``.

Because ``zeta_opt`` is a compromise between ``zeta_P`` and ``zeta_Q``, the
optimal curve's true maximum lies slightly above the fixed points:
:func:`peaks` finds it exactly, as a root of the derivative of the rational
function ``|X1/delta_st|^2`` of ``Omega^2``.

The undamped absorber (``c = 0``, seed 002, sec. 6.2) has an anti-resonance
at ``w = p_a`` (``X1 = 0``) and two resonances at the roots of
``Omega^4 - (1 + mu^2 + beta mu^2) Omega^2 + mu^2 = 0``; with ``zeta -> inf``
the two masses move as one, resonant at ``Omega = 1/sqrt(1 + beta)``.

Notation: seed 002 writes ``mu`` for the mass ratio and ``alpha`` for the
frequency ratio; here (and in seed 000) they are ``beta`` and ``mu``.

The dimensional design of an absorber for a given main system is
:mod:`contin.modal.absorber_design`.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.polynomial import Polynomial

__all__ = [
    "response",
    "amplification",
    "fixed_points",
    "optimal_tuning",
    "optimal_damping",
    "optimal_damping_absorber",
    "fixed_point_damping",
    "fixed_point_height",
    "mass_ratio_for_height",
    "undamped_resonances",
    "peaks",
    "true_peak",
    "plot_curves",
]


# ---------------------------------------------------------------- dimensionless formulas
def response(Omega, beta: float, mu: float, zeta: float):
    """Complex ``X1/delta_st`` and ``X2/delta_st`` (seed 000, sec. 7.3, the ``zeta`` form).

    Parameters
    ----------
    Omega : array_like, shape (m,)
        ``w/p``.
    beta, mu : float
        Mass ratio ``m2/m1`` and tuning ``p_a/p``.
    zeta : float
        ``c/(2 m2 p)`` (main-system convention); ``inf`` for a rigid joint.

    Returns
    -------
    X1, X2 : ndarray of complex, shape (m,)
        ``x_j = Re(X_j delta_st e^{i w t})``.
    """
    O = np.asarray(Omega, dtype=float)
    if np.isinf(zeta):
        x = 1.0 / (1.0 - (1.0 + beta) * O**2)  # the masses move together: m1 + m2 on k1
        return x.astype(complex), x.astype(complex)
    d = 2j * zeta * O
    den = (1 - O**2) * (mu**2 - O**2) - beta * mu**2 * O**2 + d * (1 - (1 + beta) * O**2)
    return (mu**2 - O**2 + d) / den, (mu**2 + d) / den


def amplification(Omega, beta: float, mu: float, zeta: float):
    """``|X1|/delta_st`` of the main mass (seed 000, sec. 7.3), shape of ``Omega``.

    ``zeta = c/(2 m2 p)``; ``zeta = inf`` gives ``1/|1 - (1 + beta) Omega^2|``.
    """
    O2 = np.asarray(Omega, dtype=float) ** 2
    if np.isinf(zeta):
        return 1.0 / np.abs(1.0 - (1.0 + beta) * O2)
    num = (mu**2 - O2) ** 2 + 4 * zeta**2 * O2
    den = ((1 - O2) * (mu**2 - O2) - beta * mu**2 * O2) ** 2 + 4 * zeta**2 * O2 * (1 - (1 + beta) * O2) ** 2
    return np.sqrt(num / den)


def optimal_tuning(beta: float) -> float:
    """``mu_opt = p_a/p = 1/(1 + beta)`` (seed 000, sec. 7.4, optimal tuning)."""
    return 1.0 / (1.0 + beta)


def optimal_damping(beta: float) -> float:
    """``zeta_opt = c/(2 m2 p) = sqrt(3 beta / (8 (1 + beta)^3))``: referred to the MAIN system (seed 000, 7.4)."""
    return math.sqrt(3.0 * beta / (8.0 * (1.0 + beta) ** 3))


def optimal_damping_absorber(beta: float) -> float:
    """``zeta_a,opt = c/(2 sqrt(m2 k2)) = zeta_opt/mu_opt = sqrt(3 beta/(8 (1 + beta)))``: the absorber's own ratio."""
    return math.sqrt(3.0 * beta / (8.0 * (1.0 + beta)))


def fixed_point_damping(beta: float) -> tuple[float, float]:
    """``(zeta_P, zeta_Q)``: the ``zeta`` giving a horizontal tangent at P and at Q (seed 000, 7.4; seed 002, 6.3.3)."""
    s = math.sqrt(beta / (beta + 2.0))
    f = beta / (8.0 * (1.0 + beta) ** 3)
    return math.sqrt(f * (3.0 - s)), math.sqrt(f * (3.0 + s))


def fixed_point_height(beta: float) -> float:
    """``|X1|/delta_st`` at P and Q for the optimal tuning: ``sqrt((2 + beta)/beta)``."""
    return math.sqrt((2.0 + beta) / beta)


def mass_ratio_for_height(height: float) -> float:
    """The ``beta`` whose optimal fixed points sit at ``height`` (seed 002, 6.3.3): ``2/(height^2 - 1)``."""
    if not height > 1.0:
        raise ValueError(f"max_amplification must exceed 1 (the static response), got {height!r}")
    return 2.0 / (height**2 - 1.0)


def fixed_points(beta: float, mu: float):
    """Frequencies and heights of the fixed points P (lower) and Q (upper).

    ``Omega_P^2, Omega_Q^2`` are the roots of
    ``(2 + beta) Omega^4 - 2 {1 + mu^2 (1 + beta)} Omega^2 + 2 mu^2 = 0`` (seed 000,
    sec. 7.4); the heights come from the ``zeta -> inf`` curve
    ``1/|1 - (1 + beta) Omega^2|``, which every curve meets there.

    Returns
    -------
    (Omega_P, Omega_Q), (height_P, height_Q) : tuples of float
    """
    a, b, c = 2.0 + beta, -2.0 * (1.0 + mu**2 * (1.0 + beta)), 2.0 * mu**2
    disc = math.sqrt(b * b - 4 * a * c)  # > 0 for beta > 0
    q = -0.5 * (b - disc)  # stable quadratic roots
    x = sorted((q / a, c / q))
    Om = tuple(math.sqrt(v) for v in x)
    return Om, tuple(1.0 / abs(1.0 - (1.0 + beta) * v) for v in x)


def undamped_resonances(beta: float, mu: float) -> tuple[float, float]:
    """``(Omega_1, Omega_2)``: resonances of the undamped absorber (``c = 0``, seed 002, sec. 6.2.3).

    Roots of ``(1 - Omega^2)(mu^2 - Omega^2) - beta mu^2 Omega^2 = 0``; the
    anti-resonance is at ``Omega = mu`` (``w = p_a``).
    """
    b = 1.0 + mu**2 * (1.0 + beta)
    disc = math.sqrt(b * b - 4.0 * mu**2)
    x2 = 0.5 * (b + disc)
    return math.sqrt(mu**2 / x2), math.sqrt(x2)


def _polynomials(beta: float, mu: float, zeta: float):
    """``|X1/delta_st|^2 = N(x)/D(x)`` with ``x = Omega^2`` (seed 000, sec. 7.4, ``f(x)``)."""
    m2 = mu * mu
    z4 = 4.0 * zeta * zeta
    a = Polynomial([m2, -1.0])  # mu^2 - x
    s = Polynomial([1.0, -1.0]) * a - Polynomial([0.0, beta * m2])  # (1 - x)(mu^2 - x) - beta mu^2 x
    t = Polynomial([1.0, -(1.0 + beta)])  # 1 - (1 + beta) x
    x = Polynomial([0.0, 1.0])
    return a * a + z4 * x, s * s + z4 * x * t * t


def _polish(beta, mu, zeta, x):
    """Refine a maximum at ``x = Omega^2`` on the amplification itself (the polynomial ``N'D - ND'``
    loses digits to cancellation; a bounded search on ``f`` near a flat maximum does not)."""
    from scipy.optimize import minimize_scalar

    O = math.sqrt(x)
    r = minimize_scalar(lambda o: -amplification(o, beta, mu, zeta), bounds=(O * (1 - 1e-4), O * (1 + 1e-4)),
                        method="bounded", options={"xatol": 1e-14 * O})
    a0 = float(amplification(O, beta, mu, zeta))
    return (float(r.x), float(-r.fun)) if -r.fun >= a0 else (O, a0)


def peaks(beta: float, mu: float, zeta: float):
    """All local maxima of ``|X1|/delta_st`` over ``Omega > 0``, located exactly.

    The stationary points of ``f(x) = N(x)/D(x)`` (``x = Omega^2``) are the
    positive real roots of ``N' D - N D'`` (all of them, so no maximum is
    missed); each is polished by Newton steps, kept if ``f`` has a maximum
    there, and refined by a bounded search on ``|X1|/delta_st`` itself.

    Returns
    -------
    list of (Omega, amplification), ascending in Omega
        Empty for ``zeta = 0`` or ``inf`` (infinite resonances).
    """
    if zeta <= 0 or np.isinf(zeta):
        return []
    N, D = _polynomials(beta, mu, zeta)
    g = N.deriv() * D - N * D.deriv()
    dg = g.deriv()
    out = []
    roots = g.roots()
    scale = max(1.0, mu * mu)
    for r in roots:
        if abs(r.imag) > 1e-6 * max(1.0, abs(r.real)) or r.real <= 0:
            continue
        x = float(r.real)
        for _ in range(4):
            d = dg(x)
            if d == 0:
                break
            x -= g(x) / d
        if not (x > 0 and math.isfinite(x)):
            continue
        h = 1e-6 * scale
        f = N(x) / D(x)
        # a maximum: f is below it on both sides
        if f >= N(x + h) / D(x + h) and (x - h <= 0 or f >= N(x - h) / D(x - h)):
            out.append(_polish(beta, mu, zeta, x))
    out.sort()
    merged = []
    for o in out:  # a double root can appear twice
        if not merged or abs(o[0] - merged[-1][0]) > 1e-9 * o[0]:
            merged.append(o)
    return merged


def true_peak(beta: float, mu: float, zeta: float) -> tuple[float, float]:
    """``(Omega, amplification)`` of the global maximum of ``|X1|/delta_st`` (see :func:`peaks`)."""
    pk = peaks(beta, mu, zeta)
    if not pk:
        raise ValueError("true_peak: the response is unbounded for zeta = 0 or inf (undamped resonances)")
    return max(pk, key=lambda t: t[1])


# ---------------------------------------------------------------- figures
def plot_curves(ax, beta: float, mu: float, zetas, Omega, *, fixed=True, optimal=False, labels=None):
    """Draw ``|X1|/delta_st`` against ``Omega`` for several ``zeta`` (``inf`` allowed) on ``ax``.

    Parameters
    ----------
    ax : matplotlib Axes
    beta, mu : float
    zetas : sequence of float
        ``c/(2 m2 p)`` values.
    Omega : ndarray, shape (m,)
    fixed : bool
        Mark the fixed points P and Q.
    optimal : bool
        Add the optimal design (``mu_opt``, ``zeta_opt``) with its fixed points and true peak.
    labels : tuple of str, optional
        Names of the fixed points (seed 000: P, Q; seed 002: S, T).
    """
    names = labels or ("P", "Q")
    for z in zetas:
        y = amplification(Omega, beta, mu, z)
        y = np.where(np.isfinite(y), y, np.nan)
        ax.plot(Omega, y, lw=1.2, label="zeta = inf" if np.isinf(z) else f"zeta = {z:g}")
    if fixed:
        (O1, O2), (h1, h2) = fixed_points(beta, mu)
        ax.plot([O1, O2], [h1, h2], "ko", mfc="none", ms=7)
        for O, h, nm in ((O1, h1, names[0]), (O2, h2, names[1])):
            ax.annotate(nm, (O, h), textcoords="offset points", xytext=(5, 6), fontsize=10)
    if optimal:
        mo, zo = optimal_tuning(beta), optimal_damping(beta)
        ax.plot(Omega, amplification(Omega, beta, mo, zo), "k-", lw=2.0,
                label=f"optimal: mu = {mo:.4g}, zeta = {zo:.4g}")
        (O1, O2), (h1, h2) = fixed_points(beta, mo)
        ax.plot([O1, O2], [h1, h2], "ks", ms=5)
        Op, hp = true_peak(beta, mo, zo)
        ax.plot([Op], [hp], "r^", ms=7, label=f"true peak {hp:.5g} (fixed points {h1:.5g})")
