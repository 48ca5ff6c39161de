"""A start at many harmonics by a homotopy in H: solved with few, padded with zeros, raised to H."""

import numpy as np
import pytest

from contin.analyses.frequency_response import build_problem
from contin.bifurcation.start import HomotopyFailed, harmonic_start
from contin.engine.newton import solve_at_parameter
from contin.scene.build import build_model
from contin.scene.parse import scene_from_data

#: two masses in a chain, a cubic spring to ground on the first, a one-sided stop on the second
CHAIN = {
    "model": {
        "dofs": ["x1", "x2"],
        "parameters": {"m1": 1, "m2": 1, "k1": 1, "k2": 1, "c": 0.02, "g3": 0.5, "gap": 0.3, "ks": 20, "F": 0.1,
                       "w": 0.5},
        "mass": [["m1", 0], [0, "m2"]],
        "damping": [["2*c", "-c"], ["-c", "c"]],
        "stiffness": [["k1 + k2", "-k2"], ["-k2", "k2"]],
        "forces": [{"dof": "x1", "expr": "g3*x1**3"},
                   {"type": "gap", "dof": "x2", "clearance": "gap", "stiffness": "ks", "damping": 0, "sides": "+"}],
        "excitation": [{"dof": "x1", "expr": "F*cos(tau)"}],
        "frequency": "w",
    },
    "analysis": {"type": "frequency_response", "parameter": "w", "range": [0.5, 2.0], "harmonics": 25},
}


def chain_problem(**parameters):
    data = {**CHAIN, "model": {**CHAIN["model"], "parameters": {**CHAIN["model"]["parameters"], **parameters}}}
    scene = scene_from_data(data)
    return build_problem(scene, build_model(scene))


def equations_of_motion(u, H, w, samples=16384):
    """The chain's equations written out with numpy, projected onto harmonics 0..H (sampled densely)."""
    tau = 2 * np.pi * np.arange(samples) / samples
    U = u.reshape(2 * H + 1, 2)  # harmonic-major: mean, then (cos, sin) of each harmonic
    k = np.arange(1, H + 1)
    C, S = np.cos(np.outer(tau, k)), np.sin(np.outer(tau, k))
    x = U[0] + C @ U[1::2] + S @ U[2::2]
    xd = w * (-(S * k) @ U[1::2] + (C * k) @ U[2::2])
    xdd = w * w * (-(C * k * k) @ U[1::2] - (S * k * k) @ U[2::2])
    r1 = xdd[:, 0] + 0.04 * xd[:, 0] - 0.02 * xd[:, 1] + 2 * x[:, 0] - x[:, 1] + 0.5 * x[:, 0] ** 3 - 0.1 * np.cos(tau)
    r2 = xdd[:, 1] - 0.02 * xd[:, 0] + 0.02 * xd[:, 1] - x[:, 0] + x[:, 1] + 20 * np.maximum(x[:, 1] - 0.3, 0.0)
    return np.array([np.concatenate([[r.mean()], 2 * (C.T @ r) / samples, 2 * (S.T @ r) / samples]) for r in (r1, r2)])


def test_the_chain_with_25_harmonics_starts_at_w_0_5():
    # before: Newton from the linear solution diverged, the branch ended start_failed at w=0.5
    hb = chain_problem()
    assert hb.H == 25
    assert not solve_at_parameter(hb, hb.linear_solution(0.5), 0.5).converged
    u = harmonic_start(hb, 0.5, hb.linear_solution(0.5))
    # the equations of motion, written out here, hold for every harmonic kept
    assert np.abs(equations_of_motion(u, 25, 0.5)).max() < 1e-7
    U = u.reshape(51, 2)
    assert U[1:].any() and np.abs(U[0]).max() < 0.05  # a forced vibration about the rest position


def test_a_start_that_fails_at_every_stage_says_where():
    hb = chain_problem(F=5.0)  # fifty times the force, far beyond the linear guess
    with pytest.raises(HomotopyFailed, match=r"Newton from the guess with H=25: .*; with H=5 too: residual"):
        harmonic_start(hb, 0.3, hb.linear_solution(0.3))


def test_no_homotopy_from_as_few_harmonics_as_it_starts_with():
    hb = chain_problem(F=5.0).with_options(harmonics=5)
    with pytest.raises(HomotopyFailed, match=r"^Newton from the guess with H=5: [^;]*$"):
        harmonic_start(hb, 0.3, hb.linear_solution(0.3), low=5)
