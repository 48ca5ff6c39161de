"""Branch switching: period doubling onto the 1/2 subharmonic, and branch points.

System: the parametrically excited damped Duffing oscillator
x'' + c x' + (delta + eps cos t) x + g x^3 = 0, c = 0.1, eps = 0.4, g = 1, whose
trivial solution x = 0 is the natural nu = 1 branch (continued in delta). It
loses stability at the damped Mathieu boundaries: multiplier -1 on the first
tongue (period doubling, delta near 1/4), +1 on the r = 0 curve (branch point).
"""

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from contin.model.catalog import build_model
from contin.engine.continuation import ContinuationOptions
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.hb.harmonics import embed, harmonic_amplitudes
from contin.stability import (
    StabilityOptions,
    hill_spectrum,
    monodromy_rk4,
    multiplier_distance,
    orbit_state,
)
from contin.bifurcation.diagram import follow
from contin.bifurcation.switching import (
    doubled_problem,
    hill_vector_to_doubled,
    odd_indices,
    period_doubling_direction,
    switch_at,
)

C, EPS, G = 0.1, 0.4, 1.0


def linear_mathieu_monodromy(delta):
    """Phi(2 pi) of x'' + c x' + (delta + eps cos t) x = 0 by scipy (independent of contin)."""

    def rhs(t, y):
        x, v = y[:2], y[2:]
        return np.concatenate([v, -(delta + EPS * np.cos(t)) * x - C * v])

    y = solve_ivp(rhs, (0, 2 * np.pi), [1.0, 0.0, 0.0, 1.0], method="DOP853", rtol=1e-13, atol=1e-14).y[:, -1]
    return np.array([[y[0], y[1]], [y[2], y[3]]])


def boundary(sign, lo, hi):
    """delta where the multiplier sign*1 appears: 1 - sign tr Phi + det Phi = 0, det Phi = exp(-2 pi c)."""
    return brentq(lambda d: 1 - sign * np.trace(linear_mathieu_monodromy(d)) + np.exp(-2 * np.pi * C), lo, hi,
                  xtol=1e-13)


def nonlinear_rhs(delta):
    def rhs(t, y):
        return [y[1], -C * y[1] - (delta + EPS * np.cos(t)) * y[0] - G * y[0] ** 3]

    return rhs


@pytest.fixture(scope="module")
def diagram():
    model = build_model("mathieu", {"c": C, "g": G, "eps": EPS})
    hb = HarmonicBalance(model, "delta", HBOptions(harmonics=5))
    return follow(hb, np.zeros(hb.size), -0.2, (-0.2, 0.7), ContinuationOptions(ds=0.01, ds_max=0.05),
                  stability=StabilityOptions(method="both"), switch=("pd", "bp"))


def children(diagram, kind):
    return [i for i in range(1, len(diagram)) if diagram[i].info["origin"]["kind"] == kind]


def test_period_doublings_on_the_damped_mathieu_boundary(diagram):
    root = diagram[0]
    pds = [p for p in root.points_of_kind("pd")]
    assert len(pds) == 2
    ref = [boundary(-1, 0.0, 0.2), boundary(-1, 0.3, 0.6)]
    for p, r in zip(pds, ref):
        assert abs(p.parameter - r) < 1e-6
        assert abs(p.data["multiplier"] + 1) < 1e-4


