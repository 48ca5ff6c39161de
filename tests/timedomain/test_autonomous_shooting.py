"""Autonomous shooting of the rotating-frame rotor (f0 = 0, e = 0.15) and the exact check of the invariant circle.

Beyond its Hopf point (w_H = 1.94901345, subcritical: the orbits lie below
w_H, unstable, the bearing pressed on its casing all along) the rotating
frame's periodic orbit at w = 1.9 has ``T_r = 7.1858973216``. Outside truths:

- scipy's DOP853 (rtol 1e-11, atol 1e-13; 1e-13 changes it by < 1e-11) of the rotating-frame equations
  written here in complex form, with an event for ``r2 = delta`` (none
  fires): max difference over the orbit, positions / whole state, by the
  steps a period (fourth order): 4096: 6.2e-10 / 3.7e-7; 8192: 4.0e-11 /
  1.1e-8; 16384: 2.5e-12 / 3.1e-10.
- the fixed frame's invariant circle (contin.timedomain.invariant_circle) at
  f0 = 0 started on the orbit and solved by Newton: its points' positions
  against the orbit's (at ``t = k T``, ``R(w k T) = I``) and
  ``rho T_r - T`` (``rho = T / T_r`` in [0, 1)). Positions, by the circle's
  points N at 4096 steps a forcing period: N = 15: 1.7e-6; 21: 1.7e-7;
  31: 1.6e-8; 41: 1.6e-8 (the RK4 error); by the steps at N = 41: 4096:
  1.6e-8; 8192: 3.0e-10; 16384: 6.4e-12 (the orbit with twice the steps or more,
  scripts/figures/rotor/rotor_rotating_frame.py). ``|rho T_r - T|``: 1.1e-10 at
  4096 steps, 6.8e-12 at 8192, 4.9e-13 at 16384. Checked here: N = 31, 8192 steps.
"""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from contin.bifurcation.hopf import EquilibriumProblem, locate_hopf
from contin.engine.continuation import ContinuationOptions, continuation
from contin.model.catalog import build_model
from contin.model.rotating_frame import rotating_frame, to_fixed
from contin.timedomain.autonomous_shooting import (
    AutonomousOptions,
    AutonomousShootingProblem,
    hopf_orbit_start,
)
from contin.timedomain.invariant_circle import CircleOptions, InvariantCircleProblem

P = dict(alpha=0.611, ks2=0.611, ip=0.1, beta=0.019, delta=0.1, e=0.15, kbn=12881.0, cbn=0.515, c1=0.005, c2=0.05)
W = 1.9


def rotating_rhs(t, y, w):
    """The rotating-frame equations in complex form (disc z1, bearing z2), written independently of contin."""
    z1, z2, v1, v2 = y[0] + 1j * y[1], y[2] + 1j * y[3], y[4] + 1j * y[5], y[6] + 1j * y[7]
    a1 = (-(P["c1"] + 1j * w * (2 - P["ip"])) * v1 - (1 - w * w + P["ip"] * w * w + 1j * w * P["c1"]) * z1
          + P["alpha"] * z2 + P["e"] * w * w)
    r2 = abs(z2)
    fn = 0.0
    if r2 >= P["delta"]:
        fn = P["kbn"] * (r2 - P["delta"]) + P["cbn"] * (v2 * np.conj(z2)).real / r2
    a2 = (-(P["c2"] + 2j * w * P["beta"]) * v2 - (P["ks2"] * P["alpha"] - P["beta"] * w * w + 1j * w * P["c2"]) * z2
          + P["ks2"] * z1 - z2 / r2 * fn) / P["beta"]
    return [v1.real, v1.imag, v2.real, v2.imag, a1.real, a1.imag, a2.real, a2.imag]


def leaves_contact(t, y, w):
    return math.hypot(y[2], y[3]) - P["delta"]


@pytest.fixture(scope="module")
def family():
    """The orbits from the Hopf point down to w = 1.9 (engine, 4096 steps)."""
    rot = rotating_frame(build_model("bearing_rotor", {"f0": 0.0, "e": P["e"]}))
    eq = EquilibriumProblem(rot, "w")
    hopf = locate_hopf(eq, np.array([-0.21, 0.0, -0.1, 0.006]), 1.94, 1.96)
    problem, u0, tangent = hopf_orbit_start(rot, hopf, options=AutonomousOptions(steps=4096), eps=0.02)
    branch = continuation(problem, u0, hopf.lam, (W, 2.0), ContinuationOptions(ds=0.02, ds_max=0.1, max_points=40),
                          parameter_name="w", tangent=tangent, solve_start=False)
    return rot, hopf, problem, branch


