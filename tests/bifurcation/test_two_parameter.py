"""Two-parameter fold and period-doubling curves, against closed forms and scipy's Mathieu curves."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq
from scipy.special import mathieu_a, mathieu_b

from conftest import fd_jacobian
from contin.bifurcation.curve import BifurcationCurve
from contin.bifurcation.curve_system import FlipTestEvent, SingularityProblem
from contin.bifurcation.two_parameter import CurveOptions, continue_curve, curve_from_point
from contin.engine.branch import BranchStatus
from contin.model.catalog import build_model
from contin.engine.continuation import ContinuationOptions, continuation
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.hb.harmonics import embed
from contin.hb.derivatives import HBDerivatives, MatrixKind, flip_indices
from contin.scene.parse import parse_scene
from contin.scene.build import build_model as build_scene_model

C, K, G = 0.1, 1.0, 1.0  # Duffing x'' + C x' + K x + G x^3 = F cos(w t)
B3 = 0.75 * G


# ------------------------------------------------------------------ closed forms
def duffing_fold_forces(w):
    """F of the H = 1 folds at frequency w: d(F^2)/d(A^2) = 0 of ((K - w^2 + 3/4 G A^2)^2 + (C w)^2) A^2 = F^2."""
    s = K - w * w
    disc = s * s - 3 * (C * w) ** 2
    out = []
    if disc >= 0:
        for sign in (1, -1):
            X = (-2 * s + sign * np.sqrt(disc)) / (3 * B3)
            if X > 0:
                out.append((np.sqrt(((s + B3 * X) ** 2 + (C * w) ** 2) * X), np.sqrt(X)))
    return out


def duffing_cusp():
    """The two folds merge where the discriminant vanishes: (w^2 - K)^2 = 3 C^2 w^2."""
    w = (np.sqrt(3) * C + np.sqrt(3 * C * C + 4 * K)) / 2
    s = K - w * w
    X = -2 * s / (3 * B3)
    return w, np.sqrt(((s + B3 * X) ** 2 + (C * w) ** 2) * X)


def damped_mathieu_pd(c, eps, bracket):
    """delta where x'' + c x' + (delta + eps cos t) x = 0 has a multiplier -1 (independent monodromy)."""

    def char_at_minus_one(delta):
        def rhs(t, z):
            return np.concatenate([z[2:], -c * z[2:] - (delta + eps * np.cos(t)) * z[:2]])

        sol = solve_ivp(rhs, (0, 2 * np.pi), [1, 0, 0, 1], method="DOP853", rtol=1e-12, atol=1e-13)
        Phi = sol.y[:, -1].reshape(2, 2)
        return 1 + np.trace(Phi) + np.linalg.det(Phi)

    return brentq(char_at_minus_one, *bracket, xtol=1e-13)


def duffing(H=1, F=0.5):
    model = build_model("duffing", {"F": F, "c": C, "k": K, "g": G})
    return HarmonicBalance(model, "w", HBOptions(harmonics=H))


def rotor_problem(rng, H=8, N=128, crossings="none", spread=0.02):
    """A small rotor problem and a state whose bearing is partly in contact (the matrices need no solution).

    With ``crossings='none'`` the derivatives are assembled from the samples, otherwise from the
    problem's own linearisation with the contact switches resolved (two code paths of HBDerivatives).
    """
    model = build_model("bearing_rotor", {"f0": 0.5, "w": 2.15})
    hb = HarmonicBalance(model, "w", HBOptions(harmonics=H, samples=N, crossings=crossings))
    u = spread * rng.normal(size=hb.size)
    u[1], u[3] = 0.3, 0.1004  # mean y1, y2: the bearing on the casing, in contact over part of the period
    return hb, u


