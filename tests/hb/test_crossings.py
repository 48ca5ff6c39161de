"""Switching contact laws in the harmonic balance: exact arcs (contin.hb.contact_quadrature)
and crossings resolved between samples (contin.hb.crossings).

Truth: the Fourier coefficients of a prescribed orbit's contact force by adaptive
quadrature between the exact crossing angles; finite differences of the
residual for every Jacobian.
"""

import numpy as np
import pytest
from conftest import fd_jacobian
from scipy.integrate import quad

from contin.hb import crossings
from contin.engine.branch import BranchStatus
from contin.engine.continuation import ContinuationOptions, continuation
from contin.model.elements import GapForce, RadialGapForce
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.model.base import Monomial
from contin.models.polynomial import polynomial_model

G, K, C, OFFSET = 0.1, 50.0, 0.7, 0.02


def _gap(clip=False):
    return GapForce(0, Monomial(G), Monomial(K), Monomial(C), "both", clip)


def _exact_coefficients(A, H):
    """Fourier coefficients of the gap force along x = A cos t + OFFSET, by quadrature between crossings."""

    def force(t):
        x, v = A * np.cos(t) + OFFSET, -A * np.sin(t)
        if x > G:
            return K * (x - G) + C * v
        if x < -G:
            return K * (x + G) + C * v
        return 0.0

    pts = []
    for level in (G, -G):
        ct = (level - OFFSET) / A
        if abs(ct) < 1:
            a = np.arccos(ct)
            pts += [a, 2 * np.pi - a]
    out = np.zeros(2 * H + 1)
    kw = dict(points=sorted(pts), limit=200, epsabs=1e-13)
    out[0] = quad(force, 0, 2 * np.pi, **kw)[0] / (2 * np.pi)
    for h in range(1, H + 1):
        out[2 * h - 1] = quad(lambda t: force(t) * np.cos(h * t), 0, 2 * np.pi, **kw)[0] / np.pi
        out[2 * h] = quad(lambda t: force(t) * np.sin(h * t), 0, 2 * np.pi, **kw)[0] / np.pi
    return out


def _sampled_coefficients(A, N, H, mode):
    """The gap force's coefficients along x = A cos t + OFFSET, through the harmonic balance."""
    model = polynomial_model(["x"], {"w": 1.0}, mass=[[1.0]], damping=[[0.0]], stiffness=[[0.0]])
    model.forces.append(_gap())
    hb = HarmonicBalance(model, "w", HBOptions(harmonics=H, samples=N, crossings=mode))
    u = np.zeros(hb.size)
    u[0], u[1] = OFFSET, A
    return hb.residual(u, 1.0) - hb.linear_matrix(hb.params_at(1.0)) @ u


def test_exact_arcs_give_the_coefficients_to_rounding():
    """Contact arcs located on the series and integrated by Gauss: the quadrature's value at every N >= 64."""
    for A in (0.3, 0.13):  # two stops hit, and a graze of one stop (x - OFFSET reaches 0.11 > G only just)
        exact = _exact_coefficients(A, 5)
        for N in (64, 128, 256):
            assert np.abs(_sampled_coefficients(A, N, 5, "exact") - exact).max() < 1e-13


def test_resolved_crossings_converge_at_second_order_and_sampling_at_first():
    """Error of the coefficients against quadrature, fitted by slope in N: 2 resolved, 1 plain (the jump c v)."""
    H, A = 5, 0.3
    exact = _exact_coefficients(A, H)
    Ns = np.array([64, 128, 256, 512, 1024])
    err = {m: np.array([np.abs(_sampled_coefficients(A, N, H, m) - exact).max() for N in Ns])
           for m in ("none", "interval")}
    slope = {m: -np.polyfit(np.log(Ns), np.log(err[m]), 1)[0] for m in err}
    assert slope["interval"] == pytest.approx(2.0, abs=0.1)
    assert slope["none"] < 1.5  # measured about 1.1, erratic (the crossing's place between samples)
    assert err["interval"][-1] < 0.1 * err["none"][-1]