def test_switched_branches_are_half_subharmonic(diagram):
    pd_children = children(diagram, "pd")
    assert len(pd_children) == 2
    pds = diagram[0].points_of_kind("pd")
    for i, sp in zip(pd_children, pds):
        br, hb2 = diagram[i], diagram.problems[i]
        assert diagram.parents[i] == 0 and br.info["parent"] == 0
        assert br.info["origin"]["parameter"] == sp.parameter and diagram.origins[i] is sp
        assert br.info["subharmonic"] == 2 and br.info["harmonics"] == 10 and hb2.nu == 2
        assert len(br) > 5
        # the first point is near the PD, with a non-zero half-order (odd) harmonic
        u0, d0 = br.point(0)
        amp = harmonic_amplitudes(u0, 1)[:, 0]
        assert abs(d0 - sp.parameter) < 1e-3
        assert amp[1] > 5e-3
        # x -> -x symmetry and the half-period shift: only odd harmonics of w/2 on this branch
        for u in br.unknowns:
            a = harmonic_amplitudes(u, 1)[:, 0]
            assert a[0::2].max() < 1e-10 * a.max()
    # supercritical at the upper boundary (stable near it), subcritical at the lower one
    lower, upper = (diagram[i] for i in pd_children)
    assert not lower.point_data["stable"][:3].any()
    assert upper.point_data["stable"][:3].all()


