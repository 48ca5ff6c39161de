"""The ends of a branch of invariant circles (contin.bifurcation.circle_branch): collapse at the Neimark-Sacker
point of the forced van der Pol oscillator, locking told from the rotation number, and the periodic orbits of a
locked circle."""

from fractions import Fraction

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from contin.bifurcation.circle_branch import classify_circle_end, follow_circle, locked_orbits
from contin.engine.branch import BranchBuilder, BranchStatus, SpecialKind
from contin.engine.continuation import ContinuationOptions
from contin.model.catalog import build_model
from contin.timedomain.invariant_circle import CircleOptions, InvariantCircleProblem, circle_start
from contin.timedomain.shooting import ShootingOptions, periodic_orbit
from contin.timedomain.simulation import simulate
from van_der_pol_model import W_NS, vdp_circle_branch, vdp_model

@pytest.fixture(scope="module")
def down():
    """The circle branch from the Neimark-Sacker point down to w = 0.9."""
    return vdp_circle_branch(0.9)


def test_the_branch_from_the_neimark_sacker_point_reaches_its_range_end(down):
    prob, br = down
    assert br.status is BranchStatus.RANGE_END and br.parameter[-1] == pytest.approx(0.9)
    spread = np.asarray(br.point_data["circle_spread"])
    assert spread[0] < 0.1 < spread[-1]  # grows from the ellipse of the start (measured 0.13 -> 3.5)


def test_a_circle_followed_back_up_collapses_at_the_neimark_sacker_point(down):
    prob, br = down
    u, w = br.unknowns[-1], float(br.parameter[-1])
    prob.set_anchor(u)
    up = follow_circle(prob, u, w, (0.9, 0.96), ContinuationOptions(ds=0.05, direction=1))
    assert up.status is BranchStatus.BOUNDARY and "shrinks onto the periodic orbit" in up.message
    (end,) = [sp for sp in up.special_points if sp.event == "circle end"]
    assert end.kind is SpecialKind.NS and end.parameter == pytest.approx(W_NS, abs=1e-4)
    spread = np.asarray(up.point_data["circle_spread"])
    assert min(spread[-2:]) < 0.05 * spread.max()  # the last two points straddle the collapse
    # stopped at the flip: not retracing the tori down to the range's end
    assert up.parameter.min() == pytest.approx(0.9) and np.all(up.parameter[1:] > 0.9)


def test_a_stalled_branch_at_a_small_rational_rotation_number_is_locking():
    prob = InvariantCircleProblem(vdp_model(), "w", options=CircleOptions(points=5, steps_per_period=64))
    b = BranchBuilder("w", prob.size)
    for k, rho in enumerate((0.3991, 0.39995)):
        u = prob.unknowns(np.full((5, 2), 1.0 + k) + np.arange(5)[:, None], rho)
        b.append_point(u, 1.1 + 1e-3 * k, np.r_[np.zeros(prob.size), 1.0], k * 1e-3, 3, 1e-3, 1e-12,
                       {"circle_spread": 4.0})
    br = b.finish(BranchStatus.STEP_TOO_SMALL, "step size fell below ds_min")
    classify_circle_end(br, prob)
    assert br.status is BranchStatus.BOUNDARY and "locks" in br.message and "2/5" in br.message
    assert br.special_points[-1].kind is SpecialKind.LOCKING
    # the same stall away from a rational of small denominator keeps the engine's status
    b = BranchBuilder("w", prob.size)
    b.append_point(prob.unknowns(np.ones((5, 2)) + np.arange(5)[:, None], 0.4321), 1.1,
                   np.r_[np.zeros(prob.size), 1.0], 0.0, 3, 1e-3, 1e-12, {"circle_spread": 4.0})
    br = b.finish(BranchStatus.STEP_TOO_SMALL, "step size fell below ds_min")
    classify_circle_end(br, prob)
    assert br.status is BranchStatus.STEP_TOO_SMALL


