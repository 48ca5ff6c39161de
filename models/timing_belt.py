"""Timing belt with a rotor pulled by a magnet (seed 003).

Nagai, Koyama, Watanabe, Tanifuji & Kagotani, "Nonlinear vibrations of a
timing belt with a rotor pulled by magnetic force", Trans. JSME C 59-563
(1993). A belt span (string, stretching included) carries a rotor of mass
ratio ``beta`` at ``xi1``; a magnet pulls the rotor with
``q = sum_k gamma_k w(xi1)^k`` (k = 0..3); the whole system is shaken
laterally with the acceleration ``p_s + p_d cos(w tau)``. Nondimensional
equation of motion (eq. 7-8):

    [1 + beta delta(xi - xi1)] w_tt - n w_xixi - delta(xi - xi1) q = [1 + beta delta(xi - xi1)] (p_s + p_d cos w tau),
    n = 1 + (alpha/2) int_0^1 w_xi^2 dxi.

Galerkin on the string modes ``sin(j pi xi)``, ``j = 1..n``, with
``w(xi, tau) = sum_j b_j(tau) sin(j pi xi)`` gives (eq. 12-13)

    sum_j B_ij b_j'' + sum_j C_ij b_j + sum_jk D_ijk b_j b_k + sum_jkl E_ijkl b_j b_k b_l = F_i + (p_s + p_d cos w tau) G_i,

    B_ij = delta_ij/2 + beta s_i s_j                     C_ij = (pi^2/2) i j delta_ij - gamma1 s_i s_j
    D_ijk = -gamma2 s_i s_j s_k                          E_ijkl = (alpha pi^4/8) i j k l delta_ij delta_kl - gamma3 s_i s_j s_k s_l
    F_i = gamma0 s_i                                     G_i = (1 - (-1)^i)/(i pi) + beta s_i,     s_i = sin(i pi xi1).

(The printed eq. 12 shows ``B_ij b_j`` without the dots; it is the inertia
term ``b_j''``.) How the model evaluates it:

- ``B`` is the mass matrix, ``(pi^2/2) i^2`` and ``-gamma1 s s^T`` the
  stiffness (frequency domain, exact);
- the stretching ``E`` term is ``(alpha pi^4/8) i^2 b_i sum_k k^2 b_k^2``,
  evaluated in ``O(n)`` per time sample
  (:class:`contin.model.elements.string_stretching.StringStretchingForce`), never as an
  ``n^4`` contraction;
- the magnet's orders 2 and 3 act through the single point ``xi1``: with
  ``y = w(xi1) = s . b``, ``f_i = -s_i (gamma2 y^2 + gamma3 y^3)``
  (:class:`contin.model.elements.point_polynomial.PointForce`); order 0 is the constant
  force ``F``, order 1 the stiffness term;
- the loads are ``p_s G`` (constant) and ``p_d G cos(w tau)``.

The unknowns are the physical Galerkin coordinates ``b_1..b_n``. The static
equilibrium ``b^0`` under the magnet and ``p_s`` is the mean of every
periodic solution, so the analyses work about it as the paper does (it
solves for ``b^0``, then writes ``b = b^0 + b_bar``); the paper's modal form
(eq. 15-18) is :func:`modal_form`.

The paper's magnet coefficients ``gamma0..3 = 50, 5, 0.313, 0.0156`` are the
expansion of a force inversely proportional to the fourth power of the gap,
``gamma0 / (1 - w/d)^4 = gamma0 (1 + 4 w/d + 10 w^2/d^2 + 20 w^3/d^3 + ...)``,
with the nondimensional gap ``d = 40`` (``4/d = 0.1``, ``10/d^2 = 0.00625``,
``20/d^3 = 3.125e-4``); :func:`magnet_coefficients` gives them for any
strength and gap (the paper varies the pole strength at a fixed gap, which
scales all four).

Damping (effect ``damping``, not in the paper): ``zeta * diag(j pi)``, the
modal damping ratio ``zeta`` of every mode of the bare string (``beta = 0``,
no magnet), whose modes are the Galerkin shapes with mass 1/2 and
frequency ``j pi``: ``c_j = 2 zeta (j pi)(1/2)``. With the rotor or the magnet
the modes mix and their ratios differ from ``zeta`` somewhat.

Observables: ``w`` at ``xi_obs`` (the paper reads the belt at ``xi = 0.6``)
as the linear observable ``w = sum_j sin(j pi xi_obs) b_j``, with the columns
``amp_w, max_w, min_w, mean_w, rms_w, h0_w..h5_w`` and ``w_rms``, the
paper's eq. 21: the RMS of the vibration about the mean (the static
deflection), ``sqrt(1/2 sum_m |c_m|^2)`` over the harmonics ``m >= 1``.

``terms`` (n), ``xi1`` and ``xi_obs`` fix the model's matrices and shapes:
they are structural (:attr:`contin.model.base.Model.structural`), set when the
model is built and never continued.
"""

