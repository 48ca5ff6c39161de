"""Stability verdicts along branches: options, Duffing against time integration, damped Mathieu."""

import dataclasses

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

import contin.stability.floquet as floquet_module
import contin.stability.verdict as verdict_module
from contin.model.catalog import build_model
from contin.engine.continuation import ContinuationOptions, continuation
from contin.model.elements import GapForce
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.model.base import Monomial
from contin.models.polynomial import polynomial_model
from contin.stability import (
    StabilityChangeEvent,
    StabilityMethod,
    StabilityMonitor,
    StabilityOptions,
    classify_multipliers,
    floquet_multipliers,
    hill_spectrum,
    monodromy_reference,
    monodromy_rk4,
    multiplier_distance,
    orbit_state,
    stability_events,
)

# ---------------------------------------------------------------------------
# options
# ---------------------------------------------------------------------------


@pytest.mark.parametrize(
    "kwargs, field",
    [
        ({"tolerance": -1e-6}, "StabilityOptions.tolerance"),
        ({"tolerance": float("nan")}, "StabilityOptions.tolerance"),
        ({"steps_per_period": 4}, "StabilityOptions.steps_per_period"),
        ({"steps_per_period": 100.0}, "StabilityOptions.steps_per_period"),
        ({"real_angle_tol": 0.0}, "StabilityOptions.real_angle_tol"),
        ({"ambiguity_threshold": 1.5}, "StabilityOptions.ambiguity_threshold"),
        ({"shift_tol": 1.0}, "StabilityOptions.shift_tol"),
        ({"rtol": 0}, "StabilityOptions.rtol"),
        ({"eigenvectors": "yes"}, "StabilityOptions.eigenvectors"),
        ({"method": 3}, "StabilityOptions.method"),
    ],
)
def test_options_validation_names_the_field(kwargs, field):
    with pytest.raises(ValueError, match=field.replace(".", r"\.")):
        StabilityOptions(**kwargs)


def test_options_suggestions_and_aliases():
    with pytest.raises(ValueError, match=r"StabilityOptions\.method.*did you mean 'hill'"):
        StabilityOptions(method="hil")
    with pytest.raises(ValueError, match=r"StabilityOptions\.integrator.*did you mean 'rk4'"):
        StabilityOptions(integrator="rk5")
    with pytest.raises(ValueError, match="unknown option 'tolerence'.*did you mean 'tolerance'"):
        StabilityOptions.from_dict({"tolerence": 1e-6})
    with pytest.raises(ValueError, match="did you mean 'steps_per_period'"):
        StabilityOptions.from_dict({"step_per_period": 100})
    with pytest.raises(ValueError, match="did you mean 'method'"):
        StabilityOptions().replace(methods="hill")
    assert StabilityOptions(method="monodromy").method is StabilityMethod.FLOQUET
    assert StabilityOptions.from_dict({"method": "BOTH", "tolerance": 1e-8}).tolerance == 1e-8
    opts = StabilityOptions()
    with pytest.raises(dataclasses.FrozenInstanceError):
        opts.tolerance = 1.0
    assert StabilityOptions.from_dict(opts.to_dict()) == opts


def test_classify_multipliers():
    mu = np.array([1.5, 0.5, -1.2, -0.3, 1.1 * np.exp(2j), 1.1 * np.exp(-2j), 1 + 1e-8, np.exp(1j)])
    assert classify_multipliers(mu, 1e-6) == (1, 1, 2)
    assert classify_multipliers(mu, 1e-9) == (2, 1, 2)


# ---------------------------------------------------------------------------
# forced Duffing: folds, the unstable middle branch, time integration
# ---------------------------------------------------------------------------

C, F = 0.1, 0.5


def duffing_rhs(w):
    def rhs(t, y):
        return [y[1], F * np.cos(w * t) - C * y[1] - y[0] - y[0] ** 3]

    return rhs


@pytest.fixture(scope="module")
def duffing_branch():
    hb = HarmonicBalance(build_model("duffing", {"F": F}), "w", HBOptions(harmonics=9))
    mon = StabilityMonitor(hb, StabilityOptions(method="both"))
    br = continuation(hb, hb.linear_solution(0.5), 0.5, (0.5, 3.0), ContinuationOptions(), parameter_name="w",
                      events=stability_events(mon), monitors=[mon])
    return hb, br, mon