# ------------------------------------------------------------------ building blocks
def test_linearize_at_matches_harmonic_balance_for_every_parameter(rng):
    for hb, u in (rotor_problem(rng), rotor_problem(rng, crossings="interval"), (duffing(3), 0.3 * rng.normal(size=7))):
        der = HBDerivatives(hb)
        p = hb.params_at(hb.p0[hb.k])
        ks = list(range(p.size))
        R, J, dR = der.linearize_at(u, p, ks)
        for k in ks:
            other = HarmonicBalance(hb.model, hb.model.param_names[k], hb.options,
                                    dict(zip(hb.model.param_names, p)))
            R2, J2, Jl = other.linearize(u, p[k])
            np.testing.assert_allclose(R, R2, atol=1e-12 * np.abs(R2).max())
            np.testing.assert_allclose(J, J2, atol=1e-12 * np.abs(J2).max())
            np.testing.assert_allclose(dR[ks.index(k)], Jl, atol=1e-11 * max(1.0, np.abs(Jl).max()))


@pytest.mark.parametrize("case", ["duffing", "mathieu_nu2", "rotor", "rotor_interval"])
def test_flip_matrix_is_the_odd_block_of_the_doubled_jacobian(case, rng):
    if case.startswith("rotor"):
        hb, u = rotor_problem(rng, crossings="interval" if case == "rotor_interval" else "none")
    elif case == "duffing":
        hb, u = duffing(4), 0.3 * rng.normal(size=9)
    else:
        model = build_model("mathieu", {"eps": 0.4, "c": 0.1, "g": 1.0, "delta": 0.3})
        hb = HarmonicBalance(model, "delta", HBOptions(harmonics=5, subharmonic=2))
        u = 0.3 * rng.normal(size=hb.size)
    B = HBDerivatives(hb).flip_matrix(u, hb.params_at(hb.p0[hb.k]))
    hb2 = hb.with_options(subharmonic=2 * hb.nu, harmonics=2 * hb.H, samples=2 * hb.N)
    _, J2, _ = hb2.linearize(embed(u, hb.n, 2, 2 * hb.H), hb.p0[hb.k])
    odd = flip_indices(hb.n, hb.H)
    assert B.shape == (2 * hb.n * hb.H,) * 2
    np.testing.assert_allclose(B, J2[np.ix_(odd, odd)], atol=1e-12 * np.abs(J2).max())
    # the order-2nu Jacobian of a nu-periodic state does not couple odd and even harmonics
    even = np.setdiff1d(np.arange(hb2.size), odd)
    assert np.abs(J2[np.ix_(odd, even)]).max() < 1e-10 * np.abs(J2).max()


@pytest.mark.parametrize("kind", [MatrixKind.JACOBIAN, MatrixKind.FLIP])
@pytest.mark.parametrize("crossings", ["none", "interval", "exact"])
def test_bilinear_form_gradients_match_finite_differences(kind, crossings, rng):
    # exact arcs: an orbit that stays near the casing (with the default spread, the bearing passes near
    # the centre, where the radial law x/r Fn extended over the flights is singular and the trapezoid-minus-
    # flights form of contin.hb.contact_quadrature loses its accuracy)
    spread = 0.004 if crossings == "exact" else 0.02
    tol = 1e-5 if crossings == "exact" else 1e-7
    for hb, u in (duffing(3), 0.3 * rng.normal(size=7)), rotor_problem(rng, crossings=crossings, spread=spread):
        der = HBDerivatives(hb)
        p = hb.params_at(hb.p0[hb.k])
        ks = [hb.model.parameter_index(q) for q in ("w", "c" if hb.model.name == "duffing" else "c2",
                                                      "F" if hb.model.name == "duffing" else "f0")]

        def matrix(uu, pp):
            return der.linearize_at(uu, pp)[1] if kind is MatrixKind.JACOBIAN else der.flip_matrix(uu, pp)

        size = matrix(u, p).shape[0]
        v, w = rng.normal(size=size), rng.normal(size=size)
        S, S_u, S_p = der.bilinear(u, p, v, w, kind, ks)
        assert S == pytest.approx(w @ matrix(u, p) @ v, rel=1e-12)
        fd_u = fd_jacobian(lambda uu: np.array([w @ matrix(uu, p) @ v]), u, eps=1e-6)[0]
        np.testing.assert_allclose(S_u, fd_u, atol=tol * np.abs(fd_u).max())
        for i, k in enumerate(ks):
            def along(x, k=k):
                pp = p.copy()
                pp[k] = x[0]
                return np.array([w @ matrix(u, pp) @ v])

            fd_p = fd_jacobian(along, p[k:k + 1], eps=1e-6)[0, 0]
            assert S_p[i] == pytest.approx(fd_p, rel=tol, abs=1e-8 * max(1.0, abs(S)))


