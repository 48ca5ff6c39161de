"""Rotor whose lower bearing hits its casing through a radial clearance (seed 001).

Nondimensional equations (Inagaki, Ishida & Hayashi, Trans. JSME C 71-702
(2005), eq. 11; two printed lines drop a dot, restored here):

    x1'' + ip w y1' + c1 x1' + (x1 - alpha x2)        = e w^2 cos(w t)
    y1'' - ip w x1' + c1 y1' + (y1 - alpha y2)        = e w^2 sin(w t) + f0
    beta x2'' + c2 x2' + ks2 (alpha x2 - x1) + (x2/r2) Fn = 0
    beta y2'' + c2 y2' + ks2 (alpha y2 - y1) + (y2/r2) Fn = 0

    r2 = sqrt(x2^2 + y2^2),  Fn = kbn (r2 - delta) + cbn (x2' cos th + y2' sin th)  for r2 >= delta, else 0.

dofs ``x1, y1`` (disc) and ``x2, y2`` (lower bearing).

Contact law option ``clip``: the paper's law (eq. 3) lets the damping term
pull the bearing back while it separates (``Fn < 0`` during rebound); with
``clip: true`` ``Fn`` is cut at zero (no adhesion). The default is
``clip: false``, the paper's law, so that its diagrams are reproduced; with
``cbn = 0.515`` against ``kbn = 12881`` the adhesive part is small.
"""

from __future__ import annotations

import math

import numpy as np

from contin.model.catalog import ModelSpec, register_model
from contin.model.elements import HarmonicExcitation, RadialGapForce
from contin.model.base import Model, Monomial, ParametricMatrix
from contin.model.whirl import WHIRL_COLUMNS, WHIRL_SYMBOLS, whirl_radii

__all__ = ["stable_subharmonic_interval", "bearing_rotor", "hertz_cylinder_stiffness", "contact_damping", "restitution_coefficient"]

PARAMETERS = {"alpha": 0.611, "ks2": 0.611, "ip": 0.1, "beta": 0.019, "delta": 0.1, "e": 0.5, "f0": 0.5,
              "kbn": 12881.0, "cbn": 0.515, "c1": 0.005, "c2": 0.05, "w": 2.0}
#: physical constraints (nondimensional, eq. 10): mass and inertia ratios, stiffnesses, dampings, the
#: clearance, the eccentricity and the speed mean nothing below zero, the bearing's mass ratio at zero
#: (its equations would lose their inertia); f0 is a force of either sign
CONSTRAINTS = {"alpha": ("nonnegative", "the shaft's length ratio a/l"),
               "ks2": ("nonnegative", "the shaft's stiffness ratio at the bearing"),
               "ip": ("nonnegative", "the disc's polar inertia ratio"),
               "beta": ("positive", "the bearing's mass ratio m2/m1"),
               "delta": ("nonnegative", "the radial clearance"),
               "e": ("nonnegative", "the unbalance eccentricity"),
               "kbn": ("nonnegative", "the contact stiffness"),
               "cbn": ("nonnegative", "the contact damping"),
               "c1": ("nonnegative", "the disc damping"),
               "c2": ("nonnegative", "the bearing damping"),
               "w": ("nonnegative", "the rotor speed")}
EFFECTS = {
    "gyroscopic": "gyroscopic coupling ip*w of the disc (x1', y1')",
    "unbalance": "unbalance forcing e*w^2 (cos, sin)(w t) on the disc",
    "static_force": "static lateral force f0 on y1",
    "contact": "radial contact spring kbn*(r2 - delta) of the bearing beyond the clearance",
    "contact_damping": "contact damping cbn * radial velocity while in contact",
    "disc_damping": "disc damping c1",
    "bearing_damping": "bearing damping c2",
}


def _mono(text: str, names) -> Monomial:
    return Monomial.parse(text, list(names), "bearing_rotor")