def test_duffing_unstable_between_the_folds(duffing_branch):
    hb, br, mon = duffing_branch
    folds = br.points_of_kind("fold")
    assert len(folds) == 2
    s_lo, s_hi = sorted(p.s for p in folds)
    d = br.point_data
    inside = (br.arclength > s_lo) & (br.arclength < s_hi)
    assert inside.sum() >= 3
    # exactly one real multiplier > 1 between the folds, none elsewhere
    assert np.all(d["n_unstable"][inside] == 1) and np.all(d["n_plus"][inside] == 1)
    assert np.all(d["stable"][~inside]) and np.all(d["n_unstable"][~inside] == 0)
    for mu in d["multipliers"][inside]:
        big = mu[np.abs(mu) > 1]
        assert big.size == 1 and abs(big[0].imag) == 0.0 and big[0].real > 1
    # the stability change is the fold itself: +1 crossing there, no extra bp reported
    assert not br.points_of_kind("bp")
    for p in folds:
        mu = p.point_data["multipliers"]
        assert np.min(np.abs(mu - 1)) < 1e-3
    assert mon.disagreements == []


@pytest.mark.parametrize("target, expect_stable", [(1.2, True), (1.9, True), (1.9, False), (2.8, True)])
def test_duffing_stability_agrees_with_time_integration(duffing_branch, target, expect_stable):
    """From the HB state plus a 1e-4 perturbation: stable orbits pull it back, the middle one ejects it."""
    hb, br, _ = duffing_branch
    d = br.point_data
    cand = [i for i in range(len(br)) if bool(d["stable"][i]) == expect_stable]
    i = min(cand, key=lambda j: abs(br.parameter[j] - target))
    assert abs(br.parameter[i] - target) < 0.15
    u, w = br.point(i)
    T = 2 * np.pi / w
    z0 = orbit_state(hb, u, w, 0.0)
    periods = 40
    sol = solve_ivp(duffing_rhs(w), (0, periods * T), z0 + np.array([1e-4, -1e-4]), method="DOP853",
                    rtol=1e-10, atol=1e-12, t_eval=T * np.arange(periods + 1))
    dev = np.abs(sol.y.T - z0).max(axis=1)  # stroboscopic distance from the periodic orbit
    if expect_stable:
        assert dev[-1] < 1e-5
    else:
        assert dev[-1] > 0.1
        # growth rate in the first periods matches the unstable multiplier
        mu = np.abs(d["multipliers"][i]).max()
        rate = (dev[8] / dev[2]) ** (1 / 6)
        assert abs(rate - mu) < 0.1 * mu


# ---------------------------------------------------------------------------
# damped Mathieu: period doubling boundary
# ---------------------------------------------------------------------------


def mathieu_monodromy(delta, eps, c):
    """Phi(2 pi) of x'' + c x' + (delta + eps cos t) x = 0 (two fundamental solutions, DOP853)."""

    def rhs(t, y):
        x, v = y[:2], y[2:]
        return np.concatenate([v, -(delta + eps * np.cos(t)) * x - c * v])

    y = solve_ivp(rhs, (0, 2 * np.pi), [1.0, 0.0, 0.0, 1.0], method="DOP853", rtol=1e-13, atol=1e-14).y[:, -1]
    return np.array([[y[0], y[1]], [y[2], y[3]]])


def pd_boundary(eps, c, lo, hi):
    """delta where -1 is a multiplier: det(Phi + I) = 1 + tr Phi + det Phi = 0, det Phi = exp(-2 pi c)."""
    return brentq(lambda d: 1 + np.trace(mathieu_monodromy(d, eps, c)) + np.exp(-2 * np.pi * c), lo, hi, xtol=1e-13)