@pytest.mark.parametrize("mode", ["interval", "exact"])
def test_coefficients_are_continuous_when_a_sample_crosses_the_surface(mode):
    """Steps of the coefficients over a fine amplitude grid: the plain samples jump by ~c v / N, resolved do not.

    The grid (spacing 2.5e-5) holds A = 0.3136, where the samples t = 2 pi 20/64 and 2 pi 44/64 cross the
    lower stop (cos t = -(G + OFFSET) / A); over [0.3, 0.4] with the same spacing the ratios below were the
    same (max/median 1.004 resolved, 10.3 plain, against 1.001 and 10.3 here).
    """
    As = np.linspace(0.308, 0.32, 481)
    steps = {}
    for m in ("none", mode):
        co = np.array([_sampled_coefficients(A, 64, 5, m) for A in As])
        steps[m] = np.abs(np.diff(co, axis=0)).max(axis=1)
    smooth = np.median(steps[mode])
    assert steps[mode].max() < 1.05 * smooth  # no step larger than the smooth change
    assert steps["none"].max() > 5 * smooth  # measured 10x: a sample crossing the surface


def _clearance_model(element, n):
    names = ["x", "y"][:n]
    eye = np.eye(n).tolist()
    model = polynomial_model(names, {"c": 0.05, "F": 0.3, "w": 1.0, "g": 0.5, "kc": 40.0, "cc": 0.5}, mass=eye,
                             damping=[["c" if i == j else 0 for j in range(n)] for i in range(n)], stiffness=eye,
                             forcing=[{"dof": "x", "amplitude": "F"}])
    mono = [Monomial(1.0, ((model.parameter_index(s), 1),)) for s in ("g", "kc", "cc")]
    model.forces.append(element(*mono))
    return model


ELEMENTS = {
    "gap": (lambda clip: lambda g, k, c: GapForce(0, g, k, c, "both", clip), 1),
    "radial": (lambda clip: lambda g, k, c: RadialGapForce((0, 1), g, k, c, clip), 2),
}


@pytest.mark.parametrize("kind", sorted(ELEMENTS))
@pytest.mark.parametrize("clip", [False, True])
def test_switching_data_derivatives_equal_finite_differences(kind, clip, rng):
    """difference_x, difference_xd and switching_dp against central differences, away from the surfaces."""
    make, n = ELEMENTS[kind]
    model = _clearance_model(make(clip), n)
    el = model.forces[-1]
    p = model.parameter_vector()
    x = rng.uniform(-1.0, 1.0, size=(40, n))
    xd = rng.normal(size=(40, n))
    tau = np.zeros(40)
    sw = el.switching_functions(x, xd, tau, p)
    N, m = sw.value.shape
    for j in range(N):
        for i in range(m):
            dx = fd_jacobian(lambda z: el.switching_functions(z[None], xd[j:j + 1], tau[:1], p).difference[0, i],
                             x[j])
            dv = fd_jacobian(lambda z: el.switching_functions(x[j:j + 1], z[None], tau[:1], p).difference[0, i],
                             xd[j])
            np.testing.assert_allclose(sw.difference_x[j, i], dx, atol=1e-6 * K)
            np.testing.assert_allclose(sw.difference_xd[j, i], dv, atol=1e-6 * K)
    for name in ("g", "kc", "cc"):
        k = model.parameter_index(name)
        hp, Lp = el.switching_dp(x, xd, tau, p, k)

        def data(v, k=k):
            q = p.copy()
            q[k] = v[0]
            s = el.switching_functions(x, xd, tau, q)
            return np.concatenate([s.value.ravel(), s.difference.ravel()])

        fd = fd_jacobian(data, p[k:k + 1])[:, 0]
        # a clipped surface switches branch (min of two) where both are equal; skip those states
        ok = np.abs(fd[:N * m] - hp.ravel()) < 1e-5
        assert ok.mean() > 0.9
        np.testing.assert_allclose(hp.ravel()[ok], fd[:N * m][ok], atol=1e-6)
        np.testing.assert_allclose(Lp.ravel(), fd[N * m:], atol=1e-6 * K)