from __future__ import annotations

import math

import numpy as np

from contin.model.catalog import ModelSpec, register_model
from contin.model.elements import HarmonicExcitation, PointForce, StringStretchingForce
from contin.model.base import Model, Monomial, ParametricMatrix

__all__ = ["timing_belt", "shape_values", "load_shape", "galerkin_tensors", "magnet_coefficients",
           "modal_form", "deflection", "observe", "string_mass_frequencies", "PAPER_MAGNET", "OBSERVABLE_COLUMNS"]

#: the paper's magnet (Fig. 8 and 9): gamma0..gamma3
PAPER_MAGNET = (50.0, 5.0, 0.313, 0.0156)

PARAMETERS = {"alpha": 0.005, "beta": 0.2, "xi1": 0.4, "terms": 5.0,
              "gamma0": PAPER_MAGNET[0], "gamma1": PAPER_MAGNET[1], "gamma2": PAPER_MAGNET[2],
              "gamma3": PAPER_MAGNET[3], "p_s": 0.0, "p_d": 2.0, "w": 3.0, "zeta": 0.0, "xi_obs": 0.6}
EFFECTS = {
    "rotor_mass": "rotor of mass ratio beta at xi1 (mass matrix beta s s^T and its share beta s_i of the loads)",
    "stretching": "geometric stiffening (alpha pi^4/8) i^2 b_i sum_k k^2 b_k^2 (tension grows with the stretch)",
    "magnet": "magnetic pull q = gamma0 + gamma1 y + gamma2 y^2 + gamma3 y^3 on the rotor, y = w(xi1)",
    "static_load": "constant lateral acceleration p_s (load p_s G_i)",
    "periodic_load": "periodic lateral acceleration p_d cos(w tau) (load p_d G_i cos(w tau))",
    "damping": "modal damping zeta of the bare string's modes, zeta*diag(j pi) (not in the paper)",
}
#: physical constraints: the stretching coefficient, the rotor's mass ratio (0: no rotor, Fig. 2 starts
#: there), the damping ratio and the frequency mean nothing below zero; the positions lie inside the
#: span; the magnet's coefficients and the loads have either sign
CONSTRAINTS = {"alpha": ("nonnegative", "the stretching coefficient"),
               "beta": ("nonnegative", "the rotor's mass ratio"),
               "terms": ("terms", "Galerkin terms"),
               "xi1": ("position", "the rotor's place on the span"),
               "xi_obs": ("position", "the observation point"),
               "zeta": ("nonnegative", "the modal damping ratio"),
               "w": ("nonnegative", "the excitation frequency")}
DEFAULT_EFFECTS = ("rotor_mass", "stretching", "magnet", "static_load", "periodic_load")
STRUCTURAL = ("terms", "xi1", "xi_obs")
#: columns the model adds to ``branches.csv`` (the displacement at ``xi_obs``)
OBSERVABLE_COLUMNS = ("amp_w", "max_w", "min_w", "mean_w", "rms_w", "w_rms") + tuple(f"h{k}_w" for k in range(6))