@pytest.mark.parametrize("method", ["both", "floquet"])
def test_damped_mathieu_first_tongue(method):
    """Period-doubling boundaries of x'' + c x' + (delta + eps cos t) x = 0.

    First-order harmonic balance with x = a cos(t/2) + b sin(t/2) gives
    (delta - 1/4 + eps/2) a + (c/2) b = 0 and -(c/2) a + (delta - 1/4 - eps/2) b = 0,
    hence (delta - 1/4)^2 + c^2/4 = eps^2/4 (Nayfeh & Mook, Nonlinear Oscillations,
    1979, sec. 5.2.3): damping narrows the tongue, which only exists for eps > c. The
    exact boundary (reference) solves det(Phi + I) = 0 for the monodromy computed
    independently by scipy; the first-order formula is checked to O(eps^2).
    """
    eps, c = 0.4, 0.1
    model = build_model("mathieu", {"c": c, "g": 0.0, "eps": eps}, effects=["parametric", "damping"])
    hb = HarmonicBalance(model, "delta", HBOptions(harmonics=8))
    mon = StabilityMonitor(hb, StabilityOptions(method=method))
    br = continuation(hb, np.zeros(hb.size), -0.15, (-0.15, 0.6), ContinuationOptions(ds=0.01, ds_max=0.02),
                      parameter_name="delta", events=stability_events(mon), monitors=[mon])
    pds = br.points_of_kind("pd")
    assert len(pds) == 2
    half = 0.5 * np.sqrt(eps**2 - c**2)
    first_order = [0.25 - half, 0.25 + half]
    exact = [pd_boundary(eps, c, 0.0, 0.2), pd_boundary(eps, c, 0.3, 0.6)]
    for p, ref, approx in zip(pds, exact, first_order):
        assert abs(p.parameter - ref) < 1e-6
        assert abs(p.parameter - approx) < eps**2 / 4
        assert abs(p.data["multiplier"] + 1) < 1e-4
    # the r = 0 boundary (multiplier +1, det(Phi - I) = 0) is a branch point of the trivial branch;
    # the margin |mu| > 1 + tol biases a transversal crossing by tol / |d mu / d delta| (~1e-8)
    bp_ref = brentq(lambda d: 1 - np.trace(mathieu_monodromy(d, eps, c)) + np.exp(-2 * np.pi * c), -0.15, 0.0,
                    xtol=1e-13)
    bps = [p for p in br.points_of_kind("bp") if p.event.startswith("stability")]
    assert len(bps) == 1 and abs(bps[0].parameter - bp_ref) < 1e-6
    inside = (br.parameter > exact[0] + 1e-6) & (br.parameter < exact[1] - 1e-6)
    assert np.all(br.point_data["n_minus"][inside] == 1)


def test_unclassified_stability_event_classifies_in_its_data():
    model = build_model("mathieu", {"c": 0.1, "g": 0.0, "eps": 0.4}, effects=["parametric", "damping"])
    hb = HarmonicBalance(model, "delta", HBOptions(harmonics=6))
    mon = StabilityMonitor(hb, StabilityOptions(method="hill"))
    br = continuation(hb, np.zeros(hb.size), -0.15, (-0.15, 0.6), ContinuationOptions(ds=0.01, ds_max=0.02),
                      parameter_name="delta", events=[StabilityChangeEvent(mon)], monitors=[mon])
    kinds = [p.data["classification"] for p in br.points_of_kind("stability")]
    assert kinds == ["bp", "pd", "pd"]


# ---------------------------------------------------------------------------
# method 'both': disagreements are flagged and the monodromy wins
# ---------------------------------------------------------------------------


def test_both_trusts_the_monodromy_on_disagreement(monkeypatch):
    hb = HarmonicBalance(build_model("duffing", {"F": F}), "w", HBOptions(harmonics=5))
    w = 0.8
    from contin.engine.newton import solve_at_parameter

    u = solve_at_parameter(hb, hb.linear_solution(w), w).x
    true = floquet_multipliers(hb, u, w, StabilityOptions(method="floquet"))
    assert true.stable
    real_spectrum = floquet_module.hill_spectrum

    def wrong_spectrum(*args, **kwargs):
        spec = real_spectrum(*args, **kwargs)
        return dataclasses.replace(spec, multipliers=spec.multipliers * 3.0)

    monkeypatch.setattr(floquet_module, "hill_spectrum", wrong_spectrum)
    res = floquet_multipliers(hb, u, w, StabilityOptions(method="both"), previous=(0, 0, 0))
    assert res.disagreement and not res.marginal and res.confirmed
    assert res.method is StabilityMethod.FLOQUET and res.stable
    assert multiplier_distance(res.multipliers, true.multipliers) < 1e-12
    mon = StabilityMonitor(hb, StabilityOptions(method="both"))
    data = mon(u, w)  # recorded; told once per branch by report(), counting the branch's points
    assert data["disagreement"] and data["stable"] and mon.disagreements == [w]
    # Hill alone would have reported the wrong verdict
    assert not floquet_multipliers(hb, u, w, StabilityOptions(method="hill")).stable