@pytest.mark.parametrize("kind", sorted(ELEMENTS))
@pytest.mark.parametrize("clip", [False, True])
@pytest.mark.parametrize("lam", ["w", "g", "kc", "cc"])
@pytest.mark.parametrize("mode,amp", [("interval", 0.62), ("exact", 0.62), ("exact", 1.5)],
                         ids=["interval", "exact-on-arcs", "exact-off-arcs"])
def test_residual_jacobians_equal_finite_differences(kind, clip, lam, mode, amp):
    """dR/du and dR/dlambda on an orbit that crosses the clearance, every parameter; with exact arcs both
    forms (short contacts: on-arcs integrated; long contacts: the law over the period minus the flights)."""
    make, n = ELEMENTS[kind]
    model = _clearance_model(make(clip), n)
    hb = HarmonicBalance(model, lam, HBOptions(harmonics=5, samples=64, crossings=mode))
    u = 0.01 * np.random.default_rng(1).normal(size=hb.size)
    u[n] = amp  # a_1 of x: beyond the clearance 0.5 over part of the period
    u[0] = 0.03 if amp < 1.0 else 0.6  # x pressed against the + stop for most of the period
    if n == 2:
        u[5] = 0.3  # b_1 of y: the radial flight stays away from the centre, where the law's direction turns
    lam0 = 1.1 if lam == "w" else hb.p0[hb.k]
    _, J, Jl = hb.linearize(u, lam0)
    if mode == "interval":
        assert sum(c.t.size for _, _, c, _ in hb._crossings) >= 2
    else:
        assert any(law.quad.full for _, _, law in hb._laws) == (amp > 1.0)
        assert sum(law.quad.starts.size for _, _, law in hb._laws) >= 1
    Jfd = fd_jacobian(lambda v: hb.residual(v, lam0), u)
    Jlfd = fd_jacobian(lambda v: hb.residual(u, v[0]), np.array([lam0]))[:, 0]
    assert np.abs(J - Jfd).max() < 1e-8 * np.abs(J).max()
    assert np.abs(Jl - Jlfd).max() < 1e-7 * max(1.0, np.abs(Jl).max())


def test_branch_passes_grazing_where_the_sampled_law_stalls():
    """A clearance oscillator with contact damping, followed in w through contact onset.

    The response amplitude crosses the clearance twice in w in [0.5, 1.5]. Resolved: the branch
    reaches the range end with every point converged to 1e-10. Plain samples: the residual jumps
    when a sample crosses, and Newton cannot reach the tolerance there.
    """
    model = _clearance_model(ELEMENTS["gap"][0](False), 1)
    ends = {}
    for resolve in (True, False):
        hb = HarmonicBalance(model, "w", HBOptions(harmonics=10, samples=64, crossings="exact" if resolve else "none"))
        opts = ContinuationOptions(ds=0.02, ds_max=0.05, newton_tol=1e-10, max_points=400)
        br = continuation(hb, hb.linear_solution(0.5), 0.5, (0.5, 1.5), opts)
        amp = np.array([np.abs(hb.samples_of(u, w)[0][:, 0]).max() for u, w in zip(br.unknowns, br.parameter)])
        ends[resolve] = (br, amp)
    br, amp = ends[True]
    assert br.status is BranchStatus.RANGE_END and br.parameter[-1] == pytest.approx(1.5)
    assert amp.min() < 0.5 < amp.max()  # contact onset inside the range
    br0, _ = ends[False]
    assert br0.status is not BranchStatus.RANGE_END or len(br0) > 2 * len(br)


