"""Den Hartog's optimal absorber for a main system: the design problem, its solution and its figure.

:class:`AbsorberProblem` states the main system ``m1, k1`` and either the
absorber mass ``m2`` or the largest allowed amplification (then ``m2``
follows from a sizing rule); :func:`design_absorber` gives the optimal
tuning and damping (seed 000, sec. 7.4-7.5; seed 002, sec. 6.3.3) as an
:class:`AbsorberDesign`, from the closed forms of
:mod:`contin.modal.absorber`; :func:`draw_design` draws its response into an axes and
:func:`plot_design` into a file.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from contin.modal.absorber import (amplification, fixed_point_height, fixed_points, mass_ratio_for_height,
                                   optimal_damping, optimal_tuning, peaks, true_peak, undamped_resonances)
from contin.util.safe_files import write_user_file

__all__ = ["AbsorberProblem", "AbsorberDesign", "FixedPoint", "Peak", "design_absorber", "draw_design", "plot_design",
           "SIZINGS", "MASS_RATIOS"]

#: how ``design_absorber`` sizes ``m2`` from a maximum allowed amplification
SIZINGS = ("fixed_points", "peak")
#: mass ratios ``beta = m2/m1`` a design is made for. Den Hartog's closed forms hold for any ratio, but the
#: true peak's two maxima merge as beta falls (below about 3e-4 their polynomial roots lose their digits and the
#: peak is lost or wrong) and ``(1 + beta)^2`` overflows beyond 1e154; absorbers have ratios of 0.01 to 0.5
MASS_RATIOS = (1e-3, 1e3)


def _positive(name: str, v, where: str) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)) or not math.isfinite(v) or v <= 0:
        raise ValueError(f"{where}.{name} must be a positive finite number, got {v!r}")
    return float(v)


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
        from contin.modal.modes import frf  # deferred: scipy.linalg, 0.3 s at start-up for the closed forms alone

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

    Raises
    ------
    ValueError
        Naming the field (:class:`AbsorberProblem`); for a mass ratio
        ``m2/m1`` (given, or asked by ``max_amplification``) outside
        :data:`MASS_RATIOS`, and for values whose design over- or underflows
        in double precision (``k1/m1``, ``k2``, ``c``), naming the values.

    Examples
    --------
    Seed 000's exercise: ``design_absorber(100, 5e5, 10)`` gives ``k2 = 41322.3``
    and ``c = 237.379``.
    """
    prob = AbsorberProblem(m1, k1, m2, max_amplification, sizing)
    lo, hi = MASS_RATIOS
    if prob.m2 is not None:
        beta = prob.m2 / prob.m1
        if not lo <= beta <= hi:
            raise ValueError(f"m2 = {prob.m2!r} with m1 = {prob.m1!r} gives the mass ratio m2/m1 = {beta:.4g}, "
                             f"outside the {lo:g} to {hi:g} the design is made for")
        return _finite(_design(prob.m1, prob.k1, prob.m2, prob))
    A = prob.max_amplification
    beta = 2.0 / ((A - 1.0) * (A + 1.0))  # 2/(A^2 - 1) without overflowing A^2
    if not lo <= beta <= hi:
        raise ValueError(f"max_amplification = {A!r} asks the mass ratio m2/m1 = 2/(A^2 - 1) = {beta:.4g}, outside "
                         f"the {lo:g} to {hi:g} the design is made for")
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
        if beta > MASS_RATIOS[1]:
            raise ValueError(f"max_amplification = {A!r} with sizing 'peak' asks the mass ratio m2/m1 = {beta:.4g}, "
                             f"beyond the {MASS_RATIOS[1]:g} the design is made for")
    return _finite(_design(prob.m1, prob.k1, beta * prob.m1, prob))


def _finite(d: AbsorberDesign) -> AbsorberDesign:
    """``d`` if every number of it is finite and its stiffness, damping and frequencies positive; a
    ``ValueError`` naming the values whose ratios over- or underflow otherwise."""
    values = {"k2": d.k2, "c": d.c, "p": d.p, "p_a": d.p_a, "m2": d.m2}
    bad = [f"{k} = {v!r}" for k, v in values.items() if not (math.isfinite(v) and v >= np.finfo(float).tiny)]
    bad += [f"{k} = {v!r}" for k, v in (("true peak", d.true_peak.amplification), ("P", d.P.w), ("Q", d.Q.w))
            if not math.isfinite(v)]
    if bad:
        raise ValueError(f"m1 = {d.m1!r}, k1 = {d.k1!r}, m2 = {d.m2!r}: the design's {', '.join(bad)} over- or "
                         "underflows in double precision (choose units that bring the values nearer to 1)")
    return d


