"""The rotating frame's Hopf point against the fixed-frame harmonic branch's Neimark-Sacker point (f0 = 0).

The bearing rotor with the paper's unbalance e = 0.5 has no Hopf point at f0 = 0
(the critical real part stays between -0.0026 and -0.0015 for w in [1.1, 5],
the paper's "harmonic solution stable over the whole range"); with e = 0.15 a
complex pair crosses at w_H = 1.94901345148, omega_H = 0.92132431496.

Outside truth: the harmonic branch of ``frequency_response`` (harmonic balance,
H = 40, Floquet multipliers of its orbit by RK4, the existing path of
scenes/rotor_f0_05.yaml), whose Neimark-Sacker event is located where
``|mu| = 1 + tolerance``; it lies ``tolerance / (d|mu|/dw)`` beyond the crossing,
``d|mu|/dw = 0.0155`` here. Measured w_NS - w_H (4096 steps): tolerance 1e-6:
6.40e-5; 1e-8: 6.40e-7; 1e-10: 5.8e-9; 1e-12: -5.4e-10 (8192 steps: 8.6e-11).
And the fixed-frame flow's own multipliers (multiple shooting, variational
equations, 4096 steps) at w_H: ``|mu| = 1`` to 1e-9, angle ``omega_H T``.
"""

import math

import numpy as np
import pytest

from contin import api
from contin.bifurcation.hopf import (
    EquilibriumProblem,
    follow_equilibrium,
    hopf_test,
    locate_hopf,
)
from contin.model.catalog import build_model
from contin.model.rotating_frame import rotating_frame, to_fixed
from contin.timedomain.multiple_shooting import ShootingProblem
from contin.timedomain.shooting_options import ShootingOptions

E = 0.15


@pytest.fixture(scope="module")
def setting():
    fixed = build_model("bearing_rotor", {"f0": 0.0, "e": E})
    rot = rotating_frame(fixed)
    problem = EquilibriumProblem(rot, "w")
    x = problem.solve(np.array([-0.21, 0.0, -0.1, 0.006]), 1.9)
    branch, hopf = follow_equilibrium(problem, x, 1.9, (1.9, 2.05))
    return fixed, rot, problem, branch, hopf


def test_jacobians_are_exact(setting):
    _, _, problem, _, hopf = setting
    x, w = hopf[0].state, hopf[0].lam
    R, Ju, Jlam = problem.linearize(x, w)
    h = 1e-7
    cd = np.column_stack([(problem.residual(x + h * e, w) - problem.residual(x - h * e, w)) / (2 * h)
                          for e in np.eye(4)])
    assert np.max(np.abs(Ju - cd)) <= 1e-6 * np.max(np.abs(Ju))  # kbn = 12881: CD rounding ~1e-9 * kbn
    dl = (problem.residual(x, w + 1e-6) - problem.residual(x, w - 1e-6)) / 2e-6
    assert np.max(np.abs(Jlam - dl)) <= 1e-8 * max(1.0, np.max(np.abs(Jlam)))
    assert np.max(np.abs(R)) <= 1e-11


def test_hopf_point_located_on_the_equilibrium_branch(setting):
    _, _, _, branch, hopf = setting
    assert branch.status.value == "range_end"
    assert len(hopf) == 1
    hp = hopf[0]
    assert abs(hp.lam - 1.94901345148) < 1e-10
    assert abs(hp.omega - 0.92132431496) < 1e-10
    assert abs(hp.real_part) < 1e-12 and hp.slope > 0  # unstable beyond it
    # the bearing is pressed on its casing (no switch): penetration 7.6e-6
    assert 7e-6 < math.hypot(hp.state[2], hp.state[3]) - 0.1 < 8e-6


def test_hopf_point_is_the_harmonic_branch_neimark_sacker_point(setting):
    _, _, _, _, hopf = setting
    hp = hopf[0]
    res = api.frequency_response(api.System.builtin("bearing_rotor", parameters={"f0": 0.0, "e": E}),
                                 parameter="w", range=[1.9, 2.05], start=1.9, harmonics=40, samples=1024,
                                 stability="floquet",
                                 stability_options={"steps_per_period": 4096, "tolerance": 1e-12},
                                 continuation={"ds": 0.01, "newton_tol": 1e-11})
    ns = [p for b in res.branches for p in b.special_points if p.kind == "ns"]
    assert len(ns) == 1
    assert abs(ns[0].parameter - hp.lam) < 1e-8  # measured 5.4e-10
    # its multiplier: exp(i omega_H T), the NS angle 2 pi omega_H / w
    mu = complex(ns[0].detail.split("multiplier ")[1].split(";")[0])
    assert abs(mu - np.exp(2j * np.pi * hp.omega / hp.lam)) < 1e-5  # printed to 6 digits


def test_fixed_frame_flow_has_the_hopf_multipliers(setting):
    fixed, rot, _, _, hopf = setting
    hp = hopf[0]
    sp = ShootingProblem(fixed, "w", options=ShootingOptions(steps_per_period=4096))
    z = to_fixed(rot, np.r_[hp.state, np.zeros(4)], hp.lam, 0.0)
    mu = sp.multipliers(z, hp.lam)
    crit = mu[np.argmin(np.abs(mu - np.exp(2j * np.pi * hp.omega / hp.lam)))]
    assert abs(abs(crit) - 1.0) < 1e-9
    assert abs(crit - np.exp(2j * np.pi * hp.omega / hp.lam)) < 1e-8


def test_no_bracket_is_refused(setting):
    _, _, problem, _, hopf = setting
    with pytest.raises(ValueError, match="does not change sign.*no Hopf point bracketed"):
        locate_hopf(problem, hopf[0].state, 1.96, 2.0)
    assert hopf_test(np.array([-1.0, -2.0])) == -math.inf


def test_time_dependent_model_is_refused():
    with pytest.raises(ValueError, match="varies in time.*not autonomous"):
        EquilibriumProblem(build_model("bearing_rotor", {"f0": 0.0}), "w")