def _fake_branch(prob, points, spread=4.0):
    """A circle branch ending ``step_too_small`` through ``points`` ``(lam, rho)`` (the circles are stand-ins)."""
    b = BranchBuilder("w", prob.size)
    for k, (lam, rho) in enumerate(points):
        u = prob.unknowns(np.full((prob.points, 2), 1.0) + np.arange(prob.points)[:, None], rho)
        b.append_point(u, lam, np.r_[np.zeros(prob.size), 1.0], k * 1e-3, 3, 1e-3, 1e-12, {"circle_spread": spread})
    return b.finish(BranchStatus.STEP_TOO_SMALL, "step size fell below ds_min")


def _square_root_law(lams, lam_c, c, rational=0.5, below=True):
    """``(lam, rho)`` with ``(rho - p/q)^2 = c |lam_c - lam|``: the approach to a tongue's edge."""
    return [(lam, rational + (-1 if below else 1) * np.sqrt(c * abs(lam_c - lam))) for lam in lams]


@pytest.mark.parametrize("way", [1, -1])
def test_a_rotation_number_heading_for_a_rational_as_a_square_root_locks_ahead(way):
    """The steps fail 1e-3 before the tongue's edge, 4.5e-3 from 1/2 (beyond the tolerance of a locking at the
    last circle): the line through the last two squared distances puts the edge at lam_c, exactly for the law."""
    from contin.bifurcation.circle_branch import locking_ahead

    prob = InvariantCircleProblem(vdp_model(), "w", options=CircleOptions(points=5, steps_per_period=64))
    lam_c = 1.0 + way * 1e-3
    pts = _square_root_law([1.0 - way * 4e-3, 1.0 - way * 2e-3, 1.0], lam_c, 0.02025)
    br = _fake_branch(prob, pts)
    f, found = locking_ahead(br, prob)
    assert f == Fraction(1, 2) and found == pytest.approx(lam_c, abs=1e-12)
    classify_circle_end(br, prob)
    assert br.status is BranchStatus.BOUNDARY and "as the square root of the distance to w=" in br.message
    lock = br.special_points[-1]
    assert lock.kind is SpecialKind.LOCKING and lock.parameter == pytest.approx(lam_c, abs=1e-12)
    assert lock.data["predicted"] == lock.parameter and lock.data["rational"] == "1/2"
    # too far ahead, or a jump at the last circle (the earlier one 1.75 times above the line), or not closing
    # in: the engine's end stands
    for pts in (_square_root_law([1.0 - way * 4e-3, 1.0 - way * 2e-3, 1.0], 1.0 + way * 0.01, 0.002),
                [(1.0 - way * 4e-3, 0.480), (1.0 - way * 2e-3, 0.481), (1.0, 0.4955)],
                [(1.0 - way * 4e-3, 0.4955), (1.0 - way * 2e-3, 0.4931), (1.0, 0.490)]):
        br = _fake_branch(prob, pts)
        assert locking_ahead(br, prob) is None
        classify_circle_end(br, prob)
        assert br.status is BranchStatus.STEP_TOO_SMALL


def test_the_node_and_the_saddle_born_at_a_tongues_edge_are_told_by_their_multipliers():
    """The rotor's two orbits of two periods 1e-3 into its 1:2 tongue (multipliers as measured there, rounded):
    the node with all inside the unit circle and 0.952 near +1, the saddle with 1.078 alone outside."""
    from types import SimpleNamespace

    from contin.bifurcation.circle_branch import _saddle_node_pair

    saddle = SimpleNamespace(multipliers=np.array([1.0782, 0.96497, 0.38565 + 0.86715j, 0.38565 - 0.86715j, 2e-3]))
    node = SimpleNamespace(multipliers=np.array([0.32606 + 0.93142j, 0.32606 - 0.93142j, 0.95184, 0.89635, -2e-3]))
    assert _saddle_node_pair([saddle, node]) == (node, saddle)
    far = SimpleNamespace(multipliers=np.array([1.5, 0.5, 0.1]))  # unstable, but not near the saddle-node
    two_nodes = [node, SimpleNamespace(multipliers=np.array([0.97, 0.2]))]
    for orbits in ([far, node], two_nodes, [node], [saddle, node, node]):
        assert _saddle_node_pair(orbits) is None