def draw_design(ax, design: AbsorberDesign, points: int = 1200) -> None:
    """Draw ``|X1|/delta_st`` of a design against ``w`` into ``ax``: without damper, damper locked, optimal.

    The fixed points P and Q, where every damping gives the same amplitude
    (the crossings of the curves ``c = 0`` and ``c -> inf``), are marked with
    the true peak; the top axis shows ``w/p``.

    Parameters
    ----------
    ax : matplotlib Axes
    design : AbsorberDesign
    points : int
        Frequencies drawn, over ``0.5 p .. 1.5 p``.
    """
    d = design
    w = np.linspace(0.5 * d.p, 1.5 * d.p, points)
    top = 2.2 * d.fixed_point_height
    for z, style, lab in ((0.0, ":", "without damper ($c = 0$)"), (math.inf, "--", r"damper locked ($c \to \infty$)"),
                          (d.zeta, "-", rf"optimal damping $c$ = {d.c:.4g} ($\zeta$ = {d.zeta:.4g}, "
                                        rf"$\zeta_a$ = {d.zeta_a:.4g})")):
        y = d.amplification(w, z)
        y = np.where(y < 5 * top, y, np.nan)  # the undamped resonances leave the plot
        ax.plot(w, y, style, lw=1.8 if z == d.zeta else 1.0, color="tab:blue" if z == d.zeta else "0.35",
                label=lab)
    ax.plot([d.P.w, d.Q.w], [d.P.height, d.Q.height], "ko", mfc="none", ms=8, mew=1.2,
            label=rf"fixed points P, Q: $\sqrt{{(2+\beta)/\beta}}$ = {d.fixed_point_height:.5g}")
    for f in (d.P, d.Q):
        ax.annotate(f.name, (f.w, f.height), textcoords="offset points", xytext=(-5, 7), ha="right",
                    fontsize=9, fontweight="bold")
    tp = d.true_peak
    ax.plot([tp.w], [tp.amplification], "^", color="tab:red", ms=6, label=f"true peak {tp.amplification:.5g}")
    ax.axvline(d.anti_resonance, color="0.75", lw=0.9, zorder=0, label=r"absorber tuning $p_a$")
    ax.set_xlabel("forcing frequency $w$")
    ax.set_ylabel(r"amplitude ratio $|X_1|/\delta_{\mathrm{st}}$, $\delta_{\mathrm{st}} = F/k_1$")
    ax.set_ylim(0, top)
    sec = ax.secondary_xaxis("top", functions=(lambda x: x / d.p, lambda r: r * d.p))
    sec.set_xlabel(r"frequency ratio $w/p$, $p = \sqrt{k_1/m_1}$")


def plot_design(design: AbsorberDesign, path, points: int = 1200, dpi: float = 200):
    """Save the response of a design (:func:`draw_design`); the format follows the suffix of ``path``.

    The figure is made on its own canvas (no global figure manager, the user's matplotlib
    settings untouched), its legend below the axes.
    """
    from matplotlib.figure import Figure

    d = design
    fig = Figure(figsize=(7.2, 5.6), layout="constrained")
    ax = fig.add_subplot()
    ax.grid(True, alpha=0.3)
    draw_design(ax, d, points)
    ax.set_title(f"absorber $m_2$ = {d.m2:.4g}, $k_2$ = {d.k2:.5g}, $c$ = {d.c:.4g} on $m_1$ = {d.m1:.4g}, "
                 f"$k_1$ = {d.k1:.4g}", fontsize=10)
    handles, texts = ax.get_legend_handles_labels()
    fig.legend(handles, texts, loc="outside lower center", ncols=2, fontsize=8)
    # the format from the suffix (PNG without one); a device or pipe the user named is written in place
    fmt = Path(path).suffix.lstrip(".").lower() or "png"
    write_user_file(path, lambda fh: fig.savefig(fh, format=fmt, dpi=dpi,
                                                 metadata={"Software": "contin"} if fmt == "png" else None),
                    binary=True)
    return path
