"""The rotating frame of the bearing rotor at f0 = 0 (contin.model.rotating_frame).

Truth: the fixed-frame model's own compiled vector field. A fixed-frame
trajectory ``x = R(w t) zeta`` has ``x' = R (zeta' + w J zeta)`` and
``x'' = R (zeta'' + 2 w J zeta' - w^2 zeta)``; with ``zeta''`` from the
rotating model this must be the fixed model's acceleration at ``(x, x')`` and
phase ``w t``, in and out of contact. Measured: 3e-12 to 3e-11 absolute against
contact forces of order kbn * 0.2 = 2.6e3 (rounding).
"""

import dataclasses

import numpy as np
import pytest

from contin.bifurcation.hopf import EquilibriumProblem
from contin.model.base import Monomial
from contin.model.catalog import build_model
from contin.model.elements.radial_gap import RadialGapForce
from contin.model.rotating_frame import (
    PERIOD_FREQUENCY,
    rotating_frame,
    rotation_generator,
    to_fixed,
    to_rotating,
)
from contin.timedomain.autonomous_shooting import AutonomousShootingProblem
from contin.timedomain.integrator import compile_model


@pytest.fixture(scope="module")
def models():
    fixed = build_model("bearing_rotor", {"f0": 0.0, "e": 0.15})
    return fixed, rotating_frame(fixed)


def test_vector_field_is_the_turned_fixed_frame_field(models):
    fixed, rot = models
    cf, cr = compile_model(fixed), compile_model(rot)
    rng = np.random.default_rng(3)
    J = rotation_generator(4, [(0, 1), (2, 3)])
    for w in (1.7, 2.3):
        pf = fixed.parameter_vector({"w": w})
        pr = rot.parameter_vector({"w": w})
        for _ in range(6):
            zeta = 0.15 * rng.normal(size=8)  # the bearing in and out of its clearance 0.1
            t = 3.0 * rng.random()
            y = to_fixed(rot, zeta, w, t)
            fr = cr.rhs(zeta, 0.0, pr)
            ff = cf.rhs(y, w * t, pf)
            c, s = np.cos(w * t), np.sin(w * t)
            R = np.kron(np.eye(2), np.array([[c, -s], [s, c]]))
            acc = R @ (fr[4:] + 2 * w * J @ zeta[4:] - w * w * zeta[:4])
            scale = max(1.0, float(np.max(np.abs(ff))))
            assert np.max(np.abs(acc - ff[4:])) <= 1e-14 * scale
            assert np.array_equal(y[4:], ff[:4])


def test_frames_map_back_and_forth(models):
    _, rot = models
    Y = np.random.default_rng(1).normal(size=(5, 8))
    t = np.linspace(0.0, 2.0, 5)
    assert np.allclose(to_rotating(rot, to_fixed(rot, Y, 1.9, t), 1.9, t), Y, rtol=0, atol=1e-14)
    # at t = 0 the positions are the same, the velocities differ by w J zeta
    z = to_fixed(rot, Y[0], 1.9, 0.0)
    assert np.array_equal(z[:4], Y[0, :4])
    assert np.allclose(z[4:] - Y[0, 4:], 1.9 * rotation_generator(4, [(0, 1), (2, 3)]) @ Y[0, :4])


def test_model_is_autonomous_and_keeps_the_contact(models):
    fixed, rot = models
    assert rot.frequency == PERIOD_FREQUENCY
    assert rot.forces[0] is fixed.forces[0]
    assert all(el.order == 0.0 for el in rot.excitations)
    assert rot.structural == ("f0",)
    p = rot.parameter_vector({"w": 2.0})
    # constant force e w^2 on x1 only
    f = np.zeros((1, 4))
    for el in rot.excitations:
        el.evaluate(np.zeros(1), p, f)
    assert np.allclose(f[0], [0.15 * 4.0, 0.0, 0.0, 0.0], rtol=0, atol=1e-15)


def test_side_load_is_refused():
    with pytest.raises(ValueError, match=r"static_force.*f0 = 0.5.*breaks the rotational symmetry"):
        rotating_frame(build_model("bearing_rotor", {"f0": 0.5}))


def test_f0_stays_zero(models):
    _, rot = models
    with pytest.raises(ValueError, match="parameter 'f0'.*built into its structure"):
        EquilibriumProblem(rot, "w", {"f0": 0.2})
    with pytest.raises(ValueError, match="parameter 'f0'.*cannot be continued"):
        AutonomousShootingProblem(rot, "f0")


def test_anisotropy_and_foreign_forces_are_refused(models):
    fixed, _ = models
    with pytest.raises(ValueError, match="mass matrix .* not rotationally symmetric"):
        rotating_frame(fixed, pairs=[(0, 2), (1, 3)])
    odd = RadialGapForce((0, 2), Monomial(0.1), Monomial(1e3), label="odd")
    with pytest.raises(ValueError, match="force element 'odd' .* not a radial contact of a rotating dof pair"):
        rotating_frame(dataclasses.replace(fixed, forces=[odd]))
    with pytest.raises(ValueError, match="every dof must belong to a rotating pair"):
        rotating_frame(fixed, pairs=[(0, 1)])
    no_gyro = build_model("bearing_rotor", {"f0": 0.0}, effects=("unbalance", "contact", "disc_damping"))
    assert rotating_frame(no_gyro).n_dof == 4
