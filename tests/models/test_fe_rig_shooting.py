"""The finite-element rig's periodic orbits by shooting on its Craig-Bampton model (scenes/rotor_fe_rig.yaml).

Truth from outside the code: the equations of motion of the reduced rig integrated by scipy's DOP853
(``_reference_flow``: the model's matrices and its radial contact law written out here, the contact's
switch resolved by the adaptive step), against which the shooting orbit must close; the period
doublings that the truncated harmonic balance reports between w = 2.4018 and 2.4282 (H = 20,
docs/validation/fe-rotor.md) are checked to be absent from the flow: no real multiplier near -1 there.
"""

import math
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from contin.scene.build import build_model
from contin.scene.parse import load_scene

SCENE = Path(__file__).resolve().parents[2] / "scenes" / "rotor_fe_rig.yaml"


@pytest.fixture(scope="module")
def rig():
    return build_model(load_scene(SCENE))


def _reference_flow(model, w: float, z0, periods: float = 1.0, rtol: float = 1e-11) -> np.ndarray:
    """The state after ``periods`` forcing periods from ``z0``, by DOP853 on the equations written out here.

    ``M x'' + (C0 + w G) x' + K x + f_c(x, x') = e w^2 (cos wt, sin wt) on the disc + side load``, with the
    radial contact ``f_c = (k (r - delta) + c v_n) e_r`` at the bearing where ``r > delta``.
    """
    p = model.parameter_vector({"w": w})
    Minv = np.linalg.inv(model.mass.value(p))
    C, K = model.damping.value(p), model.stiffness.value(p)
    n = model.n_dof
    static, rotating = np.zeros(n), np.zeros(n, dtype=complex)
    for e in model.excitations:  # A cos(order w t + phase): order 0 a constant load, order 1 the unbalance
        a = e.amplitude.value(p)
        if e.order == 0.0:
            static[e.dof] += a * math.cos(e.phase)
        else:
            assert e.order == 1.0
            rotating[e.dof] += a * np.exp(1j * e.phase)
    g, = model.forces
    ix, iy = g.ix, g.iy
    delta, k, c = g.clearance.value(p), g.stiffness.value(p), g.damping.value(p)

    def rhs(t, z):
        x, v = z[:n], z[n:]
        f = static + np.real(rotating * np.exp(1j * w * t)) - C @ v - K @ x
        r = math.hypot(x[ix], x[iy])
        if r > delta:
            ex, ey = x[ix] / r, x[iy] / r
            fn = k * (r - delta) + c * (v[ix] * ex + v[iy] * ey)
            f[ix] -= fn * ex
            f[iy] -= fn * ey
        return np.concatenate([v, Minv @ f])

    sol = solve_ivp(rhs, (0.0, periods * 2 * math.pi / w), np.asarray(z0, dtype=float), method="DOP853",
                    rtol=rtol, atol=rtol * 0.1)
    assert sol.success, sol.message
    return sol.y[:, -1]


def _orbit(model, w: float, segments: int = 1):
    """The rig's harmonic orbit at ``w`` by shooting (4096 RK4 steps a revolution), Newton from the
    harmonic balance's state (H = 20, the scene's harmonics): the problem, its unknowns, the last residual
    and the harmonic balance's own residual in the flow."""
    from contin.hb.problem import HarmonicBalance, HBOptions
    from contin.stability import orbit_state
    from contin.timedomain.shooting import ShootingOptions, ShootingProblem

    hb = HarmonicBalance(model, "w", HBOptions(harmonics=20, samples=512, crossings="interval"))
    z = orbit_state(hb, model.start(hb, w), w, 0.0)
    problem = ShootingProblem(model, "w", options=ShootingOptions(steps_per_period=4096, segments=segments))
    u = problem.start_unknowns(z, w)
    start = float(np.abs(problem.residual(u, w)).max())
    for _ in range(12):
        R, J, _ = problem.linearize(u, w)
        if np.abs(R).max() < 1e-11:
            break
        u = u + np.linalg.solve(J, -R)
    return problem, u, float(np.abs(problem.residual(u, w)).max()), start


@pytest.mark.slow
def test_harmonic_orbit_by_shooting_closes_under_an_independent_integration(rig):
    w = 2.4
    _, u, residual, hb_residual = _orbit(rig, w)
    assert residual < 1e-10
    # the truncated series (H = 20) is not an orbit of the flow: it misses it by 5e-2 after one revolution
    assert hb_residual > 1e-2
    z0 = u[:2 * rig.n_dof]
    scale = np.abs(z0).max()
    # RK4 at 4096 steps a revolution against DOP853 at rtol 1e-11: the step's truncation error (3e-6 measured)
    assert np.abs(_reference_flow(rig, w, z0) - z0).max() < 1e-5 * scale


@pytest.mark.slow
@pytest.mark.parametrize("w", [2.4018, 2.4282])
def test_no_period_doubling_of_the_flow_where_the_truncated_series_finds_them(rig, w):
    """At the harmonic balance's first and last period doubling (H = 20) the flow's multiplier nearest -1 is
    complex and well away from it, and the orbit is unstable by a complex pair (the self-excited whirl); the
    nearest one checked on DOP853's flow map along its eigenvector's real part."""
    problem, u, residual, _ = _orbit(rig, w)
    assert residual < 1e-10
    factors = problem.factors(u, w)
    Phi = np.eye(factors.shape[1])
    for F in factors:
        Phi = F @ Phi
    mu, V = np.linalg.eig(Phi)
    j = int(np.argmin(np.abs(mu + 1.0)))
    assert abs(mu[j] + 1.0) > 0.1 and abs(mu[j].imag) > 0.1  # the nearest is complex, and not close
    assert np.abs(mu).max() > 1.0  # unstable all the same: the self-excited whirl
    np.testing.assert_allclose(np.sort_complex(mu), np.sort_complex(problem.multipliers(u, w)), atol=1e-8)
    # DOP853's monodromy along Re v: Phi Re(v) = Re(mu v), by central differences of the flow map
    z0, v = u[:2 * rig.n_dof], V[:, j] / np.abs(V[:, j]).max()
    h = 1e-6
    column = (_reference_flow(rig, w, z0 + h * v.real) - _reference_flow(rig, w, z0 - h * v.real)) / (2 * h)
    assert np.abs(column - (mu[j] * v).real).max() < 2e-3 * np.abs(v).max() * abs(mu[j])