def shape_values(n: int, xi) -> np.ndarray:
    """``sin(j pi xi)`` for ``j = 1..n``, exact zeros at nodes.

    Parameters
    ----------
    n : int
    xi : float or ndarray, shape (P,)

    Returns
    -------
    ndarray, shape (n,) or (P, n)
    """
    j = np.arange(1, n + 1)
    s = np.sin(np.multiply.outer(np.asarray(xi, dtype=float), j) * np.pi)
    s[np.abs(s) < 1e-13] = 0.0  # xi1 = 0.4 is a node of sin(5 pi xi): keep that mode exactly decoupled
    return s


def load_shape(n: int, beta: float, xi1: float, rotor: bool = True) -> np.ndarray:
    """``G_i = (1 - (-1)^i)/(i pi) + beta s_i`` (eq. 13), shape (n,); without the rotor term if not ``rotor``."""
    i = np.arange(1, n + 1)
    g = (1.0 - (-1.0) ** i) / (i * np.pi)
    return g + beta * shape_values(n, xi1) if rotor else g


def galerkin_tensors(n: int, alpha: float, beta: float, xi1: float, gamma=(0.0, 0.0, 0.0, 0.0)) -> dict:
    """The coefficient tensors of eq. 13, written out in full.

    For checks and for the modal form; the model itself never forms ``D``
    or ``E`` (the ``n^4`` entries of ``E`` are ``O(n)`` structure).

    Returns
    -------
    dict
        ``B, C`` (n, n), ``D`` (n, n, n), ``E`` (n, n, n, n), ``F, G`` (n,).
    """
    g0, g1, g2, g3 = (float(g) for g in gamma)
    i = np.arange(1, n + 1)
    s = shape_values(n, xi1)
    I = np.eye(n)
    B = 0.5 * I + beta * np.outer(s, s)
    C = np.diag(np.pi**2 / 2 * i * i) - g1 * np.outer(s, s)
    D = -g2 * np.einsum("i,j,k->ijk", s, s, s)
    E = (alpha * np.pi**4 / 8) * np.einsum("i,j,k,l,ij,kl->ijkl", i, i, i, i, I, I) \
        - g3 * np.einsum("i,j,k,l->ijkl", s, s, s, s)
    return {"B": B, "C": C, "D": D, "E": E, "F": g0 * s, "G": load_shape(n, beta, xi1)}


def magnet_coefficients(strength: float, gap: float = 40.0) -> tuple:
    """``gamma0..3`` of the pull ``strength / (1 - w/gap)^4`` expanded to third order.

    ``magnet_coefficients(50, 40) = (50, 5, 0.3125, 0.015625)``, the paper's
    values to the printed digits (0.313, 0.0156).
    """
    g = float(strength)
    d = float(gap)
    return (g, 4 * g / d, 10 * g / d**2, 20 * g / d**3)


def string_mass_frequencies(beta: float, xi1: float, count: int) -> np.ndarray:
    """Exact natural frequencies of the taut string with a point mass (no stretching, no magnet).

    ``w'' + omega^2 w = 0`` on both sides of ``xi1`` with ``w(0) = w(1) = 0``,
    continuity at ``xi1`` and the jump ``w'(xi1+) - w'(xi1-) = -beta omega^2
    w(xi1)`` (eq. 7 linearised, tension 1) give the frequency equation

        sin(omega) = beta omega sin(omega xi1) sin(omega (1 - xi1))

    (``cot(omega xi1) + cot(omega (1 - xi1)) = beta omega`` without its
    poles); its roots include the modes with a node at the mass,
    ``omega = j pi`` where ``sin(j pi xi1) = 0``. These are the limits of
    the Galerkin frequencies as ``n`` grows, which lie above them
    (Rayleigh-Ritz).

    Returns
    -------
    ndarray, shape (count,)
        The lowest ``count`` frequencies, ascending.
    """
    from scipy.optimize import brentq

    def f(om):
        return math.sin(om) - beta * om * math.sin(om * xi1) * math.sin(om * (1 - xi1))

    out = []
    grid = np.linspace(1e-6, (count + 2) * math.pi, 4000 * (count + 2))
    vals = np.array([f(o) for o in grid])
    for a, b, fa, fb in zip(grid[:-1], grid[1:], vals[:-1], vals[1:]):
        if fa == 0.0:
            out.append(a)
        elif fa * fb < 0:
            out.append(brentq(f, a, b, xtol=1e-15, rtol=1e-15))
    # the modes with a node at the mass, exactly (the sign-change search finds them too; duplicates go below)
    for j in range(1, count + 3):
        if abs(math.sin(j * math.pi * xi1)) < 1e-12:
            out.append(j * math.pi)
    out = np.sort(np.array(out))
    out = out[out > 1e-3]
    keep = [out[0]] if out.size else []
    for v in out[1:]:
        if v - keep[-1] > 1e-9:
            keep.append(v)
    return np.array(keep[:count])


