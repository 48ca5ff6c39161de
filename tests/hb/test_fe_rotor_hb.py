"""Harmonic balance of a finite-element rotor with its clearance contact against time simulation of the full model.

The seed-001 test rig from ROSS (76 lateral dofs, ``scenes/data/rig_001.npz``), its harmonic solution found on
the problem condensed onto the contact node and expanded to every dof: the full model (no reduction, no
condensation) integrated by RK4 from the HB state over one period stays on the HB orbit at every dof.
"""

from pathlib import Path

import numpy as np
import pytest

from contin.bifurcation.start import contact_start
from contin.hb.condensation import condense
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.model.fem.builder import fe_rotor_model
from contin.model.fem.matrices import load_matrices
from contin.model.fem.rig import rig_items
from contin.stability.saltation import orbit_state
from contin.timedomain.simulation import simulate

RIG = Path(__file__).resolve().parents[2] / "scenes" / "data" / "rig_001.npz"


@pytest.fixture(scope="module")
def solution():
    model = fe_rotor_model(load_matrices(RIG), **rig_items())
    w = 1.6
    hb = HarmonicBalance(model, "w", HBOptions(harmonics=24, subharmonic=1, crossings="interval", samples=512),
                         {"w": w})
    u = contact_start(hb, w)
    return model, hb, u, w


def test_condensed_solution_solves_the_full_problem(solution):
    model, hb, u, w = solution
    R = hb.residual(u, w)  # the full residual, every dof and harmonic
    assert np.abs(R).max() < 1e-8
    cond = condense(hb, require=True)
    assert cond.dof_names == ["x_18", "y_18"] and cond.size == 2 * 49
    _, J, _ = cond.linearize(cond.restrict(u), w)
    h = 1e-7
    uc = cond.restrict(u)
    for j in (0, 3, 40):  # columns of the condensed Jacobian against finite differences
        e = np.zeros(uc.size)
        e[j] = h
        fd = (cond.residual(uc + e, w) - cond.residual(uc - e, w)) / (2 * h)
        assert np.abs(J[:, j] - fd).max() < 1e-5 * np.abs(J).max()


def test_full_model_simulated_from_the_hb_state_stays_on_its_orbit(solution):
    model, hb, u, w = solution
    S = 16384  # above RK4's limit for the shaft's stiffest element mode (about 8700 per period here)
    n = model.n_dof
    start = orbit_state(hb, u, w, 0.0)
    sim = simulate(model, {"w": w}, start[:n], start[n:], periods=1.0, steps_per_period=S, record_every=S // 64)
    hb_x = orbit_state(hb, u, w, sim.t)[:, :n]
    scale = np.abs(hb_x).max(axis=0)
    for name in ("x_18", "y_18", "x_11", "y_11", "x_5"):
        i = model.dof_index(name)
        err = np.abs(sim.x[:, i] - hb_x[:, i]).max() / scale[i]
        assert err < 2e-3, (name, err)
    # after one period the simulated state is back where it started (the orbit is periodic)
    assert np.abs(sim.x[-1] - start[:n]).max() < 2e-3 * np.abs(hb_x).max()
