"""Saltation matrices at contact switches: the monodromy against finite differences of the simulated flow.

The truth is the flow map of the independent time integrator
(:func:`contin.timedomain.simulation.simulate`: compiled fixed-step RK4 with the contact
switches located in time), differentiated by central finite differences in
each of the ``2n`` directions of the initial state:

    Phi_FD[:, j] = (phi_T(z0 + eps e_j) - phi_T(z0 - eps e_j)) / (2 eps).

Its error: RK4 at ``S = 8192`` (1-dof) or ``16384`` (rotor) steps per period
with located switches is fourth order, ``~ (omega h)^4`` below 1e-10 for the
oscillator and ~1e-9 for the rotor (contact frequency 823 against ``h = T/S``);
the central difference adds ``O(eps^2)`` and rounding ``~ 1e-16/eps``, about
1e-10 for ``eps = 1e-6``. Measured agreement with the reference monodromy
(nonlinear DOP853 from the same start, saltation at its own switches): 4e-9 to
1e-8, so the tolerance is 1e-7.

The production monodromy (:func:`monodromy_rk4`) integrates along the HB
orbit rather than the exact trajectory through ``z0``; its difference from the
flow map is the HB truncation (algebraic in ``H`` for impacts), checked against
the measured one-period orbit error.
"""

import numpy as np
import pytest

from contin import ContinWarning
from conftest import fd_jacobian
from contin.models.polynomial import polynomial_model

from contin.model.catalog import build_model
from contin.model.elements import GapForce, RadialGapForce
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.model.base import Monomial
from contin.timedomain.simulation import simulate
from contin.stability import (
    StabilityMethod,
    StabilityOptions,
    floquet_multipliers,
    monodromy_reference,
    monodromy_rk4,
    orbit_state,
)
from contin.stability.monodromy import switching_events
from contin.bifurcation.start import simulation_start


def flow_jacobian(model, w, z0, periods=1, steps=8192, eps=1e-6):
    """Central finite differences of the simulated flow map over ``periods`` forcing periods."""
    n = model.n_dof

    def flow(z):
        run = simulate(model, {"w": w}, z[:n], z[n:], periods=periods, steps_per_period=steps, record_every=steps)
        return run.final_state

    return fd_jacobian(flow, z0, eps=eps)


def multipliers(Phi):
    return np.sort_complex(np.linalg.eigvals(Phi))


# ---------------------------------------------------------------- the switching functions of the contact elements
@pytest.mark.parametrize("clip", [False, True])
def test_contact_switching_functions(rng, clip):
    """Sign of h = law applied by evaluate; gradients = finite differences; jump = force difference on the surface."""
    p = np.zeros(1)
    gap = GapForce(0, Monomial(0.5), Monomial(4.0), Monomial(0.7), sides="both", clip=clip)
    radial = RadialGapForce((0, 1), Monomial(0.1), Monomial(500.0), Monomial(0.8), clip=clip)
    for el, n in ((gap, 1), (radial, 2)):
        x = rng.normal(scale=0.6 if n == 1 else 0.1, size=(400, n))
        xd = rng.normal(scale=0.5, size=(400, n))
        sw = el.switching_functions(x, xd, np.zeros(400), p)
        f = np.zeros((400, n))
        el.evaluate(x, xd, np.zeros(400), p, f, np.zeros((400, n, n)), np.zeros((400, n, n)))
        on = sw.value > 0
        assert on.any() and (~on).any()
        # the force is the sum of the active laws' differences (every law vanishes when inactive)
        np.testing.assert_allclose(f, np.einsum("jm,jmn->jn", on, sw.difference), atol=1e-12)
        # the gradients, away from the kink of min(penetration, F/k) (at distance c |normal velocity| / k)
        k, c = el.stiffness.value(p), el.damping.value(p)
        vn = xd[:, 0] if n == 1 else np.einsum("ji,ji->j", x, xd) / np.hypot(x[:, 0], x[:, 1])
        checked = 0
        for j in range(40):
            if clip and c * abs(vn[j]) / k < 1e-5:
                continue
            for i in range(sw.value.shape[1]):
                zz = np.concatenate([x[j], xd[j]])
                g = np.concatenate([sw.grad_x[j, i], sw.grad_xd[j, i]])

                def h(z, i=i, el=el, n=n):
                    return el.switching_functions(z[None, :n], z[None, n:], np.zeros(1), p).value[0, i:i + 1]

                np.testing.assert_allclose(fd_jacobian(h, zz, eps=1e-8)[0], g, rtol=1e-5, atol=1e-6)
                checked += 1
        assert checked > 20
    # on a surface: the damping term jumps at x = g / r = delta; the clipped force is continuous where it vanishes
    v = 0.3
    sw = gap.switching_functions(np.array([[0.5]]), np.array([[v]]), np.zeros(1), p)
    assert sw.value[0, 0] == 0.0 and np.isclose(sw.jump[0, 0, 0], 0.7 * v, rtol=1e-14)
    if clip:
        xs = 0.5 + 0.7 * 0.3 / 4.0  # k (x - g) - c v = 0 with v = -0.3: the clipped force reaches zero
        sw = gap.switching_functions(np.array([[xs]]), np.array([[-0.3]]), np.zeros(1), p)
        assert abs(sw.value[0, 0]) < 1e-15 and abs(sw.jump[0, 0, 0]) < 1e-15 and sw.grad_xd[0, 0, 0] > 0
    sw = radial.switching_functions(np.array([[0.06, 0.08]]), np.array([[0.3, 0.4]]), np.zeros(1), p)
    np.testing.assert_allclose(sw.jump[0, 0], 0.8 * 0.5 * np.array([0.6, 0.8]), rtol=1e-12)