# ---------------------------------------------------------------- model
def _build(params: dict, effects: tuple) -> Model:
    names = list(params)
    n_float = float(params["terms"])
    if not (n_float >= 1 and n_float == int(n_float) and n_float <= 200):
        raise ValueError(f"model.parameters.terms: expected an integer from 1 to 200 (Galerkin terms), "
                         f"found {params['terms']!r}")
    n = int(n_float)
    xi1, xi_obs = float(params["xi1"]), float(params["xi_obs"])
    for key, v in (("xi1", xi1), ("xi_obs", xi_obs)):
        if not 0.0 < v < 1.0:
            raise ValueError(f"model.parameters.{key}: expected a position strictly between 0 and 1, found {v}")
    j = np.arange(1, n + 1)
    s = shape_values(n, xi1)
    ss = np.outer(s, s)
    g_belt = load_shape(n, 0.0, xi1, rotor=False)

    def mono(text):
        return Monomial.parse(text, names, "timing_belt")

    mass = [(Monomial(1.0), 0.5 * np.eye(n))]
    stiff = [(Monomial(1.0), np.diag(np.pi**2 / 2 * j * j))]
    damp = []
    forces, excitations = [], []
    terms = [f"n = {n} Galerkin terms sin(j pi xi); B b'' + C b (frequency domain): string 1/2 and (pi^2/2) j^2"]
    if "rotor_mass" in effects:
        mass.append((mono("beta"), ss))
        terms.append(f"rotor: beta s s^T in B, s = sin(j pi xi1), xi1 = {xi1:g}")
    if "damping" in effects:
        damp.append((mono("zeta"), np.diag(np.pi * j)))
        terms.append("modal damping zeta*diag(j pi) (frequency domain)")
    if "stretching" in effects:
        forces.append(StringStretchingForce(j * j, Monomial(np.pi**4 / 8, mono("alpha").powers), label="stretching"))
    if "magnet" in effects:
        stiff.append((Monomial(-1.0, mono("gamma1").powers), ss))
        terms.append("magnet order 1: -gamma1 s s^T in C (frequency domain)")
        forces.append(PointForce(s, [(2, Monomial(-1.0, mono("gamma2").powers)),
                                     (3, Monomial(-1.0, mono("gamma3").powers))], label="magnet"))
        for i in range(n):
            if s[i] != 0.0:
                excitations.append(HarmonicExcitation(i, Monomial(s[i], mono("gamma0").powers), 0.0, 0.0, "magnet"))

    def loads(amplitude: str, order: float, label: str):
        for i in range(n):
            if g_belt[i] != 0.0:
                excitations.append(HarmonicExcitation(i, Monomial(g_belt[i], mono(amplitude).powers), order, 0.0, label))
            if "rotor_mass" in effects and s[i] != 0.0:
                excitations.append(HarmonicExcitation(i, Monomial(s[i], mono(f"{amplitude}*beta").powers), order, 0.0,
                                                      label))

    if "static_load" in effects:
        loads("p_s", 0.0, "static_load")
    if "periodic_load" in effects:
        loads("p_d", 1.0, "periodic_load")
    c_obs = shape_values(n, xi_obs)
    model = Model(
        name="timing_belt",
        dof_names=tuple(f"b{k}" for k in j),
        parameters=dict(params),
        mass=ParametricMatrix(n, tuple(mass)),
        damping=ParametricMatrix(n, tuple(damp)),
        stiffness=ParametricMatrix(n, tuple(stiff)),
        forces=forces,
        excitations=excitations,
        effects=tuple(effects),
        terms=terms,
        linear_observables={"w": c_obs},
        structural=STRUCTURAL,
        # the frequency w and the displacement w share a name: figures write Omega for the first,
        # "w at xi = 0.6" for the second (rms_w reads "RMS of w at xi = 0.6")
        symbols={"parameter:w": r"\Omega", "w": rf"$w$ at $\xi = {xi_obs:g}$", "xi_obs": r"\xi_{\mathrm{obs}}"},
    )
    model.observables = lambda u, n_dof, nu: observe(u, c_obs)
    model.observable_names = OBSERVABLE_COLUMNS
    model.start = _start
    return model


