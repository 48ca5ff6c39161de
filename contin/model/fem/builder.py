"""A :class:`contin.model.base.Model` of a finite-element rotor with a clearance contact at a node.

The rotor's lateral matrices (:class:`~contin.model.fem.matrices.RotorMatrices`,
SI) are scaled to the units of :class:`Units` as the paper scales its reduced
model (Inagaki, Ishida & Hayashi 2005, eq. 10): lengths by ``L``, time by
``1/w0``, forces by ``m L w0^2``. With ``D`` the diagonal of ``L`` on the
translations and 1 on the rotations (which stay in radians),

    M~ = D M D / (m L^2),   C~ = D C D / (m L^2 w0),   K~ = D K D / (m L^2 w0^2),   G~ = D G D / (m L^2),

and ``w = Omega / w0`` multiplies ``G~``. The model's parameters are

========  ===================================================================
``w``     speed ``Omega / w0``
``e``     unbalance of the first item, ``m_u e_u / (m L)``; further items keep
          their ratio to it (force ``e w^2 (cos, sin)(w t + phase)``, ROSS's sense)
``f0``    side load ``|F| / (m L w0^2)`` along the item's direction
``delta`` radial clearance ``/ L``
``kbn``   contact stiffness ``/ (m w0^2)``
``cbn``   contact damping ``/ (m w0)``
========  ===================================================================

(each only with its item). Bearing coefficients are B-splines of the speed
(:mod:`contin.model.fem.coefficients`); a constant one is summed into the
constant matrices. With :class:`Reduction` the model is the Craig-Bampton
reduction (:mod:`contin.model.fem.reduction`) onto the contact, unbalance and
side-load nodes' ``(x, y)`` and some fixed-interface modes; without, it keeps
every lateral dof (and the harmonic balance condenses them exactly onto the
contact, :mod:`contin.hb.condensation`).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sl

from contin.model.base import Model, Monomial, ParametricMatrix
from contin.model.elements import GapForce, HarmonicExcitation, RadialGapForce
from contin.model.fem.coefficients import SplineCoefficient
from contin.model.fem.matrices import RotorMatrices
from contin.model.fem.reduction import craig_bampton
from contin.model.whirl import WHIRL_COLUMNS, WHIRL_SYMBOLS, whirl_radii

__all__ = ["SPEED", "Units", "Contact", "Unbalance", "SideLoad", "Reduction", "fe_rotor_model", "FEInfo"]

#: the model's speed parameter ``Omega / w0``: its excitation frequency (``tau = w t``) and the
#: continuation parameter a scene of a rotor defaults to (:func:`contin.scene.parse.model_frequency`)
SPEED = "w"


def _positive(owner: str, name: str, v, allow_zero=False):
    ok = isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) and (v >= 0 if allow_zero else v > 0)
    if not ok:
        raise ValueError(f"{owner}.{name}: expected a finite number {'>= 0' if allow_zero else '> 0'}, found {v!r}")


def _node(owner: str, v):
    if not (isinstance(v, int) and not isinstance(v, bool) and v >= 0):
        raise ValueError(f"{owner}.node: expected a node number (integer >= 0), found {v!r}")


@dataclass(frozen=True)
class Units:
    """Units of the model: ``length`` [m], ``mass`` [kg], ``frequency`` [rad/s].

    None: ``mass`` the heaviest disc (else the rotor's mass), ``frequency``
    the lowest natural frequency at rest with the contact node held.
    ``Units(1.0, 1.0, 1.0)`` keeps SI.
    """

    length: float = 1e-3
    mass: float | None = None
    frequency: float | None = None

    def __post_init__(self):
        _positive("units", "length", self.length)
        for k in ("mass", "frequency"):
            if getattr(self, k) is not None:
                _positive("units", k, getattr(self, k))


@dataclass(frozen=True)
class Contact:
    """The clearance contact at ``node``: SI values.

    ``type`` ``radial_gap``: a circular clearance of the node's ``(x, y)``
    (:class:`contin.model.elements.RadialGapForce`, the rotor paper's eq. 3);
    ``gap``: a clearance along one direction ``x`` or ``y`` on ``sides``
    ``both``, ``+`` or ``-`` (:class:`contin.model.elements.GapForce`).
    """

    node: int
    clearance: float
    stiffness: float
    damping: float = 0.0
    clip: bool = False
    type: str = "radial_gap"
    direction: str = "y"
    sides: str = "both"

    def __post_init__(self):
        _node("contact", self.node)
        if self.type not in ("radial_gap", "gap"):
            raise ValueError(f"contact.type: expected 'radial_gap' or 'gap', found {self.type!r}")
        if self.direction not in ("x", "y"):
            raise ValueError(f"contact.direction: expected 'x' or 'y', found {self.direction!r}")
        if self.sides not in ("both", "+", "-"):
            raise ValueError(f"contact.sides: expected 'both', '+' or '-', found {self.sides!r}")
        _positive("contact", "clearance", self.clearance, allow_zero=True)
        _positive("contact", "stiffness", self.stiffness)
        _positive("contact", "damping", self.damping, allow_zero=True)
        if not isinstance(self.clip, bool):
            raise ValueError(f"contact.clip: expected true or false, found {self.clip!r}")


@dataclass(frozen=True)
class Unbalance:
    """``magnitude`` [kg m] at ``node``, ``phase`` [rad] (ROSS's ``run_unbalance_response`` arguments)."""

    node: int
    magnitude: float
    phase: float = 0.0

    def __post_init__(self):
        _node("unbalance", self.node)
        _positive("unbalance", "magnitude", self.magnitude)
        if not (isinstance(self.phase, (int, float)) and math.isfinite(self.phase)):
            raise ValueError(f"unbalance.phase: expected a finite number (rad), found {self.phase!r}")


@dataclass(frozen=True)
class SideLoad:
    """A constant force ``(fx, fy)`` [N] at ``node`` (the paper's ``f0`` from the coupling)."""

    node: int
    force: tuple = (0.0, 0.0)

    def __post_init__(self):
        _node("side_load", self.node)
        f = tuple(self.force)
        if len(f) != 2 or not all(isinstance(v, (int, float)) and math.isfinite(v) for v in f) or f == (0, 0):
            raise ValueError(f"side_load.force: expected [fx, fy] in N, not both zero, found {self.force!r}")


@dataclass(frozen=True)
class Reduction:
    """Craig-Bampton reduction with ``modes`` fixed-interface modes, built at ``speed`` [rad/s]."""

    modes: int
    speed: float = 0.0

    def __post_init__(self):
        if not (isinstance(self.modes, int) and not isinstance(self.modes, bool) and self.modes >= 0):
            raise ValueError(f"reduction.modes: expected an integer >= 0, found {self.modes!r}")
        _positive("reduction", "speed", self.speed, allow_zero=True)


@dataclass(frozen=True)
class FEInfo:
    """What the model was built from: its units, its basis and where the physical dofs went.

    Attributes
    ----------
    units : Units
        With ``mass`` and ``frequency`` resolved.
    basis : ndarray, shape (n_physical, n_model) or None
        ``x = basis q`` in model units (None: no reduction).
    interior_frequencies : ndarray
        Fixed-interface modes kept [model time units].
    physical_dofs : tuple of str
        The rotor's lateral dof names.
    """

    units: Units
    basis: np.ndarray | None = None
    interior_frequencies: np.ndarray = field(default_factory=lambda: np.zeros(0))
    physical_dofs: tuple = ()
    scale: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def physical(self, X: np.ndarray) -> np.ndarray:
        """Model coordinates ``(..., n_model)`` to SI ``(..., n_physical)`` (m, rad)."""
        X = np.asarray(X)
        if self.basis is not None:
            X = X @ self.basis.T
        return X * self.scale


def _heaviest(rotor: RotorMatrices) -> float:
    if rotor.discs.size:
        return float(rotor.discs[:, 1].max())
    return float(np.trace(rotor.mass[0::4, 0::4]))


def _lowest_frequency(M, K, held) -> float:
    keep = np.setdiff1d(np.arange(M.shape[0]), np.asarray(held, dtype=int))
    Ks, Ms = 0.5 * (K + K.T)[np.ix_(keep, keep)], 0.5 * (M + M.T)[np.ix_(keep, keep)]
    w2 = sl.eigh(Ks, Ms, eigvals_only=True, subset_by_index=[0, min(5, keep.size - 1)])
    pos = w2[w2 > 1e-9 * max(abs(w2[-1]), 1e-300)]
    if not pos.size:
        raise ValueError("units.frequency: the rotor has no natural frequency at rest to scale time by; give one")
    return float(np.sqrt(pos[0]))


def fe_rotor_model(rotor: RotorMatrices, contact: Contact | None = None, unbalance=(), side_load: SideLoad | None = None,
                   units: Units = Units(), reduction: Reduction | None = None, speed: float = 0.0,
                   name: str = "fe_rotor") -> Model:
    """The model of a finite-element rotor (see the module docstring for its units and parameters).

    Parameters
    ----------
    rotor : RotorMatrices
    contact : Contact, optional
    unbalance : sequence of Unbalance
    side_load : SideLoad, optional
    units : Units
    reduction : Reduction, optional
    speed : float
        Initial value of the speed parameter ``w`` (model units).
    name : str

    Returns
    -------
    Model
        With ``model.fe`` an :class:`FEInfo`.

    Raises
    ------
    ValueError
        Naming the item: a node off the rotor, a contact at a bearing node
        (its coefficients would act beside the clearance), ...
    """
    unbalance = tuple(unbalance)
    for item, what in [(contact, "contact"), (side_load, "side_load")] + [(u, f"unbalance[{i}]") for i, u in
                                                                          enumerate(unbalance)]:
        if item is not None and item.node >= rotor.n_nodes:
            raise ValueError(f"{what}.node: expected a node in 0..{rotor.n_nodes - 1}, found {item.node}")
    if contact is not None:
        axes = "xy" if contact.type == "radial_gap" else contact.direction
        if any(b.node == contact.node and any(k[0] == "k" and (k[1] in axes or k[2] in axes) for k in b.splines)
               for b in rotor.bearings):
            raise ValueError(f"contact.node: node {contact.node} has a bearing stiffness along the contact's "
                             f"{' and '.join(axes)}; the clearance contact replaces that bearing, so the rotor file "
                             "must have none there (a mass or damping is fine)")
    n = rotor.n_dof
    Mb0, Cb0, Kb0 = rotor.bearing_matrices(0.0)
    held = rotor.node_dofs(contact.node) if contact is not None else ()
    m_ref = units.mass if units.mass is not None else _heaviest(rotor)
    w0 = units.frequency if units.frequency is not None else _lowest_frequency(rotor.mass + Mb0, rotor.stiffness + Kb0,
                                                                                held)
    L = units.length
    units = Units(L, m_ref, w0)
    d = np.where(np.arange(n) % 4 < 2, L, 1.0)
    DD = np.outer(d, d) / (m_ref * L * L)
    params = {SPEED: float(speed)}
    if unbalance:
        params["e"] = unbalance[0].magnitude / (m_ref * L)
    if side_load is not None:
        params["f0"] = float(np.hypot(*side_load.force)) / (m_ref * L * w0 * w0)
    if contact is not None:
        params.update(delta=contact.clearance / L, kbn=contact.stiffness / (m_ref * w0 * w0),
                      cbn=contact.damping / (m_ref * w0))
    names = list(params)
    iw = names.index(SPEED)
    one = Monomial(1.0)
    mats = {"m": [DD * rotor.mass], "c": [DD * rotor.damping / w0], "k": [DD * rotor.stiffness / w0**2]}
    varying = {"m": [], "c": [(Monomial(1.0, ((iw, 1),)), DD * rotor.gyroscopic)], "k": []}
    scale = {"m": 1.0 / m_ref, "c": 1.0 / (m_ref * w0), "k": 1.0 / (m_ref * w0 * w0)}
    for b in rotor.bearings:
        idx = rotor.node_dofs(b.node)
        for cname, (t, c, k) in b.splines.items():
            kind, r, s = cname[0], idx["xy".index(cname[1])], idx["xy".index(cname[2])]
            A = np.zeros((n, n))
            A[r, s] = 1.0
            if k == 0:
                mats[kind].append(scale[kind] * float(c[0]) * A)
            else:
                varying[kind].append((SplineCoefficient(iw, t, c, k, scale[kind], w0, f"{cname} of bearing at node "
                                                        f"{b.node}"), A))
    terms = {kind: [(one, sum(mats[kind]))] + varying[kind] for kind in "mck"}
    dofs = list(rotor.dof_names)
    boundary: list = []
    for item in (contact, side_load, *unbalance):
        if item is not None:
            boundary += [i for i in rotor.node_dofs(item.node) if i not in boundary]
    basis, freqs = None, np.zeros(0)
    if reduction is not None:
        if not boundary:
            raise ValueError("reduction: needs a contact, unbalance or side load: their nodes are the boundary")
        p_r = np.array([reduction.speed / w0] + [0.0] * (len(names) - 1))
        Mr = sum(c.value(p_r) * A for c, A in terms["m"])
        Kr = sum(c.value(p_r) * A for c, A in terms["k"])
        basis, freqs = craig_bampton(Mr, Kr, boundary, reduction.modes)
        terms = {kind: [(c, basis.T @ A @ basis) for c, A in terms[kind]] for kind in "mck"}
        dofs = [dofs[i] for i in boundary] + [f"q_{j + 1}" for j in range(reduction.modes)]
        where = {g: j for j, g in enumerate(boundary)}
    else:
        where = {g: g for g in range(n)}
    nm = len(dofs)
    forces, excitations, text = [], [], [f"finite-element rotor ({rotor.n_nodes} nodes, {n} lateral dofs) from "
                                         f"{rotor.source or 'matrices'}; units L={L:g} m, m={m_ref:g} kg, "
                                         f"w0={w0:g} rad/s"]
    if reduction is not None:
        text.append(f"Craig-Bampton reduction onto {len(boundary)} boundary dofs and {reduction.modes} modes")
    text.append("M x'' + (C + sum C_b(w) + w G) x' + (K + sum K_b(w)) x (frequency domain)")

    def mono(pname, const=1.0, extra=()):
        return Monomial(const, ((names.index(pname), 1),) + extra)

    if contact is not None:
        ix, iy = (where[i] for i in rotor.node_dofs(contact.node))
        damping = mono("cbn") if contact.damping > 0 else Monomial(0.0)
        if contact.type == "radial_gap":
            forces.append(RadialGapForce((ix, iy), mono("delta"), mono("kbn"), damping, clip=contact.clip,
                                         label="contact"))
        else:
            forces.append(GapForce(ix if contact.direction == "x" else iy, mono("delta"), mono("kbn"), damping,
                                   sides=contact.sides, clip=contact.clip, label="contact"))
    for u in unbalance:
        ix, iy = (where[i] for i in rotor.node_dofs(u.node))
        amp = mono("e", u.magnitude / unbalance[0].magnitude, ((iw, 2),))
        excitations.append(HarmonicExcitation(ix, amp, 1.0, u.phase, "unbalance"))
        excitations.append(HarmonicExcitation(iy, amp, 1.0, u.phase - math.pi / 2, "unbalance"))
    if side_load is not None:
        ix, iy = (where[i] for i in rotor.node_dofs(side_load.node))
        fx, fy = side_load.force
        r = math.hypot(fx, fy)
        for dof, comp in ((ix, fx), (iy, fy)):
            if comp:
                excitations.append(HarmonicExcitation(dof, mono("f0", comp / r), 0.0, 0.0, "side_load"))
    model = Model(name=name, dof_names=tuple(dofs), parameters=params,
                  mass=ParametricMatrix(nm, tuple(terms["m"])), damping=ParametricMatrix(nm, tuple(terms["c"])),
                  stiffness=ParametricMatrix(nm, tuple(terms["k"])), forces=forces, excitations=excitations,
                  frequency=SPEED,
                  effects=tuple(k for k, v in (("contact", contact), ("unbalance", unbalance),
                                               ("static_force", side_load)) if v), terms=text)
    parts = {}
    disc_node = unbalance[0].node if unbalance else (int(rotor.discs[0, 0]) if rotor.discs.size else None)
    if disc_node is not None and all(i in where for i in rotor.node_dofs(disc_node)):
        parts["disc"] = tuple(where[i] for i in rotor.node_dofs(disc_node))
    if contact is not None:
        parts["bearing"] = tuple(where[i] for i in rotor.node_dofs(contact.node))
    if parts:
        cols = tuple(c for c in WHIRL_COLUMNS if c.rsplit("_", 1)[1] in parts)
        model.observables = functools.partial(whirl_radii, parts=parts)
        model.whirl_parts = dict(parts)
        model.observable_names = cols
    model.symbols = {SPEED: r"\Omega", "kbn": r"k_{bn}", "cbn": r"c_{bn}", "f0": r"f_0", **WHIRL_SYMBOLS}
    model.fe = FEInfo(units, basis, freqs, tuple(rotor.dof_names), d)
    return model