def test_both_confirms_only_where_needed(duffing_branch):
    hb, br, mon = duffing_branch
    stats = mon.statistics()
    # the first point, the verdict changes near the two folds (and their location steps)
    assert 3 <= stats["confirmations"] < stats["evaluations"] / 2
    assert br.point_data["confirmed"][0]


def test_method_none_is_rejected():
    hb = HarmonicBalance(build_model("duffing"), "w", HBOptions(harmonics=3))
    with pytest.raises(ValueError, match="none"):
        floquet_multipliers(hb, np.zeros(hb.size), 1.0, StabilityOptions(method="none"))
    with pytest.raises(ValueError, match="none"):
        StabilityMonitor(hb, StabilityOptions(method="none"))


# ---------------------------------------------------------------------------
# Hill against monodromy on every test system
# ---------------------------------------------------------------------------


def test_hill_against_monodromy_on_all_systems(duffing_branch):
    """|mu_Hill - mu_RK4| after optimal pairing, smooth systems: <= 1e-6.

    Both use the same HB orbit, so the difference is Hill's truncation of the
    perturbation (exponentially small in H for smooth forces; H = 9 here) plus
    the RK4 error ~ (w_eff h)^4 T/120 (~1e-8 at S = 1024). For the piecewise-linear
    clearance oscillator Hill converges only algebraically in H (the sampled
    Jacobian is a step function; measured at w = 0.9: 0.042, 0.048, 0.020, 0.006
    for H = 10, 20, 40, 80) and RK4 is first order (~2 h): the stated tolerance
    there is 0.1 for H = 20, S = 2048.
    """
    hb, br, _ = duffing_branch
    for i in range(0, len(br), 6):
        u, w = br.point(i)
        h = hill_spectrum(hb, u, w).multipliers
        m = monodromy_rk4(hb, u, w, 1024).multipliers
        assert multiplier_distance(h, m) < 1e-6, w
    # Mathieu-Duffing on a non-trivial 2T-periodic orbit is checked in test_switching.py
    model = polynomial_model(["x"], {"c": 0.05, "F": 0.3, "w": 1.0}, mass=[[1.0]], damping=[["c"]],
                             stiffness=[[1.0]], forcing=[{"dof": "x", "amplitude": "F"}])
    model.forces.append(GapForce(0, Monomial(0.5), Monomial(4.0)))
    hbg = HarmonicBalance(model, "w", HBOptions(harmonics=20))
    gb = continuation(hbg, hbg.linear_solution(0.9), 0.9, (0.9, 1.5), ContinuationOptions(max_points=200))
    for i in range(0, len(gb), 4):
        u, w = gb.point(i)
        d = multiplier_distance(hill_spectrum(hbg, u, w).multipliers, monodromy_rk4(hbg, u, w, 2048).multipliers)
        assert d < 0.1, (w, d)


# ---------------------------------------------------------------------------
# Neimark-Sacker: the forced van der Pol oscillator
# ---------------------------------------------------------------------------