def _build(params: dict, effects: tuple, clip: bool = False) -> Model:
    names = list(params)
    z = 0
    C = [[("c1" if "disc_damping" in effects else z), ("ip*w" if "gyroscopic" in effects else z), z, z],
         [("-ip*w" if "gyroscopic" in effects else z), ("c1" if "disc_damping" in effects else z), z, z],
         [z, z, ("c2" if "bearing_damping" in effects else z), z],
         [z, z, z, ("c2" if "bearing_damping" in effects else z)]]
    K = [[1, z, "-alpha", z], [z, 1, z, "-alpha"], ["-ks2", z, "ks2*alpha", z], [z, "-ks2", z, "ks2*alpha"]]
    M = [[1, z, z, z], [z, 1, z, z], [z, z, "beta", z], [z, z, z, "beta"]]
    forces, excitations = [], []
    terms = ["M x'' + K x (frequency domain): disc 1, bearing beta; shaft stiffness alpha, ks2"]
    if "gyroscopic" in effects:
        terms.append("gyroscopic +-ip*w on the disc velocities (frequency domain)")
    if "disc_damping" in effects or "bearing_damping" in effects:
        terms.append("damping " + ", ".join(n for n, e in (("c1", "disc_damping"), ("c2", "bearing_damping")) if e in effects)
                     + " (frequency domain)")
    if "contact" in effects:
        damping = _mono("cbn", names) if "contact_damping" in effects else Monomial(0.0)
        forces.append(RadialGapForce((2, 3), _mono("delta", names), _mono("kbn", names), damping, clip=clip,
                                     label="contact"))
    elif "contact_damping" in effects:
        raise ValueError("model.effects: 'contact_damping' needs 'contact'")
    if "unbalance" in effects:
        excitations.append(HarmonicExcitation(0, _mono("e*w**2", names), 1.0, 0.0, "unbalance"))
        excitations.append(HarmonicExcitation(1, _mono("e*w**2", names), 1.0, -math.pi / 2, "unbalance"))
    if "static_force" in effects:
        excitations.append(HarmonicExcitation(1, _mono("f0", names), 0.0, 0.0, "static_force"))
    model = Model(
        name="bearing_rotor",
        dof_names=("x1", "y1", "x2", "y2"),
        parameters=dict(params),
        mass=ParametricMatrix.from_entries(M, names, "model.mass"),
        damping=ParametricMatrix.from_entries(C, names, "model.damping"),
        stiffness=ParametricMatrix.from_entries(K, names, "model.stiffness"),
        forces=forces,
        excitations=excitations,
        effects=tuple(effects),
        terms=terms,
    )
    if "contact" in effects:
        model.start = _homotopy_start
    model.observables = whirl_components
    model.whirl_parts = dict(PARTS)
    model.observable_names = WHIRL_COLUMNS
    model.symbols = dict(SYMBOLS)
    return model


#: how figures write the rotor speed, the parameters and the whirl columns (:mod:`contin.output.labels`)
SYMBOLS = {"w": r"\Omega", "ks2": r"k_{s2}", "ip": r"i_p", "kbn": r"k_{bn}", "cbn": r"c_{bn}", **WHIRL_SYMBOLS}


#: the node pairs whose whirl the rows carry: the disc (x1, y1) and the bearing (x2, y2)
PARTS = {"disc": (0, 1), "bearing": (2, 3)}


def whirl_components(u: np.ndarray, n_dof: int, nu: int) -> dict:
    """Forward and backward whirl radii of the disc (x1, y1) and the bearing (x2, y2) at w/2 and at w
    (:func:`contin.model.whirl.whirl_radii`; zero at w/2 for ``nu = 1``, the zero-amplitude solution of the
    paper's Fig. 4)."""
    return whirl_radii(u, n_dof, nu, PARTS)


#: Harmonics of the homotopy in the contact stiffness (the start at full H follows by Newton).
HOMOTOPY_HARMONICS = 8


