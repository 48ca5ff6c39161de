"""Backbone curves (contin.bifurcation.backbone): exact Duffing backbones, Jacobians, time integration, failure paths."""

import math

import numpy as np
import pytest
from scipy.special import ellipk

from conftest import fd_jacobian
from contin.bifurcation.backbone import BackboneError, BackboneProblem, trace_backbone
from contin.model.catalog import build_model
from contin.engine.continuation import ContinuationOptions
from contin.modal.equilibrium import ModalError


def duffing_frequency(k, g, A):
    """Exact frequency of x'' + k x + g x^3 = 0 with amplitude A (complete elliptic integral K(m))."""
    wn2 = k + g * A * A
    m = g * A * A / (2 * wn2)
    return math.pi * math.sqrt(wn2) / (2 * ellipk(m))


def test_duffing_backbone_is_the_exact_elliptic_frequency():
    # the built-in forced Duffing oscillator: its forcing is dropped, the backbone is that of x'' + x + 0.5 x^3
    model = build_model("duffing", {"m": 1.0, "c": 0.0, "k": 1.0, "g": 0.5}, ["cubic", "forcing"])
    br, prob = trace_backbone(model, 1, (1e-3, 3.0), harmonics=13, amplitude="peak")
    assert br.status.value == "range_end" and len(br) > 20
    A = np.exp(br.parameter)
    W = br.unknowns[:, prob.m]
    exact = np.array([duffing_frequency(1.0, 0.5, a) for a in A])
    # Newton's absolute tolerance (1e-10 on a residual of the size of the amplitude) limits the smallest amplitudes
    np.testing.assert_allclose(W, exact, rtol=1e-8)
    np.testing.assert_allclose(W[A > 0.1], exact[A > 0.1], rtol=1e-10)
    # from the linear frequency, with Lindstedt's first correction 3 g A^2 / (8 w0)
    assert prob.omega0 == pytest.approx(1.0, rel=1e-14)
    assert W[0] - prob.omega0 == pytest.approx(3 * 0.5 * A[0] ** 2 / 8, rel=1e-3)
    assert np.abs(br.unknowns[:, prob.m + 1]).max() < 1e-10  # the unfolding parameter vanishes on the branch


@pytest.mark.parametrize("mode, k, g", [(1, np.pi**2, 0.005 * np.pi**4 / 4), (2, 4 * np.pi**2, 4 * 0.005 * np.pi**4)])
def test_belt_without_rotor_follows_the_single_mode_duffing_backbone(mode, k, g):
    # beta = 0, no magnet: mode j alone is invariant and obeys (1/2) b'' + (pi^2 j^2/2) b + (alpha pi^4/8) j^4 b^3 = 0
    model = build_model("timing_belt", {"beta": 0.0}, ["stretching"])
    br, prob = trace_backbone(model, mode, (1e-3, 8.0), observe=f"b{mode}", harmonics=11, amplitude="peak")
    assert br.status.value == "range_end"
    A = np.exp(br.parameter)
    np.testing.assert_allclose(br.unknowns[:, prob.m], [duffing_frequency(k, g, a) for a in A], rtol=2e-8)
    others = np.delete(br.unknowns[:, : prob.m].reshape(len(br), -1, 5), mode - 1, axis=2)
    assert np.abs(others).max() < 1e-12


@pytest.mark.parametrize("amplitude", ["peak", "rms"])
@pytest.mark.parametrize("log", [True, False])
def test_backbone_jacobians_against_finite_differences(amplitude, log, rng):
    model = build_model("timing_belt", {"terms": 3}, ["rotor_mass", "stretching", "magnet"])
    prob = BackboneProblem(model, 1, "w", harmonics=3, amplitude=amplitude, log=log)
    v = prob.linear_guess(2.0)
    v[: prob.m] += 0.2 * rng.standard_normal(prob.m)
    v[prob.m + 1] = 0.03
    lam = prob.parameter_of(1.5)
    _, J, Jlam = prob.linearize(v, lam)
    np.testing.assert_allclose(J, fd_jacobian(lambda z: prob.residual(z, lam), v), rtol=1e-6,
                               atol=1e-7 * np.abs(J).max())
    fd = (prob.residual(v, lam + 1e-6) - prob.residual(v, lam - 1e-6)) / 2e-6
    np.testing.assert_allclose(Jlam, fd, rtol=1e-6, atol=1e-9)


