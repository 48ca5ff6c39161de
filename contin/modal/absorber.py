"""The damped dynamic vibration absorber and Den Hartog's fixed-point design (seeds 000 and 002).

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
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.polynomial import Polynomial

__all__ = [
    "AbsorberProblem",
    "AbsorberDesign",
    "FixedPoint",
    "Peak",
    "design_absorber",
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
    "plot_design",
    "SIZINGS",
]

#: how ``design_absorber`` sizes ``m2`` from a maximum allowed amplification
SIZINGS = ("fixed_points", "peak")


def _positive(name: str, v, where: str) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)) or not math.isfinite(v) or v <= 0:
        raise ValueError(f"{where}.{name} must be a positive finite number, got {v!r}")
    return float(v)


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


# ---------------------------------------------------------------- dimensional design
@dataclass(frozen=True)
class AbsorberProblem:
    """What the absorber must do: the main system and either ``m2`` or a maximum amplification.

    Parameters
    ----------
    m1, k1 : float
        Main mass and spring (positive).
    m2 : float, optional
        Absorber mass.
    max_amplification : float, optional
        Instead of ``m2``: the largest allowed ``|X1|/delta_st`` (> 1). ``m2``
        then follows from ``sizing``.
    sizing : str
        ``"fixed_points"`` (seed 002, sec. 6.3.3: the fixed points at the
        allowed height, ``beta = 2/(A^2 - 1)``; the true peak is then slightly
        above it) or ``"peak"`` (the smallest ``m2`` whose optimal design's true
        peak equals the allowed height).

    Raises
    ------
    ValueError
        Naming the field.
    """

    m1: float
    k1: float
    m2: float | None = None
    max_amplification: float | None = None
    sizing: str = "fixed_points"

    def __post_init__(self):
        where = "AbsorberProblem"
        object.__setattr__(self, "m1", _positive("m1", self.m1, where))
        object.__setattr__(self, "k1", _positive("k1", self.k1, where))
        if (self.m2 is None) == (self.max_amplification is None):
            raise ValueError(f"{where}: give exactly one of m2 (the absorber mass) and max_amplification "
                             f"(the largest allowed |X1|/delta_st), got m2={self.m2!r}, "
                             f"max_amplification={self.max_amplification!r}")
        if self.m2 is not None:
            object.__setattr__(self, "m2", _positive("m2", self.m2, where))
        else:
            A = _positive("max_amplification", self.max_amplification, where)
            if A <= 1.0:
                raise ValueError(f"{where}.max_amplification must exceed 1 (the static response), got {A!r}")
            object.__setattr__(self, "max_amplification", A)
        if self.sizing not in SIZINGS:
            raise ValueError(f"{where}.sizing must be one of {SIZINGS}, got {self.sizing!r}")


@dataclass(frozen=True)
class FixedPoint:
    """A fixed point of the response curves: ``Omega = w/p``, ``w`` [rad/s], ``height = |X1|/delta_st``."""

    name: str
    Omega: float
    w: float
    height: float


@dataclass(frozen=True)
class Peak:
    """A maximum of ``|X1|/delta_st``: at ``Omega = w/p``, ``w`` [rad/s]."""

    Omega: float
    w: float
    amplification: float


@dataclass(frozen=True)
class AbsorberDesign:
    """Den Hartog's optimal absorber for a main system (seed 000, sec. 7.4-7.5).

    Attributes
    ----------
    m1, k1, m2, k2, c : float
        Masses, springs and the damper between main mass and absorber.
    beta : float
        ``m2/m1``.
    p, p_a : float
        ``sqrt(k1/m1)``, ``sqrt(k2/m2)`` [rad/s].
    mu : float
        ``p_a/p = 1/(1 + beta)``.
    zeta : float
        ``c/(2 m2 p)``, referred to the MAIN system: ``sqrt(3 beta/(8 (1+beta)^3))``.
    zeta_a : float
        ``c/(2 sqrt(m2 k2))``, the absorber's OWN ratio: ``zeta/mu = sqrt(3 beta/(8 (1+beta)))``.
    P, Q : FixedPoint
    fixed_point_height : float
        ``sqrt((2 + beta)/beta)``.
    peaks : tuple of Peak
        Local maxima of the optimal curve (near P and near Q).
    true_peak : Peak
        The highest of them (slightly above the fixed points).
    resonances : tuple of float
        Resonances of the same absorber without its damper (``c = 0``) [rad/s].
    anti_resonance : float
        ``p_a`` [rad/s]: the undamped absorber holds the main mass still there.
    rigid_resonance : float
        ``p/sqrt(1 + beta)`` [rad/s]: the resonance with a rigid damper (``zeta -> inf``).
    problem : AbsorberProblem
    """

    m1: float
    k1: float
    m2: float
    k2: float
    c: float
    beta: float
    p: float
    p_a: float
    mu: float
    zeta: float
    zeta_a: float
    P: FixedPoint
    Q: FixedPoint
    fixed_point_height: float
    peaks: tuple
    true_peak: Peak
    resonances: tuple
    anti_resonance: float
    rigid_resonance: float
    problem: AbsorberProblem

    def matrices(self):
        """``M, C, K`` of the two-mass system (seed 000, sec. 7.3), each (2, 2)."""
        M = np.diag([self.m1, self.m2])
        C = np.array([[self.c, -self.c], [-self.c, self.c]])
        K = np.array([[self.k1 + self.k2, -self.k2], [-self.k2, self.k2]])
        return M, C, K

    def amplification(self, w, zeta: float | None = None):
        """``|X1|/delta_st`` at ``w`` [rad/s], shape of ``w``; another ``zeta`` (main convention) if given."""
        return amplification(np.asarray(w, dtype=float) / self.p, self.beta, self.mu,
                             self.zeta if zeta is None else zeta)

    def frf(self, w, F: float = 1.0):
        """Complex amplitudes ``(X1, X2)`` for ``F cos(w t)`` on the main mass, shape (len(w), 2).

        Solved from the impedance matrix (:func:`contin.modal.modes.frf`).
        """
        from contin.modal.modes import frf

        M, C, K = self.matrices()
        return frf(M, C, K, w, [F, 0.0])

    def as_dict(self) -> dict:
        """Plain numbers for JSON output."""
        d = {k: getattr(self, k) for k in ("m1", "k1", "m2", "k2", "c", "beta", "p", "p_a", "mu", "zeta", "zeta_a",
                                           "fixed_point_height", "anti_resonance", "rigid_resonance")}
        d["P"] = vars(self.P).copy()
        d["Q"] = vars(self.Q).copy()
        d["peaks"] = [vars(pk).copy() for pk in self.peaks]
        d["true_peak"] = vars(self.true_peak).copy()
        d["resonances"] = list(self.resonances)
        d["max_amplification"] = self.problem.max_amplification
        d["sizing"] = self.problem.sizing if self.problem.max_amplification is not None else None
        return d

    def report(self) -> str:
        """A readable account of the design (used by ``contin absorber``)."""
        P, Q, tp = self.P, self.Q, self.true_peak
        above = 100.0 * (tp.amplification / self.fixed_point_height - 1.0)
        lines = [
            f"main system      m1 = {self.m1:.6g}, k1 = {self.k1:.6g}, p = sqrt(k1/m1) = {self.p:.6g} rad/s",
        ]
        if self.problem.max_amplification is not None:
            how = ("fixed points at the allowed height, beta = 2/(A^2 - 1)" if self.problem.sizing == "fixed_points"
                   else "true peak at the allowed height")
            lines.append(f"allowed          |X1|/delta_st <= A = {self.problem.max_amplification:.6g} ({how})")
        lines += [
            f"absorber mass    m2 = {self.m2:.6g}  (beta = m2/m1 = {self.beta:.6g})",
            f"optimal tuning   mu = p_a/p = 1/(1+beta) = {self.mu:.6g}, p_a = {self.p_a:.6g} rad/s",
            f"                 k2 = k1 beta/(1+beta)^2 = {self.k2:.6g}",
            f"optimal damping  c = {self.c:.6g}",
            f"                 zeta   = c/(2 m2 p)        = sqrt(3 beta/(8 (1+beta)^3)) = {self.zeta:.6g}"
            "  (referred to the main system)",
            f"                 zeta_a = c/(2 sqrt(m2 k2)) = sqrt(3 beta/(8 (1+beta)))   = {self.zeta_a:.6g}"
            "  (the absorber's own ratio; zeta_a = zeta/mu)",
            f"fixed points     P: Omega = {P.Omega:.6g} (w = {P.w:.6g} rad/s), Q: Omega = {Q.Omega:.6g} "
            f"(w = {Q.w:.6g} rad/s)",
            f"                 height |X1|/delta_st = sqrt((2+beta)/beta) = {self.fixed_point_height:.6g}",
            f"true peak        |X1|/delta_st = {tp.amplification:.6g} at Omega = {tp.Omega:.6g} "
            f"(w = {tp.w:.6g} rad/s), {above:.3g} % above the fixed points",
        ]
        if len(self.peaks) == 2:
            a, b = self.peaks
            lines.append(f"                 local maxima {a.amplification:.6g} (Omega = {a.Omega:.6g}) and "
                         f"{b.amplification:.6g} (Omega = {b.Omega:.6g})")
        r1, r2 = self.resonances
        lines += [
            f"without damper   anti-resonance at w = p_a = {self.anti_resonance:.6g} rad/s; resonances at "
            f"w = {r1:.6g} and {r2:.6g} rad/s (Omega = {r1 / self.p:.6g}, {r2 / self.p:.6g})",
            f"rigid damper     resonance at w = p/sqrt(1+beta) = {self.rigid_resonance:.6g} rad/s",
        ]
        if self.problem.max_amplification is not None and tp.amplification > self.problem.max_amplification * (1 + 1e-9):
            lines.append(f"note             the true peak exceeds the allowed {self.problem.max_amplification:.6g}; "
                         "size by the true peak (sizing 'peak') to meet it")
        return "\n".join(lines)


def _design(m1: float, k1: float, m2: float, problem: AbsorberProblem) -> AbsorberDesign:
    beta = m2 / m1
    p = math.sqrt(k1 / m1)
    mu = optimal_tuning(beta)
    k2 = k1 * beta / (1.0 + beta) ** 2
    zeta = optimal_damping(beta)
    c = 2.0 * m2 * p * zeta
    (OP, OQ), (hP, hQ) = fixed_points(beta, mu)
    pk = tuple(Peak(O, O * p, a) for O, a in peaks(beta, mu, zeta))
    top = max(pk, key=lambda t: t.amplification)
    R1, R2 = undamped_resonances(beta, mu)
    return AbsorberDesign(
        m1=m1, k1=k1, m2=m2, k2=k2, c=c, beta=beta, p=p, p_a=mu * p, mu=mu, zeta=zeta, zeta_a=zeta / mu,
        P=FixedPoint("P", OP, OP * p, hP), Q=FixedPoint("Q", OQ, OQ * p, hQ),
        fixed_point_height=fixed_point_height(beta), peaks=pk, true_peak=top, resonances=(R1 * p, R2 * p),
        anti_resonance=mu * p, rigid_resonance=p / math.sqrt(1.0 + beta), problem=problem,
    )


def _peak_height(beta: float) -> float:
    return true_peak(beta, optimal_tuning(beta), optimal_damping(beta))[1]


def design_absorber(m1: float, k1: float, m2: float | None = None, *, max_amplification: float | None = None,
                    sizing: str = "fixed_points") -> AbsorberDesign:
    """Den Hartog's optimal absorber for the main system ``m1, k1``.

    Parameters
    ----------
    m1, k1 : float
    m2 : float, optional
        The absorber mass; or instead
    max_amplification : float, optional
        The largest allowed ``|X1|/delta_st``; ``m2`` follows from ``sizing``
        (see :class:`AbsorberProblem`).
    sizing : {"fixed_points", "peak"}

    Returns
    -------
    AbsorberDesign

    Examples
    --------
    Seed 000's exercise: ``design_absorber(100, 5e5, 10)`` gives ``k2 = 41322.3``
    and ``c = 237.379``.
    """
    prob = AbsorberProblem(m1, k1, m2, max_amplification, sizing)
    if prob.m2 is not None:
        return _design(prob.m1, prob.k1, prob.m2, prob)
    A = prob.max_amplification
    beta = mass_ratio_for_height(A)
    if sizing == "peak":
        from scipy.optimize import brentq

        # the true peak exceeds the fixed points, so more mass is needed; it falls as beta grows
        hi = beta
        for _ in range(200):
            hi *= 1.5
            if _peak_height(hi) < A:
                break
        else:  # pragma: no cover - the peak tends to 1 as beta grows
            raise ValueError(f"no absorber mass reaches the amplification {A!r}")
        beta = brentq(lambda b: _peak_height(b) - A, beta, hi, xtol=1e-14 * beta, rtol=1e-13)
    return _design(prob.m1, prob.k1, beta * prob.m1, prob)


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


def plot_design(design: AbsorberDesign, path, points: int = 1200):
    """Save the response of a design: ``|X1|/delta_st`` against ``w`` with ``c = 0``, the optimum and ``c -> inf``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    d = design
    w = np.linspace(0.5 * d.p, 1.5 * d.p, points)
    fig, ax = plt.subplots(figsize=(7.2, 4.6), constrained_layout=True)
    for z, style, lab in ((0.0, ":", "without damper (c = 0)"), (math.inf, "--", "rigid damper (c -> inf)"),
                          (d.zeta, "-", f"optimal: c = {d.c:.4g} (zeta = {d.zeta:.4g}, zeta_a = {d.zeta_a:.4g})")):
        y = d.amplification(w, z)
        y = np.where(y < 5 * d.fixed_point_height, y, np.nan)  # clip the undamped resonances
        ax.plot(w, y, style, lw=1.8 if z == d.zeta else 1.0, label=lab)
    ax.plot([d.P.w, d.Q.w], [d.P.height, d.Q.height], "ko", mfc="none", ms=8, label="fixed points P, Q")
    for f in (d.P, d.Q):
        ax.annotate(f.name, (f.w, f.height), textcoords="offset points", xytext=(5, 6))
    tp = d.true_peak
    ax.plot([tp.w], [tp.amplification], "r^", label=f"true peak {tp.amplification:.5g} (fixed points "
                                                    f"{d.fixed_point_height:.5g})")
    ax.axvline(d.anti_resonance, color="0.6", lw=0.8)
    ax.set_xlabel("forcing frequency w [rad/s]")
    ax.set_ylabel("|X1| / delta_st")
    ax.set_ylim(0, 2.2 * d.fixed_point_height)
    ax.set_title(f"absorber m2 = {d.m2:.4g}, k2 = {d.k2:.5g}, c = {d.c:.4g} on m1 = {d.m1:.4g}, k1 = {d.k1:.4g}")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path