@pytest.mark.parametrize("kind,p1,p2", [("fold", "w", "F"), ("pd", "w", "c"), ("pd", "delta", "eps")])
def test_augmented_jacobians_match_finite_differences(kind, p1, p2, rng):
    if p1 == "delta":
        model = build_model("mathieu", {"eps": 0.4, "c": 0.1, "g": 1.0, "delta": 0.3})
        hb = HarmonicBalance(model, "delta", HBOptions(harmonics=4))
        u = 0.2 * rng.normal(size=hb.size)
    else:
        hb = duffing(3)
        u = 0.4 * rng.normal(size=hb.size)
    pr = SingularityProblem(hb, kind, p1, p2)
    z = np.concatenate([u, [float(hb.p0[pr.k1]) + 0.1]])
    lam = float(hb.p0[pr.k2])
    pr.initialize_borders(z, lam)
    F, Jz, Jl = pr.linearize(z, lam)
    assert F.shape == (hb.size + 1,) and Jz.shape == (hb.size + 1,) * 2
    np.testing.assert_allclose(F, pr.residual(z, lam))
    fd_z = fd_jacobian(lambda zz: pr.residual(zz, lam), z, eps=1e-6)
    fd_l = fd_jacobian(lambda ll: pr.residual(z, ll[0]), np.array([lam]), eps=1e-6)[:, 0]
    np.testing.assert_allclose(Jz, fd_z, atol=1e-7 * np.abs(fd_z).max())
    np.testing.assert_allclose(Jl, fd_l, atol=1e-7 * max(1.0, np.abs(fd_l).max()))
    # g and the bilinear form agree: M v = -g b, so w^T M v = -g
    d = pr._cache
    assert d["S"] == pytest.approx(-d["g"], rel=1e-9, abs=1e-12)


@pytest.mark.parametrize("crossings", ["none", "interval"])
def test_rotor_augmented_jacobian_matches_finite_differences(crossings, rng):
    hb, u = rotor_problem(rng, crossings=crossings)
    pr = SingularityProblem(hb, "pd", "w", "c2")
    z = np.concatenate([u, [2.15]])
    pr.initialize_borders(z, 0.05)
    _, Jz, Jl = pr.linearize(z, 0.05)
    fd_z = fd_jacobian(lambda zz: pr.residual(zz, 0.05), z, eps=1e-7)
    fd_l = fd_jacobian(lambda ll: pr.residual(z, ll[0]), np.array([0.05]), eps=1e-7)[:, 0]
    # the contact Jacobian is piecewise: compare away from samples on the switching surface
    np.testing.assert_allclose(Jz, fd_z, atol=1e-5 * np.abs(fd_z).max())
    np.testing.assert_allclose(Jl, fd_l, atol=1e-6 * max(1.0, np.abs(fd_l).max()))


# ------------------------------------------------------------------ fold curves
@pytest.fixture(scope="module")
def duffing_curve():
    hb = duffing(1)
    br = continuation(hb, hb.linear_solution(0.5), 0.5, (0.5, 3.0), ContinuationOptions(ds_max=0.1))
    folds = br.points_of_kind("fold")
    assert len(folds) == 2
    curve = curve_from_point(hb, folds[1], "F", (0.0, 0.5), (0.5, 3.0), ContinuationOptions(ds=0.01, ds_max=0.05))
    return folds, curve