def _planar_contact_orbit():
    """Three dofs with a radial clearance on the first two, and an orbit that crosses it eight times.

    The third dof carries no contact force and the switching function does not depend on it, so
    the crossing terms fill the rows and columns of two of the three dofs only.
    """
    model = polynomial_model(["x", "y", "z"], {"c": 0.05, "F": 0.3, "w": 1.0, "g": 0.5, "kc": 40.0, "cc": 0.5},
                             mass=np.eye(3).tolist(), damping=[["c", 0, 0], [0, "c", 0], [0, 0, "c"]],
                             stiffness=[[1.0, 0, 0.3], [0, 1.0, 0], [0.3, 0, 2.0]],
                             forcing=[{"dof": "x", "amplitude": "F"}])
    mono = [Monomial(1.0, ((model.parameter_index(s), 1),)) for s in ("g", "kc", "cc")]
    model.forces.append(RadialGapForce((0, 1), *mono))
    U = np.zeros((15, 3))
    U[0] = [0.05, -0.02, 0.1]
    U[1] = [0.55, 0.0, 0.2]  # a_1
    U[2] = [0.0, 0.35, 0.0]  # b_1
    U[5] = [0.1, 0.0, 0.05]  # a_3
    U[6] = [0.0, -0.1, 0.0]  # b_3
    U[9] = [0.12, 0.02, 0.0]  # a_5
    U[10] = [0.0, 0.1, 0.0]  # b_5
    return model, U.reshape(-1)


@pytest.mark.parametrize("lam", ["w", "cc"])
def test_crossing_jacobian_with_several_switches_equals_finite_differences(lam):
    """dR/du and dR/dlambda against central differences on an orbit with eight transversal switches."""
    model, u = _planar_contact_orbit()
    hb = HarmonicBalance(model, lam, HBOptions(harmonics=7, samples=128, crossings="interval"))
    lam0 = 1.1 if lam == "w" else hb.p0[hb.k]
    _, J, Jl = hb.linearize(u, lam0)
    (_, _, cr, _), = hb._crossings
    assert cr.t.size == 8 and np.abs(cr.slope).min() > 0.01
    Jfd = fd_jacobian(lambda v: hb.residual(v, lam0), u)
    Jlfd = fd_jacobian(lambda v: hb.residual(u, v[0]), np.array([lam0]))[:, 0]
    assert np.abs(J - Jfd).max() < 1e-8 * np.abs(J).max()
    assert np.abs(Jl - Jlfd).max() < 1e-7 * max(1.0, np.abs(Jl).max())


def test_crossing_jacobian_kernel_is_the_sum_of_rank_one_terms_on_any_dof_selection():
    """add_crossing_jacobian against P(theta_a) (x) dc_a/dt L_a (x) dt/dU summed term by term, on all
    dofs and on the slices of the contact dofs (a Jacobian restricted to them)."""
    model, u = _planar_contact_orbit()
    hb = HarmonicBalance(model, "w", HBOptions(harmonics=7, samples=128, crossings="interval"))
    hb.linearize(u, 1.1)
    (_, sw, cr, coef), = hb._crossings
    H, N, n = hb.H, hb.N, hb.n
    dtdU = crossings.crossing_gradients(cr.phi, cr.gx, cr.gxd, cr.slope, 1.1, H)
    ref = np.zeros((hb.size, hb.size))
    hh = np.arange(1, H + 1)
    for k, (j, j1, i) in enumerate(cr.intervals):
        for side, a in enumerate((j, j1)):
            P = np.concatenate([[1.0], np.column_stack([2 * np.cos(hh * hb.theta[a]),
                                                        2 * np.sin(hh * hb.theta[a])]).ravel()]) / N
            ref += np.outer(np.kron(P, coef[k, 2 + side] * sw.difference[a, i]), dtdU[k].ravel())
    J = np.zeros((hb.size, hb.size))
    crossings.add_crossing_jacobian(cr.intervals, coef, sw.difference, hb.theta, dtdU, J)
    assert np.abs(J - ref).max() < 1e-13 * np.abs(ref).max()
    assert np.abs(ref.reshape(2 * H + 1, n, 2 * H + 1, n)[:, 2]).max() == 0.0  # no row nor column of z
    dofs = np.array([0, 1])
    idx = (np.arange(2 * H + 1)[:, None] * n + dofs).ravel()
    Js = np.zeros((idx.size, idx.size))
    crossings.add_crossing_jacobian(cr.intervals, coef, sw.difference[:, :, dofs], hb.theta, dtdU[:, :, dofs], Js)
    assert np.abs(Js - ref[np.ix_(idx, idx)]).max() < 1e-13 * np.abs(ref).max()


