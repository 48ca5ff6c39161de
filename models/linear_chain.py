"""A linear chain of ``n`` masses between two walls (seed 002, sec. 2.1, 3.1 and 4.1).

    m_i x_i'' = F_i cos(w t) + P_i - c_i (x_i' - x_{i-1}') + c_{i+1} (x_{i+1}' - x_i')
                                   - k_i (x_i - x_{i-1}) + k_{i+1} (x_{i+1} - x_i),   x_0 = x_{n+1} = 0

Spring ``k1`` and damper ``c1`` tie mass 1 to the left wall, ``k_i``, ``c_i``
join masses ``i-1`` and ``i``, and ``k_{n+1}``, ``c_{n+1}`` tie mass ``n`` to the
right wall (0 for a free end). In matrix form ``M x'' + C x' + K x = F cos(w t) + P``
with ``M = diag(m_i)`` and the tridiagonal ``C`` and ``K`` of the seed
(``k11 = k1 + k2, k12 = -k2, k22 = k2 + k3`` for ``n = 2``).

The option ``n`` (default 2) sets the number of masses; the parameters are
then ``m1..mn, k1..k(n+1), c1..c(n+1), F1..Fn, P1..Pn, w``. Two masses cover both
seeds: seed 002's example is ``m1 = m, m2 = 2m, k1 = k2 = k, k3 = 2k``; seed 000's
damped absorber is ``k3 = 0``, ``c1 = c3 = 0`` and ``c2 = c`` (the damper between the
main mass and the absorber). Everything is linear, so the harmonic balance with
``H = 1`` is exactly the impedance solve of :mod:`contin.modal.modes`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

import numpy as np

from contin.model.catalog import ModelSpec, register_model
from contin.model.elements import HarmonicExcitation
from contin.model.base import Model, Monomial, ParametricMatrix
from contin.util.naming import suggest

__all__ = ["linear_chain", "chain_parameters", "chain_constraints", "LinearChainSpec"]

EFFECTS = {
    "damping": "viscous dampers c1..c(n+1) (wall-mass and mass-mass, like the springs)",
    "forcing": "harmonic forces F_i cos(w t) on each mass",
    "static_load": "constant forces P_i on each mass",
}
MAX_MASSES = 200


def chain_parameters(n: int) -> dict:
    """Default parameters of an ``n``-mass chain: unit masses and springs, no damping, F1 = 1."""
    p = {f"m{i}": 1.0 for i in range(1, n + 1)}
    p.update({f"k{i}": 1.0 for i in range(1, n + 2)})
    p.update({f"c{i}": 0.0 for i in range(1, n + 2)})
    p.update({f"F{i}": 1.0 if i == 1 else 0.0 for i in range(1, n + 1)})
    p.update({f"P{i}": 0.0 for i in range(1, n + 1)})
    p["w"] = 1.0
    return p


def chain_constraints(n: int) -> dict:
    """Physical constraints of an ``n``-mass chain: masses > 0, springs and dampers >= 0 (0: no element)."""
    rules = {f"m{i}": ("positive", f"the mass of mass {i}") for i in range(1, n + 1)}
    rules.update({f"k{i}": ("nonnegative", "a spring stiffness (0 for none)") for i in range(1, n + 2)})
    rules.update({f"c{i}": ("nonnegative", "a damper's coefficient (0 for none)") for i in range(1, n + 2)})
    rules["w"] = ("nonnegative", "the excitation frequency")
    return rules


def _chain_matrix(n: int, prefix: str, names) -> ParametricMatrix:
    """Tridiagonal chain matrix of the elements ``prefix1 .. prefix(n+1)`` (parameter-dependent)."""
    terms = []
    for i in range(n + 1):
        mono = Monomial.parse(f"{prefix}{i + 1}", names)
        A = np.zeros((n, n))
        left, right = i - 1, i  # element i+1 joins mass i (or the left wall) and mass i+1 (or the right wall)
        if left >= 0:
            A[left, left] += 1.0
        if right < n:
            A[right, right] += 1.0
        if left >= 0 and right < n:
            A[left, right] = A[right, left] = -1.0
        terms.append((mono, A))
    return ParametricMatrix(n, tuple(terms))


def _build(params: dict, effects: tuple, n: int = 2) -> Model:
    names = list(params)
    M = ParametricMatrix(n, tuple((Monomial.parse(f"m{i + 1}", names), np.diag(np.eye(n)[i])) for i in range(n)))
    K = _chain_matrix(n, "k", names)
    C = _chain_matrix(n, "c", names) if "damping" in effects else ParametricMatrix(n)
    excitations = []
    if "forcing" in effects:
        excitations += [HarmonicExcitation(i, Monomial.parse(f"F{i + 1}", names), 1.0, 0.0, label=f"forcing F{i + 1}")
                        for i in range(n)]
    if "static_load" in effects:
        excitations += [HarmonicExcitation(i, Monomial.parse(f"P{i + 1}", names), 0.0, 0.0, label=f"static load P{i + 1}")
                        for i in range(n)]
    terms = [f"M x'' + K x: {n} masses m1..m{n}, springs k1..k{n + 1} (frequency domain)"]
    if "damping" in effects:
        terms.append(f"C x': dampers c1..c{n + 1} (frequency domain)")
    return Model(
        name="linear_chain",
        dof_names=tuple(f"x{i + 1}" for i in range(n)),
        parameters=dict(params),
        mass=M,
        damping=C,
        stiffness=K,
        excitations=excitations,
        frequency="w",
        effects=tuple(effects),
        terms=terms,
        symbols={"w": r"\Omega"},
    )


@dataclass(frozen=True)
class LinearChainSpec(ModelSpec):
    """The chain's catalogue entry: its parameter list follows the option ``n``."""

    def parameter_constraints(self, options: Mapping | None = None) -> dict:
        n = (options or {}).get("n", self.options["n"])
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or not 1 <= n <= MAX_MASSES:
            return {}  # build() refuses the option
        return chain_constraints(int(n))

    def build(self, parameters: Mapping | None = None, effects=None, **options) -> Model:
        for k in options:
            if k not in self.options:
                raise ValueError(f"model.options.{k}: unknown option of '{self.name}'{suggest(k, self.options)}; "
                                 f"expected one of {list(self.options)}")
        n = options.get("n", self.options["n"])
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or not 1 <= n <= MAX_MASSES:
            raise ValueError(f"model.options.n: expected the number of masses, an integer from 1 to {MAX_MASSES}, "
                             f"found {n!r}")
        spec = ModelSpec(self.name, self.summary, chain_parameters(int(n)), self.effects, self.default_effects,
                         lambda p, e: _build(p, e, int(n)), constraints=chain_constraints(int(n)))
        return spec.build(parameters, effects)


linear_chain = register_model(
    LinearChainSpec(
        name="linear_chain",
        summary="n masses in a chain between two walls (seed 002): M x'' + C x' + K x = F cos(w t) + P; "
                "option n (default 2)",
        parameters=chain_parameters(2),
        effects=EFFECTS,
        default_effects=("damping", "forcing"),
        builder=lambda p, e: _build(p, e, 2),
        options={"n": 2},
        constraints=chain_constraints(2),
    )
)
