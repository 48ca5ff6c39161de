"""A generic polynomial multi-degree-of-freedom model.

    M x'' + C x' + K x + sum_t c_t(p) prod_i x_i^e_ti xdot_i^d_ti = sum_r A_r(p) cos(o_r tau + phi_r)

Matrix entries, coefficients and amplitudes are numbers or products of
parameters such as ``"-0.5*k*w**2"`` (:class:`contin.model.base.Monomial`).
"""

from __future__ import annotations

from typing import Mapping, Sequence

import numpy as np

from contin.model.elements import HarmonicExcitation, PolynomialForce
from contin.model.base import Model, Monomial, ParametricMatrix
from contin.util.naming import suggest

__all__ = ["polynomial_model"]


def _exponents(spec: Mapping, dofs: Sequence[str], where: str) -> list[int]:
    out = [0] * len(dofs)
    for name, e in (spec or {}).items():
        if name not in dofs:
            raise ValueError(f"{where}: unknown degree of freedom '{name}'{suggest(name, dofs)}; expected one of {list(dofs)}")
        if isinstance(e, bool) or not isinstance(e, (int, np.integer)) or e < 0:
            raise ValueError(f"{where}.{name}: expected a non-negative integer exponent, found {e!r}")
        out[dofs.index(name)] = int(e)
    return out


def polynomial_model(
    dofs: Sequence[str],
    parameters: Mapping[str, float],
    mass,
    damping=None,
    stiffness=None,
    nonlinear: Sequence[Mapping] = (),
    forcing: Sequence[Mapping] = (),
    frequency: str = "w",
    name: str = "polynomial",
    effects: tuple = (),
    terms: list | None = None,
) -> Model:
    """Build a polynomial model.

    Parameters
    ----------
    dofs : sequence of str, length n
    parameters : dict
        Names to values; must contain ``frequency``.
    mass, damping, stiffness : nested lists (n, n)
        Numbers or parameter products; ``damping``/``stiffness`` default to zero.
    nonlinear : list of dict
        ``{"dof": name, "coef": monomial, "x": {dof: power}, "v": {dof: power},
        "order": o, "phase": phi}``: adds
        ``coef * cos(o tau + phi) * prod x^power * prod xdot^power`` (no cosine
        factor when ``o = 0``, the default) to the left-hand side of the
        equation of ``dof``.
    forcing : list of dict
        ``{"dof": name, "amplitude": monomial, "order": 1, "phase": 0}``:
        adds ``amplitude*cos(order*tau + phase)`` to the right-hand side.
    frequency : str
        The excitation-frequency parameter.
    """
    dofs = list(dofs)
    n = len(dofs)
    names = list(parameters)
    zero = [[0.0] * n for _ in range(n)]
    M = ParametricMatrix.from_entries(mass, names, "model.mass")
    C = ParametricMatrix.from_entries(damping if damping is not None else zero, names, "model.damping")
    K = ParametricMatrix.from_entries(stiffness if stiffness is not None else zero, names, "model.stiffness")
    for label, mat in (("mass", M), ("damping", C), ("stiffness", K)):
        if mat.n != n:
            raise ValueError(f"model.{label}: expected a {n}x{n} matrix for dofs {dofs}, found {mat.n}x{mat.n}")
    forces = []
    poly_terms = []
    for i, t in enumerate(nonlinear):
        where = f"model.nonlinear[{i}]"
        if t.get("dof") not in dofs:
            raise ValueError(f"{where}.dof: unknown degree of freedom {t.get('dof')!r}; expected one of {dofs}")
        poly_terms.append(
            (
                dofs.index(t["dof"]),
                Monomial.parse(t.get("coef", 1.0), names, f"{where}.coef"),
                _exponents(t.get("x"), dofs, f"{where}.x"),
                _exponents(t.get("v"), dofs, f"{where}.v"),
                float(t.get("order", 0.0)),
                float(t.get("phase", 0.0)),
            )
        )
    if poly_terms:
        forces.append(PolynomialForce(n, poly_terms))
    excitations = []
    for i, fo in enumerate(forcing):
        where = f"model.forcing[{i}]"
        if fo.get("dof") not in dofs:
            raise ValueError(f"{where}.dof: unknown degree of freedom {fo.get('dof')!r}; expected one of {dofs}")
        excitations.append(
            HarmonicExcitation(
                dofs.index(fo["dof"]),
                Monomial.parse(fo.get("amplitude", 1.0), names, f"{where}.amplitude"),
                float(fo.get("order", 1.0)),
                float(fo.get("phase", 0.0)),
            )
        )
    return Model(
        name=name,
        dof_names=tuple(dofs),
        parameters=dict(parameters),
        mass=M,
        damping=C,
        stiffness=K,
        forces=forces,
        excitations=excitations,
        frequency=frequency,
        effects=tuple(effects),
        terms=list(terms or ["M x'' + C x' + K x (frequency domain)"]),
    )