def test_forced_van_der_pol_neimark_sacker():
    """x'' - mu (1 - x^2) x' + x = F cos(w t), mu = 0.2, F = 0.5.

    The forced response is stable only inside the entrainment band; at its ends a
    complex pair leaves the unit circle (Neimark-Sacker, onset of quasi-periodic
    motion). Checks: the kind, |mu| = 1 with a non-real multiplier at both ends,
    Hill and the monodromy locating the same points, and time integration: inside
    the band a perturbed start returns to the orbit, outside it drifts away.
    """
    mu, F = 0.2, 0.5
    model = polynomial_model(["x"], {"mu": mu, "F": F, "w": 1.0}, mass=[[1.0]], damping=[["-mu"]],
                             stiffness=[[1.0]], nonlinear=[{"dof": "x", "coef": "mu", "x": {"x": 2}, "v": {"x": 1}}],
                             forcing=[{"dof": "x", "amplitude": "F"}])
    hb = HarmonicBalance(model, "w", HBOptions(harmonics=7))
    found = {}
    for method in ("hill", "floquet"):
        mon = StabilityMonitor(hb, StabilityOptions(method=method))
        br = continuation(hb, hb.linear_solution(0.6), 0.6, (0.6, 1.4), ContinuationOptions(), parameter_name="w",
                          events=stability_events(mon), monitors=[mon])
        ns = br.points_of_kind("ns")
        assert len(ns) == 2 and len(br.special_points) == 4  # start, 2 x ns, end
        for p in ns:
            m = p.data["multiplier"]
            assert abs(abs(m) - 1) < 1e-4 and 0.1 < abs(np.angle(m)) < np.pi - 0.1
        found[method] = [p.parameter for p in ns]
        if method == "hill":
            hill_branch = br
    np.testing.assert_allclose(found["hill"], found["floquet"], atol=1e-6)
    lo, hi = found["hill"]

    def rhs(w):
        return lambda t, y: [y[1], F * np.cos(w * t) + mu * (1 - y[0] ** 2) * y[1] - y[0]]

    d = hill_branch.point_data
    for target, stable in ((0.5 * (lo + hi), True), (lo - 0.08, False)):
        i = int(np.argmin(np.abs(hill_branch.parameter - target)))
        assert bool(d["stable"][i]) == stable and (stable or d["n_complex"][i] == 2)
        u, w = hill_branch.point(i)
        T = 2 * np.pi / w
        z0 = orbit_state(hb, u, w, 0.0)
        sol = solve_ivp(rhs(w), (0, 60 * T), z0 + 1e-3, method="DOP853", rtol=1e-10, atol=1e-12,
                        t_eval=[59 * T, 60 * T])
        dev = np.abs(sol.y[:, -1] - z0).max()
        if stable:
            # converged onto a periodic orbit, which is the HB one up to its truncation error (H = 7:
            # the true flow misses the start by orbit_error ~ 3e-5 after a period); the fixed point of
            # the period map lies within orbit_error / (1 - |mu|max) of the start
            hb_error = monodromy_reference(hb, u, w).orbit_error
            assert np.abs(sol.y[:, -1] - sol.y[:, 0]).max() < 1e-7
            assert dev < 2 * hb_error / (1 - d["max_multiplier"][i]) + 1e-6, (w, dev, hb_error)
        else:
            assert dev > 1e-2, (w, dev)


# --------------------------------------------------------------------------
# the classified events on multipliers given in closed form
# --------------------------------------------------------------------------
class _Line:
    def linearize(self, u, lam):
        return np.array([u[0] - lam]), np.array([[1.0]]), np.array([-1.0])


class _ClosedFormMonitor:
    """A stability monitor whose multipliers are closed-form functions of the parameter."""

    hb = None

    def __init__(self, multipliers):
        self.multipliers = multipliers
        self.options = StabilityOptions(method="floquet")
        self.calls = 0

    def analyze(self, u, lam):
        self.calls += 1
        return verdict_module.monodromy_result(self.multipliers(lam), 1.0, self.options)

    def __call__(self, u, lam, Ju=None, Jlam=None):
        return self.analyze(u, lam).monitor_data()


TOL = 1e-6
A = 0.3  # speed of the pair along the real axis after it collides


def _collide_then_cross(lam):
    """A pair outside the circle colliding on the negative real axis at 0.3 (no bifurcation); one of
    the two reals then crosses -1 inwards (a period doubling); another pair leaves the circle at 0.7."""
    d = lam - 0.3
    if d < 0:
        pair = -1.02 * np.exp(np.array([1j, -1j]) * A * np.sqrt(-d))
    else:
        pair = -1.02 * np.exp(np.array([1.0, -1.0]) * A * np.sqrt(d))
    ns = (0.5 + (lam / 0.7) * 0.5) * np.exp(np.array([1j, -1j]))
    return np.concatenate([pair, ns, [0.5, 0.2]]).astype(complex)


def test_period_doubling_only_where_a_real_multiplier_crosses_minus_one():
    mon = _ClosedFormMonitor(_collide_then_cross)
    br = continuation(_Line(), [0.0], 0.0, (0.0, 1.0), ContinuationOptions(ds=0.02, ds_max=0.1),
                      monitors=[mon], events=stability_events(mon))
    lam_pd = 0.3 + (np.log(1.02 / (1 + TOL)) / A) ** 2  # |mu| = 1 + tolerance
    lam_ns = 0.7 * (1 + TOL - 0.5) / 0.5
    got = sorted(((p.kind.value, p.parameter) for p in br.special_points if p.kind.value in ("pd", "ns", "bp")),
                 key=lambda kp: kp[1])
    assert [k for k, _ in got] == ["pd", "ns"]  # nothing at the collision (0.3)
    assert got[0][1] == pytest.approx(lam_pd, abs=1e-10)
    assert got[1][1] == pytest.approx(lam_ns, abs=1e-10)
    for p in br.special_points:
        if p.kind.value in ("pd", "ns"):
            assert p.located
            assert int(p.message.split("located in ")[1].split()[0]) <= 12  # superlinear, not bisection