# ---------------------------------------------------------------- a 1-dof clearance oscillator with contact damping
@pytest.fixture(scope="module", params=[False, True], ids=["unclipped", "clipped"])
def gap_orbit(request):
    """x'' + 0.05 x' + x + gap = 0.3 cos(w t), gap = 4 (x -+ 0.5) + 0.5 x' beyond |x| = 0.5, w = 1.1.

    A stable orbit hitting both stops; H = 40, started from a time simulation.
    """
    clip = request.param
    model = polynomial_model(["x"], {"c": 0.05, "F": 0.3, "w": 1.0}, mass=[[1.0]], damping=[["c"]],
                             stiffness=[[1.0]], forcing=[{"dof": "x", "amplitude": "F"}])
    model.forces.append(GapForce(0, Monomial(0.5), Monomial(4.0), Monomial(0.5), sides="both", clip=clip))
    hb = HarmonicBalance(model, "w", HBOptions(harmonics=40, samples=2048))
    w = 1.1
    u = simulation_start(hb, w, transient=200, steps_per_period=2048)
    z0 = orbit_state(hb, u, w, 0.0)
    return clip, model, hb, u, w, flow_jacobian(model, w, z0)


def test_gap_oscillator_monodromy_equals_the_simulated_flow_map(gap_orbit):
    """Saltation matrices make the monodromy the derivative of the flow map; without them it is far off."""
    clip, _, hb, u, w, Phi = gap_orbit
    ref = monodromy_reference(hb, u, w)
    assert len(ref.switches) == 4 and {e.direction for e in ref.switches} == {-1, 1}
    assert np.abs(ref.matrix - Phi).max() < 1e-7  # measured 4e-9 (clipped), 8e-9 (unclipped)
    bare = monodromy_reference(hb, u, w, switches="piecewise")
    assert np.abs(bare.matrix - Phi).max() > 0.3  # measured 0.46, 0.52
    # the production path along the HB orbit: the same up to the HB truncation
    mono = monodromy_rk4(hb, u, w, 4096)
    assert len(mono.switches) == 4 and mono.saltation
    for a, b in zip(mono.switches, ref.switches):  # the HB orbit switches where the flow does, within its error
        assert a.direction == b.direction and abs(a.time - b.time) < 1e-3
    orbit_error = ref.orbit_error  # |phi_T(z0) - z0| of the HB start: 5e-4 (unclipped), 2e-4 (clipped)
    assert orbit_error < 1e-3
    # measured 4.9e-4 and 4.4e-4: 1.0 and 2.2 times the orbit error
    assert np.abs(mono.matrix - Phi).max() < 5 * orbit_error
    assert np.abs(monodromy_rk4(hb, u, w, 4096, switches="piecewise").matrix - Phi).max() > 0.3
    d = np.abs(multipliers(mono.matrix) - multipliers(Phi)).max()
    assert d < 1e-3  # measured 4.3e-4, 2.6e-4
    bare_mu = multipliers(monodromy_rk4(hb, u, w, 4096, switches="piecewise").matrix)
    if clip:
        # contact starts with a jump c v (saltation) and ends where the force reaches zero (continuous, S = I):
        # without the entry saltation the multipliers are wrong
        salt = [np.abs(e.saltation - np.eye(2)).max() for e in mono.switches]
        assert sorted(salt) == pytest.approx([0.0, 0.0, 0.5, 0.5], abs=1e-12)
        assert np.abs(bare_mu - multipliers(Phi)).max() > 0.1  # measured 0.27
    else:
        # entry and exit saltations S_in = I - a N, S_out = I + a N (a = c_contact/m, N = e_v e_x^T); for a
        # 1-dof law with constant coefficients tr(S_out C S_in Y) = tr(C Y) (C, Y: contact and free flows,
        # both companion-form exponentials), so the multipliers alone do not see the saltation: Phi does
        assert np.abs(bare_mu - multipliers(mono.matrix)).max() < 1e-8


