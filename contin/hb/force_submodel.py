"""The nonlinear forces of a model on the dofs they act on, as a harmonic-balance problem of those dofs alone.

The condensed problem (:mod:`contin.hb.condensation`) needs the forces and
their Jacobian on the kept dofs only. Evaluated on the full model, every
sampled array has the full model's size (``(N, n, n)`` Jacobians of a
finite-element rotor with hundreds of dofs); on the model of the kept dofs
(its matrices zero, no excitation, each element moved by
:meth:`contin.model.base.ForceElement.remapped`) they have the size of the
contact's dofs.
"""

from __future__ import annotations

import dataclasses

from contin.hb.problem import HarmonicBalance
from contin.model.base import Model, ParametricMatrix

__all__ = ["force_submodel_problem"]


def force_submodel_problem(hb: HarmonicBalance, kept) -> HarmonicBalance | None:
    """The problem of ``hb``'s forces on the dofs ``kept`` alone, or None if an element cannot be moved.

    Parameters
    ----------
    hb : HarmonicBalance
    kept : sequence of int, sorted
        Every dof a force element acts on or depends on is among them.

    Returns
    -------
    HarmonicBalance or None
        Its residual is the forces' coefficients on ``kept`` (in their order),
        its Jacobian their derivatives; the sample count is ``hb``'s.
    """
    kept = tuple(int(i) for i in kept)
    forces = [el.remapped(kept) for el in hb.model.forces]
    if not forces or any(el is None for el in forces):
        return None
    m = hb.model
    n = len(kept)
    sub = Model(name=f"{m.name} (forces on {len(kept)} dofs)", dof_names=tuple(m.dof_names[i] for i in kept),
                parameters=dict(m.parameters), mass=ParametricMatrix(n), damping=ParametricMatrix(n),
                stiffness=ParametricMatrix(n), forces=forces, frequency=m.frequency, min_samples=m.min_samples)
    return HarmonicBalance(sub, hb.parameter, dataclasses.replace(hb.options, samples=hb.N), hb.parameters(),
                           hb.frequency)
