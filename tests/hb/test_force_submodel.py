"""Force elements moved onto the dofs they act on (``ForceElement.remapped``) give the same forces there."""

import numpy as np
import pytest

from contin.hb.force_submodel import force_submodel_problem
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.model.base import ForceElement, Model, Monomial, ParametricMatrix
from contin.model.elements import GapForce, PointForce, PolynomialForce, RadialGapForce

N_DOF = 5
KEPT = (1, 3, 4)


def _elements():
    ex = np.zeros(N_DOF, int)
    ev = np.zeros(N_DOF, int)
    ex[3], ev[1] = 2, 1
    return [RadialGapForce((3, 1), Monomial(0.05), Monomial(300.0), Monomial(0.4)),
            GapForce(4, Monomial(0.02), Monomial(500.0), Monomial(0.1), sides="both"),
            PolynomialForce(N_DOF, [(4, Monomial(0.7), ex, ev)]),
            PointForce(np.array([0.0, 0.5, 0.0, -1.0, 0.2]), [(3, Monomial(2.0))])]


def _model(forces):
    eye = ParametricMatrix(N_DOF, ((Monomial(1.0), np.eye(N_DOF)),))
    return Model(name="five", dof_names=tuple(f"x{i}" for i in range(N_DOF)), parameters={"w": 1.3}, mass=eye,
                 damping=eye, stiffness=eye, forces=forces)


@pytest.mark.parametrize("index", range(4))
def test_remapped_element_gives_the_kept_dofs_forces(index, rng):
    el = _elements()[index]
    assert set(el.active_dofs()) <= set(KEPT)
    hb = HarmonicBalance(_model([el]), "w", HBOptions(harmonics=3, samples=64, crossings="none"))
    sub = force_submodel_problem(hb, KEPT)
    U = np.zeros((7, N_DOF))
    U[:, list(KEPT)] = 0.05 * rng.standard_normal((7, len(KEPT)))
    x, xd, _ = hb.samples_of(U.reshape(-1), 1.3)
    full = hb._forces_at(x, xd, hb.params_at(1.3), U.reshape(-1))
    part = sub._forces_at(x[:, KEPT], xd[:, KEPT], sub.params_at(1.3), U[:, KEPT].reshape(-1))
    k = list(KEPT)
    assert np.allclose(full[0][:, k], part[0], rtol=0, atol=1e-14)
    assert np.allclose(full[1][:, k][:, :, k], part[1], rtol=0, atol=1e-14)
    assert np.allclose(full[2][:, k][:, :, k], part[2], rtol=0, atol=1e-14)


def test_an_element_that_cannot_move_keeps_the_full_evaluation():
    class Fixed(RadialGapForce):
        remapped = ForceElement.remapped  # the base class's answer: it cannot be moved

    el = Fixed((3, 1), Monomial(0.05), Monomial(300.0))
    assert el.remapped(KEPT) is None
    hb = HarmonicBalance(_model([el]), "w", HBOptions(harmonics=2, samples=32))
    assert force_submodel_problem(hb, KEPT) is None