# ------------------------------------------------------- the rotor with c2 = 5 (impacting orbits, paper Fig. 8)
@pytest.mark.slow  # saltation against the flow map is checked on the clearance oscillator by default
def test_impacting_rotor_monodromy_equals_the_simulated_flow_map():
    """The bearing hits its casing twice per revolution at w = 2 (c2 = 5, H = 40; the paper's law).

    The saltation matrices have entries c_bn/beta = 27, but the bearing's own
    damping c2/beta = 263 wipes the velocity kick out within the period: they
    move Phi by 1.6e-5 (4e-6 with the clipped law), which the reference path
    resolves (agreement with the flow map 1e-8). Along the HB orbit (H = 40) the
    monodromy is off by 2e-2, the HB truncation of this impacting orbit (the
    true flow misses the start by 2.4e-3 after a period), far more than the
    saltation itself: on this model the HB error dominates.
    """
    model = build_model("bearing_rotor", {"f0": 0.5, "c2": 5.0})
    hb = HarmonicBalance(model, "w", HBOptions(harmonics=40, samples=1024))
    w = 2.0
    u = model.start(hb, w)
    Phi = flow_jacobian(model, w, orbit_state(hb, u, w, 0.0), steps=16384)
    # rtol 1e-7: the difference to Phi is Phi's own error (measured 1.42e-8 with rtol 1e-9 and 1e-8, 1.49e-8
    # here; 1.61e-5 without the saltation matrices at each), in half the time of rtol 1e-9
    ref = monodromy_reference(hb, u, w, rtol=1e-7, atol=1e-8)
    assert len(ref.switches) == 4  # in and out twice (the HB orbit adds a spurious graze: 6 switches)
    err = np.abs(ref.matrix - Phi).max()
    bare = np.abs(monodromy_reference(hb, u, w, rtol=1e-7, atol=1e-8, switches="piecewise").matrix - Phi).max()
    assert err < 1e-7 and bare > 30 * err, (err, bare)  # measured 1.5e-8 and 1.6e-5
    mono = monodromy_rk4(hb, u, w, 8192)
    assert mono.switches and ref.orbit_error < 5e-3
    assert np.abs(mono.matrix - Phi).max() < 10 * ref.orbit_error  # measured 1.9e-2
    assert np.abs(np.abs(mono.multipliers).max() - np.abs(np.linalg.eigvals(Phi)).max()) < 1e-3  # measured 4e-4


def test_hill_misses_the_saltation_and_both_reports_the_monodromy(gap_orbit):
    """Hill's matrices from the plain sampled Jacobian cannot hold the jump of the force (a delta at the
    surface): with the clipped law its multipliers are those of the monodromy without saltation, 0.27 off
    the flow map's, whatever its selection quality says. With the crossings resolved between samples
    (``crossings: interval``, :mod:`contin.hb.crossings`) dR/du holds the jump through the crossing's dependence
    on the orbit, and Hill lands on the flow map's multipliers. With the exact arcs (the default) dR/du holds
    it as Leibniz terms at the arc ends, which do not make a Hill matrix of the same kind; its selection
    quality drops. Method 'both' reports the monodromy there and 'hill' flags the point every way."""
    clip, model, hb, u, w, Phi = gap_orbit
    truth = multipliers(Phi)
    both = floquet_multipliers(hb, u, w, StabilityOptions(method="both", steps_per_period=4096))
    assert both.method is StabilityMethod.FLOQUET and both.confirmed
    assert np.abs(np.sort_complex(both.multipliers) - truth).max() < 1e-3
    for mode in ("none", "interval", "exact"):
        problem = HarmonicBalance(model, "w", HBOptions(harmonics=40, samples=2048, crossings=mode))
        with pytest.warns(ContinWarning, match="saltation"):
            hill = floquet_multipliers(problem, u, w, StabilityOptions(method="hill"))
        assert hill.ambiguous
        if clip and mode != "exact":
            err = np.abs(np.sort_complex(hill.multipliers) - truth).max()
            assert hill.quality > 0.9  # the selection itself looks fine
            if mode == "none":
                bare = multipliers(monodromy_rk4(hb, u, w, 4096, switches="piecewise").matrix)
                assert err > 0.1  # measured 0.27
                assert np.abs(np.sort_complex(hill.multipliers) - bare).max() < 0.02  # measured 6e-3
            else:
                assert err < 1e-3  # measured 2.2e-4


def test_switches_are_located_to_rounding_on_the_hb_orbit(gap_orbit):
    """Brent's method on the trigonometric series: h(t_c) at rounding level, direction as sampled."""
    _, model, hb, u, w, _ = gap_orbit
    ev = switching_events(hb, u, w, 512)
    el = model.forces[0]
    p = hb.params_at(w)
    for e in ev:
        z = orbit_state(hb, u, w, np.array([e.time - 1e-6, e.time, e.time + 1e-6]))
        h = el.switching_functions(z[:, :1], z[:, 1:], np.zeros(3), p).value[:, e.function]
        assert abs(h[1]) < 1e-14
        assert np.sign(h[2] - h[0]) == e.direction