def _homotopy_start(hb, lam0: float):
    """Start by homotopy in the contact stiffness (see :mod:`contin.bifurcation.start`).

    The guess puts disc and bearing on the side the static force pushes them
    to; with a soft contact (``kbn = 20``) Newton converges from there. If the
    homotopy fails at the start speed it is done at ``w = 2`` and the solution
    continued in ``w`` to the start. If that fails too (a guess far from the
    orbit: small or no static force, large bearing damping), the start comes
    from a time simulation to steady state (:func:`contin.bifurcation.start.simulation_start`),
    which finds the harmonic solution wherever it is stable.
    """
    from contin.bifurcation.start import HomotopyFailed, homotopy_start, simulation_start

    guess = np.zeros(hb.size)
    f0 = hb.p0[hb.model.parameter_index("f0")]
    side = 1.0 if f0 >= 0 else -1.0
    guess[:4] = [0.0, side * 0.5, 0.0, side * 0.2]
    # the homotopy with few harmonics: pressed on its casing the bearing's orbit is nearly harmonic,
    # and Newton with all of them converges from it
    coarse = min(hb.H, HOMOTOPY_HARMONICS)
    try:
        return homotopy_start(hb, lam0, "kbn", 20.0, guess, harmonics=coarse)
    except HomotopyFailed:
        if not hb.frequency_moves:
            raise
        try:
            return homotopy_start(hb, lam0, "kbn", 20.0, guess, at=2.0, harmonics=coarse)
        except HomotopyFailed as exc:
            from contin.timedomain.simulation import SimulationError

            try:
                return simulation_start(hb, lam0, transient=800, steps_per_period=2048)
            except (HomotopyFailed, SimulationError) as sim:
                raise HomotopyFailed(f"{exc}; and from a time simulation: {sim}") from None


bearing_rotor = register_model(
    ModelSpec(
        name="bearing_rotor",
        summary="rotor with a radial clearance at the lower bearing (Inagaki, Ishida & Hayashi 2005)",
        parameters=PARAMETERS,
        effects=EFFECTS,
        default_effects=tuple(EFFECTS),
        builder=_build,
        options={"clip": False},
        constraints=CONSTRAINTS,
    )
)


def hertz_cylinder_stiffness(P_m: float, E1: float, nu1: float, E2: float, nu2: float, R1: float, R2: float,
                             length: float) -> float:
    """Equivalent linear contact stiffness of a cylinder inside a cylinder (eq. 4-6).

    The approach of a convex cylinder (radius ``R1``, the bearing holder) pressed
    into a concave one (``R2 > R1``, the casing) over the axial length ``l`` is

        d(P) = 2P(k1 + k2)/(pi l) * (1.8864 + ln(l / (2 b))),
        b = sqrt(2P(k1 + k2) R1 R2 / (pi l (R2 - R1))),   k_i = (1 - nu_i^2)/E_i.

    The linear spring storing the same strain energy at the load ``P_m`` is
    ``kbn = 2 S_m / d(P_m)^2`` with ``S_m = d(P_m) P_m - int_0^P_m d(P) dP``.

    Parameters
    ----------
    P_m : float
        Reference load [N] (the paper takes the largest bearing load at the
        main resonance of the bearing-supported linear model).
    E1, nu1, E2, nu2 : float
        Young's moduli [Pa] and Poisson ratios of holder and casing.
    R1, R2 : float
        Radii [m], ``R2 > R1``.
    length : float
        Axial contact length [m].

    Returns
    -------
    float
        ``kbn`` [N/m].
    """
    if not (0 < R1 < R2) or min(P_m, E1, E2, length) <= 0:
        raise ValueError("hertz_cylinder_stiffness needs 0 < R1 < R2 and positive load, moduli and length")
    kk = (1 - nu1**2) / E1 + (1 - nu2**2) / E2

    def approach(P):
        if P <= 0:
            return 0.0
        b = math.sqrt(2 * P * kk * R1 * R2 / (math.pi * length * (R2 - R1)))
        return 2 * P * kk / (math.pi * length) * (1.8864 + math.log(length / (2 * b)))

    d_m = approach(P_m)
    from scipy.integrate import quad  # here: the model's other users never need scipy.integrate

    energy = d_m * P_m - quad(approach, 0.0, P_m, limit=200, epsabs=0.0, epsrel=1e-12)[0]
    return 2 * energy / d_m**2


