"""Bearing rotor (seed 001): Hill against the monodromy on its branches; HB orbits against time simulation.

Hill and the monodromy use the same HB orbit, so their difference is Hill's
truncation of the perturbation plus the RK4 error of the monodromy. On the
f0 = 0.5 branches the bearing stays on its casing (no switch, the smooth RK4
path) and both are tiny: measured max |mu_Hill - mu_RK4| after optimal pairing
2.5e-7 on the harmonic branch (H = 40, 4096 steps; the stiff contact mode,
823 rad/s against h = T/4096, dominates the RK4 part) and 2e-9 to 8e-8 on the
nu = 2 branch (H = 80, 8192 steps). The stated tolerance is 1e-5 for the whole
spectrum: the selection of Hill's exponents is reliable there (quality 1).
On the impacting c2 = 5 orbit it is not: the exponents of the stiff, sampled
contact crowd the centre and the selection picks the wrong ones (quality
0.01); the critical multipliers are in Hill's spectrum all the same, within
1e-3 of the monodromy's (algebraic convergence in H), which is what is checked
there.

HB against simulation: :func:`contin.timedomain.simulation.simulate` (compiled RK4 with
located contact switches, 32768 steps per period) started at the HB state at
t = 0, compared with the HB orbit over one period (512 instants). The
simulation's own error is estimated by halving the step. Measured max
displacement error (all four dofs):

==========================  =========  =========  =========  =========
orbit                       H = 10     H = 20     H = 40     H = 80
==========================  =========  =========  =========  =========
f0 = 0.5, w = 2.0 (stable)  3.7e-2     2.4e-3     5.5e-8     5.8e-12
f0 = 0.5, w = 2.1 (unst.)   --         6.9e-4     1.0e-7     3.0e-11
c2 = 5, w = 2.0 (impacts)   1.9e-3     8.6e-4     4.0e-4     1.8e-4
==========================  =========  =========  =========  =========

(H = 80 for f0 = 0.5 is at the simulation's error.) Permanent contact:
spectral, ``err <= 30 exp(-0.4 H)`` (fitted rate 0.44-0.46); at H = 10 the
truncated series dips out of the clearance, and at w = 2.1 Newton does not
converge there. Impacts: algebraic, ``err <= 0.03 / H`` (fitted order 1.14);
the bearing velocity, whose contact dynamics at 823 rad/s (harmonic ~400) H =
80 does not resolve, is off by 0.06-0.1 at every H.
"""

import numpy as np
import pytest

from contin.model.catalog import build_model
from contin.engine.continuation import ContinuationOptions
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.engine.newton import solve_at_parameter
from contin.timedomain.simulation import simulate
from contin.stability import (
    StabilityOptions,
    floquet_multipliers,
    hill_spectrum,
    monodromy_rk4,
    multiplier_distance,
    orbit_state,
)
from contin.bifurcation.start import simulation_start

N_DOF = 4


def resize(u, H):
    """Truncate or zero-pad a coefficient vector to H harmonics."""
    U = u.reshape(-1, N_DOF)
    V = np.zeros((2 * H + 1, N_DOF))
    k = min(U.shape[0], V.shape[0])
    V[:k] = U[:k]
    return V.reshape(-1)


def solve(hb, guess, w, **kw):
    res = solve_at_parameter(hb, guess, w, ContinuationOptions(newton_tol=1e-9, newton_max_iter=30), **kw)
    assert res.converged, (hb.H, w, res.message)
    return res.x