def test_switched_branch_agrees_with_time_integration(diagram):
    """solve_ivp from the HB state over one period 4 pi.

    Bound: |x_ivp - x_HB| <= 5 tau_H max(1, |mu|max) + 1e-9, with tau_H the
    largest amplitude of the last two retained harmonics (the a-posteriori HB
    truncation indicator, H = 10 here: the coefficients decay geometrically so the
    neglected tail is of that order) and |mu|max the largest multiplier (an
    unstable orbit amplifies the start mismatch by at most that over a period).
    """
    for i in children(diagram, "pd"):
        br, hb2 = diagram[i], diagram.problems[i]
        for j in (0, len(br) // 3, 2 * len(br) // 3, len(br) - 1):
            u, d = br.point(j)
            T = 4 * np.pi
            ts = np.linspace(0, T, 81)
            sol = solve_ivp(nonlinear_rhs(d), (0, T), orbit_state(hb2, u, d, 0.0), method="DOP853", rtol=1e-12,
                            atol=1e-13, t_eval=ts)
            err = np.abs(sol.y.T - orbit_state(hb2, u, d, ts)).max()
            tau = harmonic_amplitudes(u, 1)[-2:, 0].max()
            mu = np.abs(br.point_data["multipliers"][j]).max()
            assert err <= 5 * tau * max(1.0, mu) + 1e-9, (d, err, tau, mu)


def test_switched_branch_stability_agrees_with_time_integration(diagram):
    """A stable 2T-periodic point attracts a perturbed start; an unstable one repels it."""
    for i in children(diagram, "pd"):
        br, hb2 = diagram[i], diagram.problems[i]
        j = len(br) // 2
        u, d = br.point(j)
        z0 = orbit_state(hb2, u, d, 0.0)
        T = 4 * np.pi
        sol = solve_ivp(nonlinear_rhs(d), (0, 20 * T), z0 + 1e-4, method="DOP853", rtol=1e-10, atol=1e-12,
                        t_eval=[20 * T])
        dev = np.abs(sol.y[:, -1] - z0).max()
        if br.point_data["stable"][j]:
            assert dev < 1e-5
        else:
            assert dev > 1e-2


def test_hill_against_monodromy_on_the_subharmonic_branch(diagram):
    """Same tolerance statement as for the other systems: < 1e-6 for H = 10, S = 1024."""
    for i in children(diagram, "pd"):
        br, hb2 = diagram[i], diagram.problems[i]
        for j in range(0, len(br), 4):
            u, d = br.point(j)
            h = hill_spectrum(hb2, u, d).multipliers
            m = monodromy_rk4(hb2, u, d, 1024).multipliers
            assert multiplier_distance(h, m) < 1e-6 * max(1.0, np.abs(m).max())


def test_odd_block_decouples_and_is_singular_at_the_pd(diagram):
    root, hb = diagram[0], diagram.problems[0]
    sp = root.points_of_kind("pd")[1]
    hb2 = doubled_problem(hb)
    u2 = embed(sp.unknowns, 1, 2, hb2.H)
    _, Ju, Jlam = hb2.linearize(u2, sp.parameter)
    odd = odd_indices(1, hb2.H)
    even = np.setdiff1d(np.arange(hb2.size), odd)
    scale = np.abs(Ju).max()
    assert np.abs(Ju[np.ix_(odd, even)]).max() < 1e-14 * scale  # zero up to FFT rounding
    assert np.abs(Ju[np.ix_(even, odd)]).max() < 1e-14 * scale
    assert np.abs(Jlam[odd]).max() < 1e-14 * scale
    phi, sigma = period_doubling_direction(hb2, u2, sp.parameter)
    assert sigma[0] < 1e-6 < 1e-2 < sigma[1]
    # Hill's critical eigenvector mapped to the doubled representation spans the same null direction
    spec = hill_spectrum(hb, sp.unknowns, sp.parameter, vectors=True)
    k = int(np.argmin(np.abs(spec.multipliers + 1)))
    psi = hill_vector_to_doubled(spec.vectors[:, k], spec.exponents[k], spec.Omega, 1, hb2.H)
    psi2 = hill_vector_to_doubled(spec.vectors[:, k], spec.exponents[k], spec.Omega, 1, hb2.H, "imag")
    best = max(abs(phi @ psi) / np.linalg.norm(psi), abs(phi @ psi2) / np.linalg.norm(psi2))
    assert best > 1 - 1e-6
    # and the stored eigenvector of the special point is Hill's critical one
    q = sp.data["eigenvector"]
    D0, D1, D2 = hb.hill_matrices(sp.unknowns, sp.parameter)
    s = sp.data["exponent"]
    assert np.linalg.norm((D0 + s * D1 + s * s * D2) @ q) < 1e-8 * np.linalg.norm(D0, 2)


def test_hill_direction_gives_the_same_branch(diagram):
    root, hb = diagram[0], diagram.problems[0]
    sp = root.points_of_kind("pd")[1]
    opts = ContinuationOptions(ds=0.01, ds_max=0.05)
    a = switch_at(hb, root, sp, options=opts, pd_direction="svd")[0]
    b = switch_at(hb, root, sp, options=opts, pd_direction="hill")[0]
    # same motion up to the half-period shift (odd harmonics change sign)
    same = min(np.abs(a.u - b.u).max(), np.abs(a.u + b.u).max())
    assert same < 1e-8 and abs(a.lam - b.lam) < 1e-10


def test_branch_point_switching(diagram):
    """At the r = 0 boundary (multiplier +1, det(Phi - I) = 0) the trivial branch crosses a
    branch of non-zero 2 pi-periodic solutions; both sides are traced."""
    root = diagram[0]
    ref = boundary(+1, -0.2, 0.0)
    bps = root.points_of_kind("bp")
    assert bps and all(abs(p.parameter - ref) < 1e-6 for p in bps)
    kids = children(diagram, "bp")
    assert len(kids) == 2  # the engine's determinant test and the +1 event found the same point once
    firsts = [diagram[i].unknowns[0] for i in kids]
    np.testing.assert_allclose(firsts[0], -firsts[1], atol=1e-9)  # x -> -x mirror images
    for i in kids:
        br, hb = diagram[i], diagram.problems[i]
        assert br.info["subharmonic"] == 1 and br.info["origin"]["kind"] == "bp"
        u, d = br.point(len(br) // 2)
        assert np.abs(u).max() > 1e-2
        assert np.abs(hb.residual(u, d)).max() < 1e-9
        T = 2 * np.pi
        ts = np.linspace(0, T, 41)
        sol = solve_ivp(nonlinear_rhs(d), (0, T), orbit_state(hb, u, d, 0.0), method="DOP853", rtol=1e-12,
                        atol=1e-13, t_eval=ts)
        err = np.abs(sol.y.T - orbit_state(hb, u, d, ts)).max()
        tau = harmonic_amplitudes(u, 1)[-2:, 0].max()
        assert err <= 5 * tau * max(1.0, np.abs(br.point_data["multipliers"][len(br) // 2]).max()) + 1e-9


def test_follow_depth_and_validation():
    model = build_model("mathieu", {"c": C, "g": G, "eps": EPS})
    hb = HarmonicBalance(model, "delta", HBOptions(harmonics=3))
    dg = follow(hb, np.zeros(hb.size), 0.0, (0.0, 0.5), {"ds": 0.02, "ds_max": 0.05}, switch=("pd",), max_depth=0)
    assert len(dg) == 1 and dg[0].info["parent"] is None and dg.children(0) == []
    with pytest.raises(ValueError, match="switch at 'pd', 'bp' and 'ns' points, not 'fold'"):
        follow(hb, np.zeros(hb.size), 0.0, (0.0, 0.5), switch=("fold",))
    with pytest.raises(ValueError, match="unknown option 'tolerence'.*did you mean 'tolerance'"):
        follow(hb, np.zeros(hb.size), 0.0, (0.0, 0.5), stability={"tolerence": 1e-6})


def test_a_side_without_a_first_point_is_reported(diagram):
    """An offset far beyond Newton's basin: the side is reported with its reason, not dropped silently."""
    from contin.bifurcation.switching import switch_at

    root, hb = diagram[0], diagram.problems[0]
    pd = root.points_of_kind("pd")[0]
    failures = []
    starts = switch_at(hb, root, pd, eps=1e9, failures=failures)
    assert starts == [] and len(failures) == 1
    f = failures[0]
    assert f["kind"] == "pd" and f["side"] == 1 and abs(f["parameter"] - pd.parameter) < 1e-12
    assert "Newton failed" in f["message"]
    assert diagram.failed_switches == []  # every side of the normal switches found its first point


@pytest.mark.slow  # ~10 s: the contact rotor traced with Floquet stability, its branches switched
def test_every_switch_asked_on_a_contact_orbit_starts_a_branch_or_says_why(tmp_path):
    """The rotor pressed into its clearance (f0 = 0.7, H = 8): each period doubling of the harmonic branch either
    starts a branch or is a shortfall naming it, located or not (20 location iterations leave some of them
    unlocated: they were dropped without a word; now they are switched at from their final bracket)."""
    from pathlib import Path

    from contin.app.runner import run_scene
    from contin.output.results import read_csv
    from contin.scene.parse import load_scene

    scene = load_scene(Path(__file__).resolve().parents[2] / "scenes" / "rotor_f0_05.yaml", overrides=[
        "model.parameters.f0=0.7", "analysis.harmonics=8", "analysis.samples=256", "analysis.starts=[]",
        "analysis.switch=[pd]", "analysis.max_branches=64", "analysis.continuation.locate_max_iter=20",
        "output.plots=false", "analysis.method=hb"])
    summary = run_scene(scene, tmp_path / "out", progress=False)
    rows = read_csv(tmp_path / "out" / "special_points.csv")
    pds = [(w, located) for b, kind, w, located in zip(rows["branch"], rows["kind"], rows["w"], rows["located"])
           if b == 0 and kind == "pd"]
    unlocated = [w for w, located in pds if not located]
    assert unlocated  # what the test is about
    children = [b for b in summary["analysis"]["branches"] if b["parent"] == 0]
    failed = [f for f in summary["analysis"]["failed_switches"] if f["parent"] == 0]
    assert len(children) + len(failed) == len(pds)
    from_bracket = sorted([b["origin"]["parameter"] for b in children if not b["origin"]["located"]]
                          + [f["parameter"] for f in failed if "switched from the bracket" in f["message"]])
    assert from_bracket == pytest.approx(sorted(unlocated), abs=1e-9)
    # a failed switch makes the run incomplete (so may a branch stopped at a grazing point: analysis.method hb)
    assert summary["status"] == "incomplete" or not failed
    assert len(summary["analysis"]["shortfalls"]) >= len(failed)