def observe(u: np.ndarray, c: np.ndarray) -> dict:
    """The columns of :data:`OBSERVABLE_COLUMNS` for the displacement ``w = c . b``.

    Parameters
    ----------
    u : ndarray, shape (n(2H+1),)
        Harmonic coefficients (ordering of :mod:`contin.hb.harmonics`).
    c : ndarray, shape (n,)
        ``sin(j pi xi_obs)``.
    """
    from contin.hb.measures import point_measures

    c = np.asarray(c, dtype=float)
    Y = np.asarray(u).reshape(-1, c.size) @ c
    H = (Y.size - 1) // 2
    m = point_measures(Y, 1, ["w"], 5)
    out = {k: m.get(k) for k in OBSERVABLE_COLUMNS}
    out["mean_w"] = float(Y[0])
    out["w_rms"] = m["rms_w"]  # eq. 21: sqrt(1/2 sum_{m>=1} |c_m|^2), the vibration about the mean
    for k in range(6):
        out[f"h{k}_w"] = m.get(f"h{k}_w") if k <= H else None
    return out


def deflection(b: np.ndarray, xi) -> np.ndarray:
    """``w(xi) = sum_j b_j sin(j pi xi)`` (eq. 10) for coefficients ``b`` (n,) or (K, n)."""
    b = np.asarray(b, dtype=float)
    return b @ shape_values(b.shape[-1], xi).T


def _start(hb, lam0: float):
    """Start of a forced response: static equilibrium plus the linear response about it.

    For a subharmonic order ``nu > 1`` the free vibration of the mode whose
    backbone reaches ``w/nu`` is added (:func:`contin.bifurcation.backbone.subharmonic_guess`,
    trying modes 1, 2, ... until one converges to a subharmonic solution).
    """
    from contin.bifurcation.backbone import subharmonic_guess
    from contin.modal.equilibrium import ModalError, static_equilibrium
    from contin.bifurcation.start import HomotopyFailed

    params = dict(zip(hb.model.param_names, hb.params_at(lam0)))
    try:
        x0 = static_equilibrium(hb.model, params)
    except ModalError as exc:
        raise HomotopyFailed(str(exc)) from None
    if hb.nu > 1 and hb.frequency_moves:
        errors = []
        for mode in range(1, min(hb.n, 3) + 1):
            try:
                return subharmonic_guess(hb, lam0, mode)
            except ModalError as exc:
                errors.append(f"mode {mode}: {exc}")
        raise HomotopyFailed("no subharmonic start: " + "; ".join(errors))
    U = np.zeros((2 * hb.H + 1, hb.n))
    U[0] = x0
    u = U.reshape(-1)
    R, J, _ = hb.linearize(u, lam0)
    try:
        du = np.linalg.solve(J, -R)
    except np.linalg.LinAlgError:
        return u
    return u + du if np.all(np.isfinite(du)) else u