def test_belt_backbones_harden_without_the_magnet_and_soften_first_with_it():
    free = build_model("timing_belt", {}, ["rotor_mass", "stretching"])
    for mode in (1, 2):
        br, prob = trace_backbone(free, mode, (1e-3, 8.0), amplitude="rms")
        W = br.unknowns[:, prob.m]
        assert W[0] == pytest.approx(prob.omega0, rel=1e-7)  # from the linear frequency (+ O(A^2))
        assert np.all(np.diff(W) > -1e-12) and W[-1] > 1.5 * prob.omega0  # hardening (Fig. 6)
    magnet = build_model("timing_belt", {}, ["rotor_mass", "stretching", "magnet"])
    br, prob = trace_backbone(magnet, 1, (1e-3, 10.0), amplitude="rms")
    W = br.unknowns[:, prob.m]
    assert W[0] == pytest.approx(prob.omega0, rel=1e-7)
    turns = [s for s in br.special_points if s.kind.value == "user"]
    assert len(turns) == 1  # softening, then hardening (Fig. 8): one frequency minimum
    w_min = turns[0].data["frequency"]
    assert w_min == pytest.approx(W.min(), rel=1e-3) and w_min < 0.75 * prob.omega0
    assert W[-1] > w_min * 1.05


@pytest.mark.slow  # the backbone against the exact elliptic frequency by default
def test_backbone_orbit_is_periodic_under_time_integration():
    from contin.timedomain.simulation import simulate

    model = build_model("timing_belt", {}, ["rotor_mass", "stretching", "magnet"])
    br, prob = trace_backbone(model, 1, (1e-3, 5.0), harmonics=17, amplitude="rms")
    u, w, _ = prob.split(br.unknowns[-1])
    U = u.reshape(-1, prob.n)
    k = np.arange(1, prob.H + 1)
    x0 = U[0] + U[1::2].sum(axis=0)
    v0 = w * (k[:, None] * U[2::2]).sum(axis=0)
    run = simulate(model, {"w": w}, x0, v0, periods=1, steps_per_period=2048, record_every=128)
    th = w * run.t
    hb_x = U[0] + np.cos(np.outer(th, k)) @ U[1::2] + np.sin(np.outer(th, k)) @ U[2::2]
    scale = np.abs(U[1:]).max()
    # H = 17: the harmonics have decayed to 1e-9 (H = 9 leaves 1.5e-4 at this amplitude, w_rms = 5)
    assert np.abs(run.x - hb_x).max() < 1e-8 * scale  # the free orbit closes after one period 2 pi / w
    assert np.abs(run.final_state[: prob.n] - x0).max() < 1e-8 * scale


def test_failure_paths_name_the_problem():
    damped = build_model("timing_belt", {"zeta": 0.01}, ["rotor_mass", "stretching", "damping"])
    with pytest.raises(BackboneError, match="has a damping matrix"):
        BackboneProblem(damped)
    bare = build_model("timing_belt", {"beta": 0.0}, ["stretching"])
    with pytest.raises(BackboneError, match="'w' does not move in mode 5"):
        BackboneProblem(bare, 5, "w")  # sin(5 pi 0.6) = 0
    with pytest.raises(BackboneError, match="mode must be from 1 to 5"):
        BackboneProblem(bare, 6)
    with pytest.raises(BackboneError, match="neither a dof .* nor a linear observable"):
        BackboneProblem(bare, 1, "v")
    with pytest.raises(BackboneError, match="amplitude must be 'peak' or 'rms'"):
        BackboneProblem(bare, 1, amplitude="max")
    with pytest.raises(ModalError, match="varies explicitly in time"):  # no free problem: its static one is refused
        BackboneProblem(build_model("mathieu", {}))
    with pytest.raises(BackboneError, match="positive"):
        trace_backbone(bare, 1, (0.0, 1.0))
    opts = ContinuationOptions(max_points=3)
    br, _ = trace_backbone(bare, 1, (1e-3, 1.0), options=opts)
    assert br.status.value == "max_points" and "max_points=3" in br.message