def test_family_leaves_the_hopf_point_downwards(family):
    _, hopf, problem, branch = family
    assert branch.status.value == "range_end" and branch.parameter[-1] == W
    assert np.all(np.asarray(branch.parameter) < hopf.lam)  # subcritical
    _, T = problem.split(branch.unknowns[0])
    assert abs(T - 2 * math.pi / hopf.omega) < 1e-2  # the Hopf period, 6.8197
    mu = problem.multipliers(branch.unknowns[-1], W)
    assert abs(mu[1] - 1.0) < 1e-8  # the trivial multiplier (the orbit's direction)
    assert abs(mu[0]) > 1.002  # unstable


def test_jacobian_against_central_differences(family):
    _, _, problem, branch = family
    u, lam = branch.unknowns[-1], W
    _, Ju, Jlam = problem.linearize(u, lam)
    cd = np.empty_like(Ju)
    for j in range(problem.size):
        h = 1e-7 * max(1.0, abs(u[j]))
        e = np.zeros(problem.size)
        e[j] = h
        cd[:, j] = (problem.residual(u + e, lam) - problem.residual(u - e, lam)) / (2 * h)
    scale = np.max(np.abs(Ju), axis=0)
    assert np.all(np.max(np.abs(Ju - cd), axis=0)[:-1] <= 1e-6 * scale[:-1])
    # the period column is the exact flow's f(phi(z)), off the discrete map's by its RK4 error: 7.6e-3 of the
    # column (the bearing's radial velocity, its stiff contact mode at h |lambda| = 1.4)
    assert np.max(np.abs(Ju[:, -1] - cd[:, -1])) <= 1.5e-2 * scale[-1]
    h = 1e-6
    dl = (problem.residual(u, lam + h) - problem.residual(u, lam - h)) / (2 * h)
    assert np.max(np.abs(Jlam - dl)) <= 1e-6 * np.max(np.abs(Jlam))


def test_orbit_against_dop853(family):
    rot, _, problem, branch = family
    fine = AutonomousShootingProblem(rot, "w", options=AutonomousOptions(steps=8192, section=problem.section))
    u = fine.solve(branch.unknowns[-1], W)
    z, T = fine.split(u)
    assert abs(T - 7.1858973216) < 1e-9
    sol = solve_ivp(rotating_rhs, (0.0, T), z, method="DOP853", rtol=1e-11, atol=1e-13, args=(W,),
                    events=leaves_contact, dense_output=True)
    assert sol.status == 0 and sol.t_events[0].size == 0  # the bearing stays in contact
    ref = sol.sol(np.linspace(0.0, T, 65)).T
    orb = fine.orbit(u, W, 64)
    assert np.max(np.abs(orb[:, :4] - ref[:, :4])) < 1e-9  # measured 4.0e-11
    assert np.max(np.abs(orb - ref)) < 5e-8  # measured 1.1e-8 (the bearing's stiff contact velocity)


def test_invariant_circle_is_the_rotating_orbit(family):
    rot, _, problem, branch = family
    N, k = 31, 256
    orbit = AutonomousShootingProblem(rot, "w", options=AutonomousOptions(steps=N * k, section=problem.section))
    u = orbit.solve(branch.unknowns[-1], W)
    _, Tr = orbit.split(u)
    states = orbit.orbit(u, W)[::k][:N]  # at t = j T_r / N
    U = to_fixed(rot, states, W, 0.0)
    T = 2 * math.pi / W
    fixed = build_model("bearing_rotor", {"f0": 0.0, "e": P["e"]})
    circle = InvariantCircleProblem(fixed, "w", options=CircleOptions(points=N, steps_per_period=8192), anchor=U)
    x = circle.solve(circle.unknowns(U, T / Tr), W, tol=1e-12)
    assert np.max(np.abs(circle.residual(x, W))) < 1e-11
    Uc, rho = circle.blocks(x)
    assert abs(rho * Tr - T) < 1e-9  # measured 7.0e-12
    assert np.max(np.abs(Uc[:, :4] - U[:, :4])) < 1e-8  # positions at t = kT; measured 4.5e-10
    assert np.max(np.abs(Uc[:, 4:] - U[:, 4:])) < 1e-7  # velocities x' = zeta' + w J zeta; measured 9.9e-9


def test_options_and_models_are_checked(family):
    rot = family[0]
    with pytest.raises(ValueError, match="AutonomousOptions.factors: expected a divisor of steps = 4096"):
        AutonomousOptions(factors=3)
    with pytest.raises(ValueError, match="AutonomousOptions.steps: expected an integer >= 16"):
        AutonomousOptions(steps=8)
    with pytest.raises(ValueError, match="AutonomousOptions.section: expected a dof index below 4"):
        AutonomousShootingProblem(rot, "w", options=AutonomousOptions(section=5))
    with pytest.raises(ValueError, match="no period parameter 'wr'"):
        AutonomousShootingProblem(build_model("bearing_rotor", {"f0": 0.0}), "w")
    with pytest.raises(ValueError, match="period parameter 'wr' is an unknown"):
        AutonomousShootingProblem(rot, "wr")