def modal_form(params: dict | None = None, b0: np.ndarray | None = None, effects=DEFAULT_EFFECTS) -> dict:
    """The paper's modal equations about the static equilibrium (eq. 15-18).

    ``b = b0 + sum_i phi_i b_bar_i / n_i`` turns eq. 12 into

        b_bar_i'' + omega_i^2 b_bar_i + sum D_bar_ijk b_bar_j b_bar_k + sum E_bar_ijkl b_bar_j b_bar_k b_bar_l
            = p_d G_bar_i cos(w tau),

    with ``phi`` the mass-normalised eigenvectors of the tangent stiffness
    (so the modal mass is 1), ``D_bar_pqr = D_pqr + sum_s (E_pqrs + E_prsq +
    E_psqr) b0_s`` in Galerkin coordinates, then
    ``D_bar_ijk = n_i/(n_j n_k) D_bar_pqr phi_pi phi_qj phi_rk``,
    ``E_bar_ijkl = n_i/(n_j n_k n_l) E_pqrs phi_pi phi_qj phi_rk phi_sl``,
    ``G_bar_i = n_i G_p phi_pi``. ``n_i`` scales each mode shape
    ``zeta_bar_i(xi) = sum_p phi_pi sin(p pi xi) / n_i`` to a largest
    displacement of 1 (the paper's Fig. 3), positive where it is largest.

    Parameters
    ----------
    params : dict, optional
        Overrides of the default parameters.
    b0 : ndarray, shape (n,), optional
        The static equilibrium (solved here if not given).
    effects : sequence of str
        ``magnet``, ``rotor_mass`` and ``stretching`` switch their terms.

    Returns
    -------
    dict
        ``omega`` (n,), ``phi`` (n, n), ``norm`` (n,) = ``n_i``, ``D`` (n, n, n),
        ``E`` (n, n, n, n), ``G`` (n,), ``b0`` (n,), ``shapes(xi)`` callable
        giving ``zeta_bar_i(xi)`` (P, n).
    """
    from contin.modal.static_path import linear_modes

    p = dict(PARAMETERS)
    p.update(params or {})
    eff = tuple(e for e in effects if e not in ("periodic_load", "damping"))
    model = timing_belt.build(p, eff)
    n = model.n_dof
    omega, phi, b0 = linear_modes(model, None, b0)
    gam = tuple(p[f"gamma{k}"] for k in range(4)) if "magnet" in eff else (0.0,) * 4
    T = galerkin_tensors(n, p["alpha"] if "stretching" in eff else 0.0,
                         p["beta"] if "rotor_mass" in eff else 0.0, p["xi1"], gam)
    Dq = T["D"] + np.einsum("pqrs,s->pqr", T["E"], b0) + np.einsum("prsq,s->pqr", T["E"], b0) \
        + np.einsum("psqr,s->pqr", T["E"], b0)
    xi = np.linspace(0.0, 1.0, 2001)
    Z = shape_values(n, xi) @ phi  # (P, n): unnormalised shapes
    imax = np.argmax(np.abs(Z), axis=0)
    norm = Z[imax, np.arange(n)]  # n_i: signed largest value -> shapes peak at +1
    inv = 1.0 / norm
    Dbar = np.einsum("i,j,k,pqr,pi,qj,rk->ijk", norm, inv, inv, Dq, phi, phi, phi, optimize=True)
    Ebar = np.einsum("i,j,k,l,pqrs,pi,qj,rk,sl->ijkl", norm, inv, inv, inv, T["E"], phi, phi, phi, phi, optimize=True)
    Gbar = norm * (T["G"] @ phi)

    def shapes(x):
        return shape_values(n, x) @ phi * inv

    return {"omega": omega, "phi": phi, "norm": norm, "D": Dbar, "E": Ebar, "G": Gbar, "b0": b0, "shapes": shapes}


timing_belt = register_model(
    ModelSpec(
        name="timing_belt",
        summary="timing belt with a rotor pulled by a magnet, n Galerkin string modes (Nagai et al. 1993)",
        parameters=PARAMETERS,
        effects=EFFECTS,
        default_effects=DEFAULT_EFFECTS,
        builder=_build,
        constraints=CONSTRAINTS,
    )
)