def test_a_narrow_stable_window_is_not_stepped_over():
    """A pair that leaves the circle at 0.5 and returns at 0.52: the steps stay near the predicted crossings."""

    def window(lam):
        r = 1.0 + 0.5 * ((lam - 0.51) ** 2 - 0.01 ** 2)
        return np.array([r * np.exp(1j), r * np.exp(-1j), 0.3, 0.1], dtype=complex)

    mon = _ClosedFormMonitor(window)
    br = continuation(_Line(), [0.0], 0.0, (0.0, 1.0), ContinuationOptions(ds=0.05, ds_max=0.5),
                      monitors=[mon], events=stability_events(mon))
    ns = [p.parameter for p in br.points_of_kind("ns")]
    root = np.sqrt(0.01 ** 2 + 2.0 * TOL)  # 0.5 (d^2 - 0.01^2) = tolerance
    assert ns == pytest.approx([0.51 - root, 0.51 + root], abs=1e-10)
    assert len(br) < 40


def test_locating_a_tongue_boundary_of_a_conservative_system_takes_a_few_solves():
    """Multipliers on the circle meeting at +1 (undamped): the product test is smooth where |mu| is flat."""

    def tongue(lam):
        if lam < 0.4:
            th = np.sqrt(0.4 - lam)
            return np.array([np.exp(1j * th), np.exp(-1j * th)])
        r = np.exp(np.sqrt(lam - 0.4))
        return np.array([r, 1.0 / r], dtype=complex)

    mon = _ClosedFormMonitor(tongue)
    br = continuation(_Line(), [0.0], 0.0, (0.0, 1.0), ContinuationOptions(ds=0.05, ds_max=0.05),
                      monitors=[mon], events=stability_events(mon))
    (bp,) = br.points_of_kind("bp")
    assert bp.parameter == pytest.approx(0.4 + np.log(1 + TOL) ** 2, abs=1e-10)
    assert int(bp.message.split("located in ")[1].split()[0]) <= 12


def test_a_window_opened_by_a_collision_near_the_circle_is_not_stepped_over():
    """A lightly damped pair (|mu| = 0.99) meets on the negative real axis at 0.6, splits into two real
    multipliers, one of which stays beyond -1 until they meet again at 0.604: a period-doubling window
    narrower than any step the moduli alone would allow (both ends of a long step are stable)."""
    lo, hi, r = 0.6, 0.604, 0.99

    def collide(lam):
        if lo < lam < hi:
            a = 2.0 * np.sqrt((lam - lo) * (hi - lam)) / (hi - lo)  # 1 in the middle of the window
            pair = -r * np.exp(np.array([1.0, -1.0]) * 0.05 * a)
        else:
            b = 0.5 * min(abs(lam - lo), abs(lam - hi))
            pair = -r * np.exp(np.array([1j, -1j]) * b)
        return np.concatenate([pair, [0.2, 0.1]]).astype(complex)

    mon = _ClosedFormMonitor(collide)
    br = continuation(_Line(), [0.0], 0.0, (0.0, 1.0), ContinuationOptions(ds=0.05, ds_max=0.5),
                      monitors=[mon], events=stability_events(mon))
    # -r exp(0.05 a) = -(1 + tolerance) where a = log((1 + TOL)/r)/0.05
    a = np.log((1 + TOL) / r) / 0.05
    half = 0.5 * (hi - lo) * np.sqrt(1 - a * a)
    pd = [p.parameter for p in br.points_of_kind("pd")]
    assert pd == pytest.approx([0.602 - half, 0.602 + half], abs=1e-10)


def test_a_zero_multiplier_has_the_exponent_minus_infinity_and_no_nan():
    """A multiplier of exactly zero (an impact that stops a dof: a zero row of a saltation matrix) has the
    exponent -inf; complex division by the period would make its imaginary part nan."""
    import warnings

    from contin.stability.verdict import log_exponents

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        e = log_exponents(np.array([0.0, -1.0, 0.5 + 0.5j]), 2.0)
    assert e[0].real == -np.inf and e[0].imag == 0.0
    np.testing.assert_allclose(e[1:], np.log(np.array([-1.0, 0.5 + 0.5j])) / 2.0, rtol=1e-15)