def test_locked_orbits_finds_the_period_two_orbit_of_a_ring_and_its_half_turn():
    """The damped Mathieu-Duffing oscillator in its principal tongue (x'' + 0.05 x' + (1/4 + 0.2 cos t) x + x^3 = 0)
    has a stable orbit of two forcing periods whose states at t = kT alternate z, -z (the equation is symmetric
    under x -> -x with a shift of one period). From a ring through z and -z the multiple shooting of
    locked_orbits finds it, with the rotation 1/2; scipy's DOP853 takes z to -z over one forcing period."""
    P = {"delta": 0.25, "eps": 0.2, "c": 0.05, "g": 1.0, "w": 1.0}
    model = build_model("mathieu", P)
    z = simulate(model, {}, [0.05], [0.0], periods=300, steps_per_period=256, record_every=256).section[-1]
    N = 11
    th = 2 * np.pi * np.arange(N) / N
    U = np.cos(th)[:, None] * z + np.sin(th)[:, None] * np.array([-z[1], z[0]])
    prob = InvariantCircleProblem(model, "w", options=CircleOptions(points=N, steps_per_period=256))
    orbits = locked_orbits(prob, prob.unknowns(U, 0.5), 1.0, 2)
    moving = [o for o in orbits if np.max(np.abs(o.unknowns)) > 1e-6]
    assert len(moving) == 1  # the trivial orbit may be found too (unstable: the tongue)
    o = moving[0]
    assert o.rotation == Fraction(1, 2) and np.max(np.abs(o.multipliers)) < 1.0  # measured 0.730
    z0, z1 = o.unknowns.reshape(2, 2)
    np.testing.assert_allclose(z1, -z0, atol=1e-10)

    def rhs(t, y):
        return [y[1], -P["c"] * y[1] - (P["delta"] + P["eps"] * np.cos(t)) * y[0] - P["g"] * y[0] ** 3]

    end = solve_ivp(rhs, (0.0, 2 * np.pi), z0, method="DOP853", rtol=1e-12, atol=1e-14).y[:, -1]
    np.testing.assert_allclose(end, -z0, atol=1e-7)
    assert all(np.max(np.abs(t.multipliers)) > 1.0 for t in orbits if t is not o)
    with pytest.raises(ValueError, match="q must be a positive integer"):
        locked_orbits(prob, prob.unknowns(U, 0.5), 1.0, 0)


@pytest.mark.slow
def test_the_rotors_torus_verdicts_agree_with_the_normal_form_and_a_long_simulation():
    """The bearing rotor at f0 = 0.5: the circle branch from the Neimark-Sacker point near w = 1.8508, with the
    scene's stability (CircleStabilityMonitor: the exponents of the Jacobians interpolated along the circle,
    at N and 2N angles, their difference the error). The torus is born on the side where the harmonic orbit is
    stable (subcritical), so it is unstable, its radial exponent near the point twice the orbit's
    ``-ln |mu|`` of its critical pair (the normal form ``r' = (1 + m) r + a r^3``, ``r*^2 = -m / a``: the
    slope ``1 - 2 m``), the orbit's multipliers from its own shooting. The exponent follows it (measured:
    +2.98e-5 against +2.81e-5 at 1.85066, +1.27e-3 against +1.35e-3 at 1.8423); near the point, below the
    verdict's floor, there is no verdict (a simulation's "stable" there contradicts the exponent's sign, and
    is dropped), beyond it every verdict is unstable, and a simulation of 8000 revolutions started on the
    circle at 1.8388 leaves it."""
    from contin.bifurcation.circle_branch import CircleStabilityMonitor

    model = build_model("bearing_rotor", {"f0": 0.5})
    n = model.n_dof
    w_ns = 1.8508364869  # the harmonic branch's (docs/tutorials/rotor.md)
    opts = ShootingOptions(steps_per_period=4096)
    run = simulate(model, {"w": w_ns - 0.002}, np.zeros(n), np.zeros(n), periods=400, steps_per_period=1024,
                   record_every=1024)
    orbit = periodic_orbit(model, {"w": w_ns - 0.002}, run.section[-1], opts)
    orbit = periodic_orbit(model, {"w": w_ns}, orbit.state, opts)
    problem, u0, tangent = circle_start(model, "w", orbit.state, w_ns,
                                        options=CircleOptions(points=15, steps_per_period=4096))
    monitor = CircleStabilityMonitor(problem)
    br = follow_circle(problem, u0, w_ns, (1.835, 2.0), ContinuationOptions(ds=0.004, max_points=40),
                       tangent=tangent, monitors=[monitor])
    assert br.status is BranchStatus.RANGE_END
    stable = np.asarray(br.point_data["stable"], dtype=bool)
    decided = np.asarray(br.point_data["evaluated"], dtype=bool)
    exponent = np.asarray(br.point_data["normal_exponent"], dtype=float)
    w = np.asarray(br.parameter)
    assert not np.any(stable[decided]) and np.all(decided[w < 1.8485])
    for i in np.flatnonzero(w < w_ns - 1e-4):
        mu = np.max(np.abs(periodic_orbit(model, {"w": float(w[i])}, orbit.state, opts).multipliers))
        assert exponent[i] == pytest.approx(-2.0 * np.log(mu), rel=0.1)
    i = int(np.argmin(np.abs(w - 1.8388)))
    u = br.unknowns[i]
    dense = problem.points_on_circle(u, np.linspace(0.0, 2 * np.pi, 3000, endpoint=False))
    z = problem.blocks(u)[0][0]
    sim = simulate(model, {"w": float(w[i])}, z[:n], z[n:], periods=8000, steps_per_period=4096, record_every=4096)
    assert float(np.min(np.linalg.norm(dense - sim.section[-1], axis=1))) > 1e-3