def test_duffing_fold_curve_is_the_closed_form_one(duffing_curve):
    folds, curve = duffing_curve
    assert isinstance(curve, BifurcationCurve) and curve.kind.value == "fold" and len(curve) > 20
    # the side that sets out towards F = 0 turns back at the cusp and ends on F = 0.5, where it started from
    assert curve.complete and sorted(e["status"] for e in curve.ends) == ["range_end", "turned_back"]
    for w, F, u in zip(curve.p1, curve.p2, curve.unknowns):
        ref = duffing_fold_forces(w)
        amp = np.hypot(u[1], u[2])
        err = min(abs(F - Fr) + abs(amp - Ar) for Fr, Ar in ref)
        assert err < 1e-9, (w, F)
    # from one fold of the frequency response at F = 0.5, through the cusp, to the other
    ends = sorted(curve.p1[[0, -1]])
    np.testing.assert_allclose(ends, sorted(f.parameter for f in folds), atol=1e-9)
    assert curve.p2[0] == 0.5 and curve.p2[-1] == 0.5


def test_duffing_cusp_is_located_at_the_closed_form_point(duffing_curve):
    _, curve = duffing_curve
    cusps = curve.points_of_kind("cusp")
    assert len(cusps) == 1 and cusps[0].located
    w_c, F_c = duffing_cusp()
    assert abs(cusps[0].p1 - w_c) < 1e-8 * w_c and abs(cusps[0].p2 - F_c) < 1e-8 * F_c
    # the cusp is the lowest force of the jump region; no other codimension-two point
    assert curve.p2.min() >= F_c - 1e-12
    assert not curve.points_of_kind("fold_flip") and not curve.points_of_kind("extremum")


def test_duffing_fold_curve_with_more_harmonics_still_has_its_cusp():
    hb = duffing(5)
    br = continuation(hb, hb.linear_solution(0.5), 0.5, (0.5, 3.0), ContinuationOptions(ds_max=0.1))
    curve = curve_from_point(hb, br.points_of_kind("fold")[0], "F", (0.0, 0.5), (0.5, 3.0),
                             ContinuationOptions(ds=0.01, ds_max=0.05))
    (cusp,) = curve.points_of_kind("cusp")
    w_c, F_c = duffing_cusp()
    # higher harmonics move the cusp a little (they are small at this weak nonlinearity)
    assert abs(cusp.p1 - w_c) < 1e-3 and abs(cusp.p2 - F_c) < 1e-3


# ------------------------------------------------------------------ period-doubling curves
def test_mathieu_duffing_pd_curves_are_the_mathieu_transition_curves():
    """Trivial solution of x'' + (delta + eps cos t) x + x^3 = 0: multiplier -1 on delta = a_1(2 eps)/4, b_1(2 eps)/4."""
    model = build_model("mathieu", {"eps": 0.4, "c": 0.0, "g": 1.0}, effects=["parametric", "cubic"])
    hb = HarmonicBalance(model, "delta", HBOptions(harmonics=8))
    br = continuation(hb, np.zeros(hb.size), -0.2, (-0.2, 0.8), ContinuationOptions(ds=0.01, ds_max=0.05),
                      events=[FlipTestEvent(hb)])
    pds = br.points_of_kind("pd")
    np.testing.assert_allclose([p.parameter for p in pds], sorted([mathieu_a(1, 0.8) / 4, mathieu_b(1, 0.8) / 4]),
                               atol=1e-9)
    for pd, ref in zip(pds, (mathieu_b, mathieu_a)):
        curve = curve_from_point(hb, pd, "eps", (0.05, 1.0), (-1.0, 2.0), ContinuationOptions(ds=0.01, ds_max=0.05))
        assert curve.complete and curve.kind.value == "pd"
        assert curve.p2.min() == 0.05 and curve.p2.max() == 1.0
        expected = np.array([ref(1, 2 * e) / 4 for e in curve.p2])
        assert np.abs(curve.p1 - expected).max() < 1e-9
        assert np.abs(curve.unknowns).max() == 0.0  # the trivial solution all along