def contact_damping(restitution: float, m2: float, kbn: float) -> float:
    """Contact damping from a restitution coefficient (eq. 7-9).

    A bearing of mass ``m2`` hitting a spring ``kbn`` with a dashpot ``cbn``
    rebounds after half a damped period with ``v1 = -v0 exp(-pi z / sqrt(1 - z^2))``,
    ``z = cbn / (2 sqrt(m2 kbn))`` (eq. 7-8). Solving ``e = -v1/v0`` for ``cbn``:

        cbn = 2 sqrt(m2 kbn) * (-ln e) / sqrt(pi^2 + (ln e)^2).

    The paper prints eq. 9 as ``sqrt(2 (ln e)^2 m2 kbn / (pi^2 + (ln e)^2))``,
    a factor ``sqrt(2)`` below this; eq. 7-8 as printed give the expression
    above, which the tests check against a simulated impact.

    Parameters
    ----------
    restitution : float
        ``0 < e <= 1``.
    m2, kbn : float
        Bearing mass and contact stiffness (consistent units).
    """
    if not 0 < restitution <= 1 or m2 <= 0 or kbn <= 0:
        raise ValueError("contact_damping needs 0 < restitution <= 1 and positive m2, kbn")
    L = -math.log(restitution)
    return 2 * math.sqrt(m2 * kbn) * L / math.sqrt(math.pi**2 + L**2)


def restitution_coefficient(cbn: float, m2: float, kbn: float) -> float:
    """Inverse of :func:`contact_damping` (eq. 7-8): ``e = exp(-pi z / sqrt(1 - z^2))``."""
    z = cbn / (2 * math.sqrt(m2 * kbn))
    if z >= 1:
        return 0.0
    return math.exp(-math.pi * z / math.sqrt(1 - z * z))


def stable_subharmonic_interval(rows: dict, special: dict, min_radius: float = 1e-3):
    """Speed interval where a stable 1/2-subharmonic (nu = 2) branch exists, from result files.

    Parameters
    ----------
    rows, special : dict of ndarray
        ``branches.csv`` and ``special_points.csv`` as read by
        :func:`contin.output.results.read_csv`.
    min_radius : float
        Smallest +w/2 forward whirl radius of the disc counted as a
        subharmonic (the harmonic solution seen as nu = 2 has zero).

    Returns
    -------
    (w_lo, w_hi) or None
        Ends of the stable part, each at the located special point (Neimark-
        Sacker, fold, period doubling) of a nu = 2 branch that bounds it where
        there is one within 0.01, else at the last stable stored point.
    """
    stable = np.array([s == "true" if isinstance(s, str) else bool(s) for s in rows["stable"]], dtype=bool)
    sel = (np.asarray(rows["nu"]) == 2) & stable & (np.asarray(rows["whirl_fwd_half_disc"]) > min_radius)
    if not np.any(sel):
        return None
    w = np.asarray(rows["w"])[sel]
    lo, hi = float(w.min()), float(w.max())
    nu2 = set(np.asarray(rows["branch"])[np.asarray(rows["nu"]) == 2].tolist())
    kinds = np.asarray(special["kind"]) if len(special.get("kind", ())) else np.array([])
    cand = [float(v) for b, k, v in zip(special.get("branch", ()), kinds, special.get("w", ()))
            if b in nu2 and k in ("ns", "fold", "pd", "stability")]
    below = [v for v in cand if lo - 0.01 <= v <= lo]
    above = [v for v in cand if hi <= v <= hi + 0.01]
    return (max(below) if below else lo), (min(above) if above else hi)