def test_series_and_crossing_gradients_equal_direct_evaluation(rng):
    """The harmonics by recurrence against cos(h phi), sin(h phi) one by one, at 80 harmonics."""
    H, n, K = 80, 3, 50
    U = rng.normal(size=(2 * H + 1, n)) / (1.0 + np.arange(2 * H + 1))[:, None]
    phi = rng.uniform(0.0, 2 * np.pi, K)
    hh = np.arange(1, H + 1)
    c, s = np.cos(np.outer(phi, hh)), np.sin(np.outer(phi, hh))
    a, b = U[1::2], U[2::2]
    x = U[0] + c @ a + s @ b
    x1 = (s * -hh) @ a + (c * hh) @ b
    x2 = -(c * hh ** 2) @ a - (s * hh ** 2) @ b
    for got, want in zip(crossings.series_at(U, phi), (x, x1, x2)):
        assert np.abs(got - want).max() < 1e-13 * np.abs(want).max()
    gx, gxd, slope, Omega = rng.normal(size=(K, n)), rng.normal(size=(K, n)), rng.normal(size=K), 0.7
    got = crossings.crossing_gradients(phi, gx, gxd, slope, Omega, H)
    want = np.empty_like(got)
    want[:, 0] = gx
    want[:, 1::2] = gx[:, None] * c[:, :, None] - Omega * gxd[:, None] * (hh * s)[:, :, None]
    want[:, 2::2] = gx[:, None] * s[:, :, None] + Omega * gxd[:, None] * (hh * c)[:, :, None]
    want *= -1.0 / slope[:, None, None]
    assert np.abs(got - want).max() < 1e-13 * np.abs(want).max()


class _Counting:
    """An element whose switching functions count their evaluations."""

    def __init__(self, element):
        self.element, self.calls = element, 0

    def switching_functions(self, x, xd, tau, p):
        self.calls += 1
        return self.element.switching_functions(x, xd, tau, p)


@pytest.mark.parametrize("excess", [0.2, 1e-9, 1e-12])
def test_crossings_are_located_to_rounding_in_few_evaluations(excess):
    """x = OFFSET + A cos(theta) reaching excess beyond the stop: the roots of x = G against arccos.

    Near the tangential touch (small excess) h is known only to its rounding error over a small
    slope; the iteration stops there instead of wandering for its full count of steps.
    """
    el = _Counting(_gap())
    N, H = 64, 5
    A = G - OFFSET + excess
    U = np.zeros((2 * H + 1, 1))
    U[0, 0], U[1, 0] = OFFSET, A
    theta = 2 * np.pi * np.arange(N) / N
    x = OFFSET + A * np.cos(theta)[:, None]
    h = el.element.switching_functions(x, np.zeros_like(x), theta, np.zeros(0)).value
    cr = crossings.locate_crossings(el, U, 1.0, theta, h, np.zeros(0))
    root = 2 * np.arcsin(np.sqrt((A - (G - OFFSET)) / (2 * A)))  # cos(root) = (G - OFFSET) / A, accurately
    roots = [root, 2 * np.pi - root]
    if A > G + OFFSET:
        back = np.arccos((-G - OFFSET) / A)
        roots += [back, 2 * np.pi - back]
    assert cr.t.size == len(roots)
    assert np.all((cr.t >= 0.0) & (cr.t <= 1.0))
    err = np.abs(cr.phi[:, None] - np.array(roots)[None]).min(axis=1)
    assert err.max() < 1e-13 / np.abs(cr.slope).min()  # rounding of h ~1e-17 over the slope
    assert el.calls <= 10  # measured 3 to 8; 41 (every step) when wandering inside the rounding error
