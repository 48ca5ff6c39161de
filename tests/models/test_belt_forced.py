"""Forced and subharmonic responses of the timing belt (Fig. 9, mu = 1/2 and 1/3) against time integration."""

import numpy as np
import pytest

from contin.model.catalog import build_model
from contin.engine.continuation import ContinuationOptions
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.models.timing_belt import observe, shape_values
from contin.engine.newton import solve_at_parameter
from contin.timedomain.simulation import simulate
from contin.stability import StabilityOptions
from contin.bifurcation.diagram import follow

C_OBS = shape_values(5, 0.6)


def w_rms(u):
    return observe(u, C_OBS)["w_rms"]


def state_at_zero(u, n, Omega):
    """``x(0)`` and ``x'(0)`` of a harmonic-balance solution with base frequency ``Omega``."""
    U = u.reshape(-1, n)
    H = (U.shape[0] - 1) // 2
    k = np.arange(1, H + 1)
    return U[0] + U[1::2].sum(axis=0), Omega * (k[:, None] * U[2::2]).sum(axis=0)


def series(u, n, theta):
    U = u.reshape(-1, n)
    k = np.arange(1, (U.shape[0] - 1) // 2 + 1)
    return U[0] + np.cos(np.outer(theta, k)) @ U[1::2] + np.sin(np.outer(theta, k)) @ U[2::2]


def simulated_rms(model, w, x0, v0, periods, record):
    """w_rms at xi = 0.6 over the last ``record`` forcing periods of a run from (x0, v0)."""
    run = simulate(model, {"w": w}, x0, v0, periods=periods, steps_per_period=128, record_every=1,
                   record_from=periods - record)
    y = run.x[:-1] @ C_OBS
    return float(np.sqrt(np.mean((y - y.mean()) ** 2))), run


def test_fold_of_the_hardening_resonance_is_where_time_integration_jumps():
    # no magnet, tiny damping zeta = 0.005: the small response, traced down from w = 3.6, folds at w = 2.914
    model = build_model("timing_belt", {"zeta": 0.005, "p_d": 2.0},
                        ["rotor_mass", "stretching", "periodic_load", "damping"])
    hb = HarmonicBalance(model, "w", HBOptions(harmonics=5))
    u0 = model.start(hb, 3.3)
    d = follow(hb, u0, 3.3, (2.7, 3.3), ContinuationOptions(ds=0.02, ds_max=0.1, direction=-1),
               stability=StabilityOptions(method="hill"), switch=())
    br = d.branches[0]
    folds = [s for s in br.special_points if s.kind.value == "fold"]
    assert len(folds) == 1 and folds[0].located
    fold = folds[0]
    assert fold.parameter == pytest.approx(2.9137, abs=2e-4)
    st = br.point_data["stable"]
    i_fold = fold.index
    assert np.all(st[: i_fold + 1]) and not np.any(st[i_fold + 2:])  # stable before the fold, unstable after
    a_fold = w_rms(fold.unknowns)
    # just above the fold the small response exists and is stable: a run started on it stays there
    w_hi = fold.parameter + 0.01
    j = int(np.argmin(np.abs(br.parameter[: i_fold + 1] - w_hi)))
    res = solve_at_parameter(hb, br.unknowns[j], w_hi)
    assert res.converged
    x0, v0 = state_at_zero(res.x, 5, w_hi)
    rms_hi, _ = simulated_rms(model, w_hi, x0, v0, 400, 20)
    assert rms_hi == pytest.approx(w_rms(res.x), rel=2e-3) and rms_hi < a_fold
    # just below the fold it does not exist: a run started from the fold solution jumps to the resonance
    w_lo = fold.parameter - 0.01
    x0, v0 = state_at_zero(fold.unknowns, 5, fold.parameter)
    rms_lo, run = simulated_rms(model, w_lo, x0, v0, 600, 20)
    assert rms_lo > 1.8 * a_fold
    # where it lands is a solution of the harmonic balance (Newton from the simulated motion) with that w_rms
    x = run.x[:-1][-128:]
    F = np.fft.rfft(x, axis=0) / 128
    U = np.zeros((11, 5))
    U[0] = F[0].real
    U[1::2] = 2 * F[1:6].real
    U[2::2] = -2 * F[1:6].imag
    res = solve_at_parameter(hb, U.reshape(-1), w_lo)
    assert res.converged and w_rms(res.x) == pytest.approx(rms_lo, rel=5e-3)


@pytest.mark.slow  # the 1/2 subharmonic against time integration by default
def test_one_third_subharmonic_agrees_with_time_integration():
    # undamped, no magnet: the 1/3 subharmonic near three times the first natural frequency (2.67)
    model = build_model("timing_belt", {"p_d": 2.0}, ["rotor_mass", "stretching", "periodic_load"])
    hb = HarmonicBalance(model, "w", HBOptions(harmonics=12, subharmonic=3))
    u0 = model.start(hb, 8.5)  # from the free vibration of mode 1 at w/3 (its backbone)
    d = follow(hb, u0, 8.5, (7.8, 8.8), ContinuationOptions(ds=0.02, ds_max=0.1, direction=-1),
               stability=StabilityOptions(method="hill"), switch=())
    br = d.branches[0]
    folds = [s for s in br.special_points if s.kind.value == "fold"]
    assert len(folds) == 1 and 7.95 < folds[0].parameter < 8.05  # the subharmonic is born at a fold near 8.01
    st = br.point_data["stable"]
    assert st[0] and not st[-1]  # the large one is stable, the small one beyond the fold unstable
    Omega = 8.5 / 3
    U = u0.reshape(-1, 5)
    assert np.abs(U[1]).max() > 1.0  # a strong w/3 component
    x0, v0 = state_at_zero(u0, 5, Omega)
    run = simulate(model, {"w": 8.5}, x0, v0, periods=3, steps_per_period=2048, record_every=64)
    ref = series(u0, 5, Omega * run.t)
    assert np.abs(run.x - ref).max() < 1e-5 * np.abs(U[1:]).max()  # one period 6 pi / w closes the orbit
    # and it is stable: 60 subharmonic periods later the motion is still on the orbit
    run = simulate(model, {"w": 8.5}, x0, v0, periods=180, steps_per_period=256, record_every=3 * 256)
    drift = np.abs(run.x - x0).max(axis=1)
    assert drift.max() < 1e-3 * np.abs(U[1:]).max()


def test_one_half_subharmonic_from_period_doubling_agrees_with_time_integration():
    # with the magnet (quadratic terms), undamped: the harmonic response loses stability by period doubling
    # near twice the first natural frequency (2 x 4.94) and the 1/2 subharmonic branches start there
    model = build_model("timing_belt", {"p_d": 2.0}, ["rotor_mass", "stretching", "magnet", "periodic_load"])
    hb = HarmonicBalance(model, "w", HBOptions(harmonics=6))
    u0 = model.start(hb, 9.6)
    # the range ends above both period doublings and below the fold at w = 10.0525, beyond which the harmonic
    # branch creeps on in steps of ~1e-8 in w up to max_points (2000 points)
    d = follow(hb, u0, 9.6, (9.6, 9.95), ContinuationOptions(ds=0.01, ds_max=0.05),
               stability=StabilityOptions(method="both"), switch=("pd",), max_branches=3)
    pds = [s for s in d.branches[0].special_points if s.kind.value == "pd"]
    assert len(pds) == 2
    np.testing.assert_allclose(sorted(s.parameter for s in pds), [9.8675, 9.8968], atol=2e-4)
    subs = [(b, p) for b, p in zip(d.branches[1:], d.problems[1:]) if p.nu == 2]
    assert subs
    for br, prob in subs:
        i = len(br) // 2
        u, w = br.unknowns[i], float(br.parameter[i])
        U = u.reshape(-1, 5)
        assert np.abs(U[1:3]).max() > 1e-3  # a w/2 component
        x0, v0 = state_at_zero(u, 5, w / 2)
        run = simulate(model, {"w": w}, x0, v0, periods=2, steps_per_period=2048, record_every=64)
        ref = series(u, 5, w / 2 * run.t)
        assert np.abs(run.x - ref).max() < 1e-5 * max(1.0, np.abs(U[1:]).max())


def test_subharmonic_start_fails_with_a_reason_where_no_backbone_reaches_w_over_nu():
    from contin.bifurcation.start import HomotopyFailed

    # hardening modes never come down to w/3 = 2, below the first natural frequency 2.67
    model = build_model("timing_belt", {"p_d": 2.0}, ["rotor_mass", "stretching", "periodic_load"])
    hb = HarmonicBalance(model, "w", HBOptions(harmonics=6, subharmonic=3))
    with pytest.raises(HomotopyFailed, match=r"no subharmonic start: mode 1: the backbone of mode 1 \(linear "
                                             r"frequency 2.66972\) does not reach w/nu = 2: its frequency runs away"):
        model.start(hb, 6.0)