def test_damped_pd_curve_matches_independent_monodromy():
    """With damping the tongue lifts off the delta axis: compare with scipy's DOP853 monodromy."""
    model = build_model("mathieu", {"eps": 0.4, "c": 0.1, "g": 1.0}, effects=["damping", "parametric", "cubic"])
    hb = HarmonicBalance(model, "delta", HBOptions(harmonics=8))
    br = continuation(hb, np.zeros(hb.size), -0.2, (-0.2, 0.8), ContinuationOptions(ds=0.01, ds_max=0.05),
                      events=[FlipTestEvent(hb)])
    pd = br.points_of_kind("pd")[0]
    assert pd.parameter == pytest.approx(damped_mathieu_pd(0.1, 0.4, (0.0, 0.25)), abs=1e-9)
    curve = curve_from_point(hb, pd, "eps", (0.1, 0.8), (-1.0, 2.0), ContinuationOptions(ds=0.01, ds_max=0.05))
    # the lower boundary of the tongue goes down to eps = 0.1 and turns back up as the upper one
    assert curve.p2.min() > 0.1
    (tip,) = [p for p in curve.points_of_kind("extremum") if p.data["parameter"] == "eps"]
    assert tip.located and curve.p2.min() >= tip.p2 - 1e-12
    for eps in (0.3, 0.6):
        got = sorted(q for q, _ in curve.crossings(eps))
        assert len(got) == 2 and got[0] < tip.p1 < got[1]
        # each root of the monodromy's characteristic polynomial at -1, bracketed around the curve's value
        ref = [damped_mathieu_pd(0.1, eps, (g - 0.02, g + 0.02)) for g in got]
        np.testing.assert_allclose(got, ref, atol=1e-8)


# ------------------------------------------------------------------ fold-flip points
FOLD_FLIP_SCENE = """
model:
  dofs: [x, y]
  parameters: {c: 0.1, g: 1.0, F: 0.5, d: 0.3, e: 0.2, w: 1.0}
  mass: [[1, 0], [0, 1]]
  damping: [[c, 0], [0, 0]]
  stiffness: [[1, 0], [0, d]]
  forces:
    - {dof: x, expr: "g*x**3"}
    - {dof: y, expr: "e*cos(tau)*y"}
  excitation:
    - {dof: x, expr: "F*cos(tau)"}
analysis: {type: frequency_response, parameter: w, range: [0.5, 3.0]}
"""


@pytest.fixture(scope="module")
def fold_flip_setup():
    """A Duffing oscillator x beside an undamped Mathieu oscillator y = 0, uncoupled.

    The folds are those of x (independent of d); the period doublings are those of y:
    y'' + (d + e cos(w t)) y = 0 is Mathieu's equation in tau = w t with delta = d/w^2,
    eps = e/w^2, so they lie on d = w^2 a_1(2e/w^2)/4 and w^2 b_1(2e/w^2)/4. A fold curve
    (w fixed, d varying) meets a period-doubling curve where both hold: a fold-flip point.
    """
    model = build_scene_model(parse_scene(FOLD_FLIP_SCENE))
    hb = HarmonicBalance(model, "w", HBOptions(harmonics=6))
    u0 = hb.linear_solution(0.5)
    br = continuation(hb, u0, 0.5, (0.5, 3.0), ContinuationOptions(ds_max=0.1), events=[FlipTestEvent(hb)])
    return hb, br


def test_fold_flip_on_a_fold_curve(fold_flip_setup):
    hb, br = fold_flip_setup
    fold = max(br.points_of_kind("fold"), key=lambda p: p.parameter)  # the upper jump, w ~ 2.2
    curve = curve_from_point(hb, fold, "d", (0.0, 2.0), (0.5, 3.0), ContinuationOptions(ds=0.01, ds_max=0.05))
    assert curve.complete
    np.testing.assert_allclose(curve.p1, fold.parameter, atol=1e-9)  # x does not feel d
    w = fold.parameter
    q = 2 * 0.2 / w**2
    expected = sorted([w * w * mathieu_b(1, q) / 4, w * w * mathieu_a(1, q) / 4])
    found = sorted(p.p2 for p in curve.points_of_kind("fold_flip"))
    assert all(p.located for p in curve.points_of_kind("fold_flip"))
    np.testing.assert_allclose(found, expected, atol=1e-8)