def one_period_error(model, hb, u, w, steps=32768):
    """Max |x_sim - x_HB| and |x'_sim - x'_HB| over one period, and the simulation's error estimate."""
    n = model.n_dof
    z0 = orbit_state(hb, u, w, 0.0)
    runs = [simulate(model, {"w": w}, z0[:n], z0[n:], periods=hb.nu, steps_per_period=S, record_every=S // 512)
            for S in (steps // 2, steps)]
    zh = orbit_state(hb, u, w, runs[1].t)
    assert np.allclose(runs[0].t, runs[1].t)
    err_x = float(np.abs(runs[1].x - zh[:, :n]).max())
    err_v = float(np.abs(runs[1].v - zh[:, n:]).max())
    sim_error = float(np.abs(runs[1].x - runs[0].x).max())  # ~15x the error of the finer run (fourth order)
    return err_x, err_v, sim_error


def compare(hb, u, w, steps):
    hill = floquet_multipliers(hb, u, w, StabilityOptions(method="hill"))
    mono = floquet_multipliers(hb, u, w, StabilityOptions(method="floquet", steps_per_period=steps))
    return hill, mono


# -------------------------------------------------------- f0 = 0.5, harmonic branch (scenes/rotor_harmonic.yaml)
@pytest.fixture(scope="module")
def harmonic():
    """nu = 1, H = 40, 1024 samples; solutions at w = 2.0 (stable), 2.1 and 2.4 (unstable), by homotopy in kbn."""
    model = build_model("bearing_rotor", {"f0": 0.5})
    hb = HarmonicBalance(model, "w", HBOptions(harmonics=40, samples=1024))
    return model, hb, {w: model.start(hb, w) for w in (2.0, 2.1, 2.4)}


def test_hill_and_monodromy_agree_on_the_harmonic_branch(harmonic):
    _, hb, sols = harmonic
    for w, u in sols.items():
        assert not monodromy_rk4(hb, u, w, 4096).switches  # permanent contact: the smooth RK4 path
        hill, mono = compare(hb, u, w, 4096)
        assert not hill.ambiguous and hill.quality > 0.9
        assert multiplier_distance(hill.multipliers, mono.multipliers) < 1e-5, w  # measured <= 2.5e-7
        assert hill.counts == mono.counts
        assert hill.stable == (w == 2.0)  # unstable by a complex pair near -1 at 2.1 and 2.4
        assert mono.n_complex == (0 if w == 2.0 else 2)


# ------------------------------------------------------- f0 = 0.5, nu = 2 branch (scenes/rotor_f0_05.yaml, its second start)
@pytest.fixture(scope="module")
def subharmonic():
    """nu = 2, H = 80, 2048 samples: from a time simulation at w = 2.16 (entrained into the +w/2 whirl),
    then Newton steps with a secant predictor down past the Neimark-Sacker point (w = 2.1498) to 2.149."""
    model = build_model("bearing_rotor", {"f0": 0.5})
    hb = HarmonicBalance(model, "w", HBOptions(harmonics=80, samples=2048, subharmonic=2))
    ws = [2.16]
    # Newton converges from 600 revolutions to the same solution as from 1500 (3e-12 apart)
    us = [simulation_start(hb, 2.16, transient=600, steps_per_period=4096)]
    for w in (2.157, 2.154, 2.152, 2.1505, 2.1495, 2.149):  # the Newton basin is small: short steps
        guess = us[-1] if len(us) < 2 else us[-1] + (us[-1] - us[-2]) * (w - ws[-1]) / (ws[-1] - ws[-2])
        us.append(solve(hb, guess, w))
        ws.append(w)
    return model, hb, dict(zip(ws, us))


@pytest.mark.slow  # the same agreement on the harmonic branch by default
def test_hill_and_monodromy_agree_on_the_subharmonic_branch(subharmonic):
    model, hb, sols = subharmonic
    for w in (2.16, 2.154, 2.149):
        u = sols[w]
        assert model.observables(u, N_DOF, 2)["whirl_fwd_half_disc"] > 0.3  # on the +w/2 forward whirl
        assert not monodromy_rk4(hb, u, w, 8192).switches
        hill, mono = compare(hb, u, w, 8192)
        assert not hill.ambiguous
        assert multiplier_distance(hill.multipliers, mono.multipliers) < 1e-5, w  # measured <= 8e-8
        assert hill.counts == mono.counts
        # stable down to the Neimark-Sacker point, a complex pair outside the circle below it
        assert mono.stable == (w > 2.1498) and mono.n_complex == (0 if w > 2.1498 else 2)


# ---------------------------------------------------------------- c2 = 5: impacting orbits (paper Fig. 8)
@pytest.fixture(scope="module")
def impacting():
    """c2 = 5, w = 2: the bearing leaves its casing twice per revolution. H = 80 by homotopy in kbn, then
    H = 40, 20, 10 by Newton from the truncated coefficients; 2048 samples throughout."""
    model = build_model("bearing_rotor", {"f0": 0.5, "c2": 5.0})
    w = 2.0
    hbs = {H: HarmonicBalance(model, "w", HBOptions(harmonics=H, samples=2048)) for H in (10, 20, 40, 80)}
    sols = {80: model.start(hbs[80], w)}
    for H in (40, 20, 10):
        sols[H] = solve(hbs[H], resize(sols[80], H), w)
    return model, w, hbs, sols


@pytest.mark.slow  # impacting orbits: saltation against the flow map in tests/stability/test_saltation.py
def test_hill_spectrum_holds_the_critical_multipliers_of_an_impacting_orbit(impacting):
    _, w, hbs, sols = impacting
    hb, u = hbs[40], sols[40]
    mono = monodromy_rk4(hb, u, w, 16384)
    assert len(mono.switches) >= 4  # contact lost and regained twice (plus HB ripple)
    spec = hill_spectrum(hb, u, w)
    assert spec.quality < StabilityOptions().ambiguity_threshold  # the selection is flagged, not trusted
    allmu = np.exp(spec.eigenvalues * spec.period)
    critical = mono.multipliers[np.argsort(-np.abs(mono.multipliers))[:4]]  # |mu| = 0.958, 0.931
    assert np.abs(critical).min() > 0.9
    for mu in critical:
        assert np.abs(allmu - mu).min() < 2e-3  # measured 8.7e-4 (H = 40)


# ---------------------------------------------------------------- HB against time simulation over one period
def test_permanent_contact_orbits_agree_with_simulation_spectrally(harmonic):
    """err_x(H) <= 30 exp(-0.4 H) + simulation error, stable (w = 2.0) and unstable (w = 2.1) orbits."""
    model, hb40, sols = harmonic
    unstable = floquet_multipliers(hb40, sols[2.1], 2.1, StabilityOptions(method="floquet", steps_per_period=4096))
    assert not unstable.stable
    for w, Hs in ((2.0, (10, 20, 40, 80)), (2.1, (20, 40, 80))):
        errs = {}
        for H in Hs:
            hb = HarmonicBalance(model, "w", HBOptions(harmonics=H, samples=1024))
            u = sols[w] if H == 40 else solve(hb, resize(sols[w], H), w)
            err_x, _, sim = one_period_error(model, hb, u, w)
            assert sim < 1e-8  # 7e-11 in permanent contact, 4e-9 from the H = 10 start (it loses contact)
            assert err_x <= 30 * np.exp(-0.4 * H) + sim, (w, H, err_x)
            errs[H] = (err_x, sim)
        assert errs[40][0] < 2e-7  # the scenes' H
        # fitted exponential rate over the points well above the simulation's error
        fit = [(H, np.log(e)) for H, (e, s) in errs.items() if e > 100 * s]
        rate = -np.polyfit(*zip(*fit), 1)[0]
        assert rate > 0.3, (w, errs, rate)  # measured 0.46 (w = 2.0), 0.44 (w = 2.1)
        assert errs[80][0] < 1e-10


@pytest.mark.slow  # impacting orbits: saltation against the flow map in tests/stability/test_saltation.py
def test_impacting_orbits_agree_with_simulation_algebraically(impacting):
    """err_x(H) <= 0.03 / H: first order in H (fitted 1.14), below 5e-4 at H = 40."""
    model, w, hbs, sols = impacting
    errs = {}
    for H in (10, 20, 40, 80):
        err_x, err_v, sim = one_period_error(model, hbs[H], sols[H], w)
        assert sim < 1e-7
        assert err_x <= 0.03 / H, (H, err_x)
        assert err_v < 0.2  # the bearing velocity: contact dynamics at harmonic ~400, unresolved
        errs[H] = err_x
    order = -np.polyfit(np.log(list(errs)), np.log(list(errs.values())), 1)[0]
    assert order > 0.9, (errs, order)
    assert all(errs[2 * H] < errs[H] for H in (10, 20, 40))
    assert errs[40] < 5e-4