def test_orbits_of_fewer_periods_are_not_taken_for_a_locking():
    """Inside the entrained range (w = 0.96) the stable harmonic orbit attracts Newton from points near it; run
    twice it is an orbit of two periods too, but not one on a 1:2 tongue: locked_orbits leaves it out, while the
    same points solved for one period find it."""
    run = simulate(vdp_model(), {"w": 0.96}, np.zeros(1), np.zeros(1), periods=300, steps_per_period=1024,
                   record_every=1024)
    z = run.section[-1]
    prob = InvariantCircleProblem(vdp_model(), "w", options=CircleOptions(points=5, steps_per_period=1024))
    ring = z + 1e-3 * np.array([[np.cos(a), np.sin(a)] for a in 2 * np.pi * np.arange(5) / 5])
    u = prob.unknowns(ring, 0.1)
    assert locked_orbits(prob, u, 0.96, 2) == []
    ones = locked_orbits(prob, u, 0.96, 1)
    assert len(ones) == 1 and np.max(np.abs(ones[0].unknowns - z)) < 1e-6


def test_a_locked_circle_starts_the_branches_of_its_orbits(monkeypatch):
    """A circle branch of the damped Mathieu-Duffing oscillator that ends locked at 1/2 (the ring of the test
    above, its end told by classify_circle_end): locked_starts gives the first point of the orbit of two periods
    (the trivial orbit, of one period, is left out), found by multiple shooting of two segments and followed by
    single shooting (its multipliers are small), with a tangent in the kernel of [dR/du dR/dlam] that goes on the
    way the circle branch went."""
    from contin.bifurcation.circle_branch import locked_starts
    from contin.timedomain.shooting_section import unknowns_at

    model = build_model("mathieu", {"delta": 0.25, "eps": 0.2, "c": 0.05, "g": 1.0, "w": 1.0})
    z = simulate(model, {}, [0.05], [0.0], periods=300, steps_per_period=256, record_every=256).section[-1]
    N = 11
    th = 2 * np.pi * np.arange(N) / N
    U = np.cos(th)[:, None] * z + np.sin(th)[:, None] * np.array([-z[1], z[0]])
    prob = InvariantCircleProblem(model, "w", options=CircleOptions(points=N, steps_per_period=256))
    b = BranchBuilder("w", prob.size)
    for k, (w, rho) in enumerate(((1.001, 0.4985), (1.0, 0.4999))):  # a branch going down in w
        b.append_point(prob.unknowns(U, rho), w, np.r_[np.zeros(prob.size), -1.0], k * 1e-3, 3, 1e-3, 1e-12,
                       {"circle_spread": 0.1})
    br = b.finish(BranchStatus.STEP_TOO_SMALL, "step size fell below ds_min")
    classify_circle_end(br, prob)
    assert br.special_points[-1].kind is SpecialKind.LOCKING
    starts = locked_starts(prob, br)
    assert len(starts) == 1
    st = starts[0]
    assert st.problem.nu == 2 and st.problem.segments == 1 and st.lam < 1.0
    assert st.problem.options.start_step == 0  # no contact to keep the section away from
    R, Ju, Jlam = st.problem.linearize(st.u, st.lam)
    assert np.abs(R).max() < 1e-9
    assert np.linalg.norm(np.c_[Ju, Jlam] @ st.tangent) < 1e-8 and st.tangent[-1] < 0.0
    z0, z1 = unknowns_at(st.problem, st.u, st.lam, 0, segments=2).reshape(2, 2)  # at t = 0 and t = T
    np.testing.assert_allclose(z1, -z0, atol=1e-8)  # the symmetric orbit of the test above

    # in a diagram the orbit's branch is followed as the circle branch's child, its origin the locking point
    from contin.bifurcation.diagram import BifurcationDiagram, _locked_children
    from contin.stability import StabilityOptions

    d = BifurcationDiagram()
    d.branches.append(br)
    d.problems.append(prob)
    d.parents.append(None)
    d.origins.append(None)
    d.monitors.append(None)
    assert _locked_children(d, 0, (0.95, 1.05), ContinuationOptions(ds=0.01, max_points=8),
                            StabilityOptions.from_dict({"method": "floquet"}), "w", lambda j, p: None,
                            lambda j, p: None, {}, 8)
    assert len(d) == 2 and d.parents[1] == 0 and d.branches[1].info["origin"]["kind"] == "locking"
    child, orbit = d.branches[1], d.problems[1]
    assert len(child) >= 5 and child.status.as_asked and child.parameter[-1] < st.lam  # on into the tongue

    # a branch whose steps stopped short of the tongue (4.5e-3 from 1/2, the edge extrapolated to w = 0.999):
    # the orbit is sought at the edge first
    b = BranchBuilder("w", prob.size)
    for k, (w, rho) in enumerate(_square_root_law([1.004, 1.002, 1.0], 0.999, 0.02025)):
        b.append_point(prob.unknowns(U, rho), w, np.r_[np.zeros(prob.size), -1.0], k * 1e-3, 3, 1e-3, 1e-12,
                       {"circle_spread": 0.1})
    br = b.finish(BranchStatus.STEP_TOO_SMALL, "step size fell below ds_min")
    classify_circle_end(br, prob)
    assert br.special_points[-1].kind is SpecialKind.LOCKING and "predicted" in br.special_points[-1].data
    (st,) = locked_starts(prob, br)
    assert st.lam == pytest.approx(0.999, abs=1e-12) and st.eps == pytest.approx(1e-3, abs=1e-12)
    z0, z1 = unknowns_at(st.problem, st.u, st.lam, 0, segments=2).reshape(2, 2)
    np.testing.assert_allclose(z1, -z0, atol=1e-8)

    # where the orbits found are a node and a saddle born together at the edge (their multipliers made so
    # here), the node's branch is started twice: on into the tongue and back to the edge
    import contin.bifurcation.circle_branch as cb

    found = cb.locked_orbits(prob, br.unknowns[-1], 0.999, 2)
    o = [f for f in found if np.max(np.abs(f.unknowns)) > 1e-6][0]
    node = cb.LockedOrbit(o.problem, o.unknowns, o.rotation, o.distance, np.array([0.95, 0.5]))
    saddle = cb.LockedOrbit(o.problem, -o.unknowns, o.rotation, o.distance, np.array([1.07, 0.5]))
    monkeypatch.setattr(cb, "locked_orbits", lambda *a, **k: [saddle, node])
    into, back = locked_starts(prob, br)
    assert np.array_equal(into.u, node.unknowns[:2]) and np.array_equal(back.u, node.unknowns[:2])
    assert into.tangent[-1] < 0.0 < back.tangent[-1] and (into.side, back.side) == (1, -1)
    assert all(np.abs(orbit.residual(u, w)).max() < 1e-8 for u, w in zip(child.unknowns, child.parameter))