def test_fold_flip_on_a_period_doubling_curve(fold_flip_setup):
    hb, br = fold_flip_setup
    pd = min(br.points_of_kind("pd"), key=lambda p: p.parameter)
    fold_w = max(p.parameter for p in br.points_of_kind("fold"))
    curve = curve_from_point(hb, pd, "d", (0.0, 2.0), (0.5, 3.0), ContinuationOptions(ds=0.01, ds_max=0.05))
    for w, d in zip(curve.p1, curve.p2):  # on a Mathieu transition curve of y
        q = 2 * 0.2 / w**2
        assert min(abs(d - w * w * mathieu_a(1, q) / 4), abs(d - w * w * mathieu_b(1, q) / 4)) < 1e-8
    # where x reaches its upper fold, J is singular on the pd curve, and the curve turns back in w
    ff = [p for p in curve.points_of_kind("fold_flip") if abs(p.p1 - fold_w) < 1e-3]
    assert len(ff) == 1 and ff[0].located
    assert ff[0].p1 == pytest.approx(fold_w, abs=1e-8)


# ------------------------------------------------------------------ options, failure paths
def test_curve_options_are_validated_naming_the_field():
    with pytest.raises(ValueError, match="CurveOptions.detect"):
        CurveOptions(detect=("cusp", "hopf"))
    with pytest.raises(ValueError, match="CurveOptions.fd_step"):
        CurveOptions(fd_step=0.5)
    with pytest.raises(ValueError, match="CurveOptions.both_ways"):
        CurveOptions(both_ways="yes")
    with pytest.raises(ValueError, match="unknown option 'detekt'"):
        CurveOptions.from_dict({"detekt": []})


def test_bad_curve_arguments_raise():
    hb = duffing(1)
    u = hb.linear_solution(1.0)
    with pytest.raises(ValueError, match="must differ"):
        continue_curve(hb, "fold", "w", "w", u, 1.0, 1.0, (0, 2))
    with pytest.raises(ValueError, match="outside its range"):
        continue_curve(hb, "fold", "w", "F", u, 5.0, 0.5, (0, 1), (0.5, 3.0))
    with pytest.raises(ValueError, match="unknown parameter 'G'"):
        continue_curve(hb, "fold", "w", "G", u, 1.0, 0.5, (0, 1))
    with pytest.raises(ValueError, match="'fold', 'pd' or 'ns'"):
        continue_curve(hb, "hopf", "w", "F", u, 1.0, 0.5, (0, 1))
    with pytest.raises(ValueError, match="ns curve by harmonic balance is not built: follow it by shooting"):
        continue_curve(hb, "ns", "w", "F", u, 1.0, 0.5, (0, 1))
    br = continuation(hb, hb.linear_solution(0.5), 0.5, (0.5, 3.0), ContinuationOptions(ds_max=0.1))
    with pytest.raises(ValueError, match="starts at a 'fold' or 'pd' point, not at 'end'"):
        curve_from_point(hb, br.points_of_kind("end")[0], "F", (0, 1))


def test_a_start_far_from_any_fold_ends_cleanly():
    """Newton from a regular point (J far from singular) either fails or lands on the curve; never NaN."""
    hb = duffing(1)
    u = hb.linear_solution(0.6)
    curve = continue_curve(hb, "fold", "w", "F", u, 0.6, 0.5, (0.0, 0.5), (0.5, 3.0),
                           ContinuationOptions(newton_max_iter=3))
    if not len(curve):
        assert curve.ends[0]["status"] == BranchStatus.START_FAILED.value
        assert "Newton did not converge" in curve.ends[0]["message"]
    assert np.all(np.isfinite(curve.p1)) and np.all(np.isfinite(curve.unknowns))
