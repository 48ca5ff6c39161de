"""The compiled pieces of the RK4 monodromy against plain formulas.

The production path builds ``A(t)`` node by node inside the integrator,
multiplies by its lower block row only, bounds the spectral radius on the way
and refines all switching times side by side. Each piece is checked against
its straightforward form: the numpy formula for ``A``, the full-matrix RK4
(:func:`rk4_segments`, bit for bit), the eigenvalues, ``scipy.optimize.brentq``
(bit for bit) and the one-point synthesis of the orbit.
"""

import numpy as np
import pytest
from scipy.optimize import brentq

from contin.model.elements import GapForce, RadialGapForce
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.model.base import Monomial
from contin.models.polynomial import polynomial_model
from contin.stability import monodromy_rk4, orbit_state, switching_events
from contin.stability.monodromy import state_matrices
from contin.stability.rk4 import _full_state_matrices, _lower_blocks, _variational_rk4, rk4_propagate, rk4_segments
from contin.stability.rk4_step_limit import RK4_STABILITY, RK4StepError, _perron_bound, _row_bound, _row_bounds
from contin.stability.saltation import _brentq_all, _switching_elements, _synthesize_at


def numpy_state_matrices(Minv, K, C, dfdx, dfdxd):
    n = Minv.shape[0]
    A = np.zeros((dfdx.shape[0], 2 * n, 2 * n))
    A[:, :n, n:] = np.eye(n)
    A[:, n:, :n] = -np.einsum("ab,jbc->jac", Minv, K[None] + dfdx)
    A[:, n:, n:] = -np.einsum("ab,jbc->jac", Minv, C[None] + dfdxd)
    return A


def random_system(rng, n, N, dense_mass):
    M = np.diag(rng.uniform(0.5, 2.0, n))
    if dense_mass:
        R = rng.normal(scale=0.2, size=(n, n))
        M = M + R @ R.T
    Minv = np.linalg.inv(M)
    K = rng.normal(size=(n, n))
    C = rng.normal(scale=0.1, size=(n, n))
    dfdx = rng.normal(size=(N, n, n))
    dfdxd = rng.normal(scale=0.1, size=(N, n, n))
    return Minv, K, C, dfdx, dfdxd


@pytest.mark.parametrize("n", [1, 2, 4, 5])
@pytest.mark.parametrize("dense_mass", [False, True])
def test_lower_blocks_are_the_numpy_state_matrices(rng, n, dense_mass):
    """``[0, I]`` on top and ``-M^-1 (K + df/dx), -M^-1 (C + df/dx')`` below, with a diagonal or a full mass matrix."""
    Minv, K, C, dfdx, dfdxd = random_system(rng, n, 50, dense_mass)
    A = _full_state_matrices(_lower_blocks(Minv, K, C, dfdx, dfdxd))
    ref = numpy_state_matrices(Minv, K, C, dfdx, dfdxd)
    np.testing.assert_allclose(A, ref, rtol=1e-13, atol=1e-13 * np.abs(ref).max())
    if not dense_mass:  # one term per entry: no summation order to differ in
        np.testing.assert_array_equal(A, ref)


@pytest.mark.parametrize("n", [1, 2, 3, 4, 5])
@pytest.mark.parametrize("dense_mass", [False, True])
def test_block_rk4_is_the_full_matrix_rk4_bit_for_bit(rng, n, dense_mass):
    """The node-by-node kernel, multiplying by the lower block row only, is rk4_segments on the full A.

    n = 1..5 covers the column groups of eight, four and one of the product.
    """
    N = 64
    Minv, K, C, dfdx, dfdxd = random_system(rng, n, N, dense_mass)
    A = _full_state_matrices(_lower_blocks(Minv, K, C, dfdx, dfdxd))
    d = 2 * n
    # the periodic orbit: one segment over all nodes, the last node wrapping to the first
    Phi = _variational_rk4(Minv, K, C, dfdx, dfdxd, np.zeros(1, np.int64), np.array([N // 2], np.int64),
                           np.array([0.01]), np.zeros((0, d, d)))
    np.testing.assert_array_equal(Phi, rk4_propagate(A, 0.01))
    # segments (one of them empty) with jump matrices after each
    starts = np.array([0, 9, 9, 30], dtype=np.int64)
    steps = np.array([4, 0, 10, 5], dtype=np.int64)
    h = np.array([0.011, 0.0, 0.007, 0.013])
    jumps = np.eye(d) + rng.normal(scale=0.1, size=(4, d, d))
    Phi = _variational_rk4(Minv, K, C, dfdx, dfdxd, starts, steps, h, jumps)
    np.testing.assert_array_equal(Phi, rk4_segments(A, starts, steps, h, jumps))
    # no jump after the last segment is the identity there
    Phi = _variational_rk4(Minv, K, C, dfdx, dfdxd, starts, steps, h, jumps[:3])
    last = np.concatenate([jumps[:3], np.eye(d)[None]])
    np.testing.assert_array_equal(Phi, rk4_segments(A, starts, steps, h, last))


def test_row_bound_bounds_the_spectral_radius_closely(rng):
    """An upper bound for any B; within the damping rate of the truth for a mass-spring system."""
    for n in (1, 2, 4, 6):
        for scale in (1e-3, 1.0, 1e4):
            B = rng.normal(scale=scale, size=(20, n, 2 * n))
            rho = np.abs(np.linalg.eigvals(_full_state_matrices(B))).max(axis=1)
            assert np.all(_row_bounds(B) >= rho)
    # stiff contact row of the rotor: stiffness 678000, damping 30 -> |lambda| = 823.4, bound 838
    B = np.array([[-678000.0, -30.0]])
    rho = np.abs(np.linalg.eigvals(_full_state_matrices(B[None])[0])).max()
    assert rho <= _row_bound(B) <= rho + 16.0
    assert np.isnan(_row_bound(np.array([[np.nan, 1.0]])))


def test_perron_bound_bounds_the_spectral_radius_more_closely(rng):
    """Collatz-Wielandt on |A|: an upper bound for any B, never above the row bound; for a light mass on a
    stiff spring (the row sums overestimate by 39%) it is rho(|A|), 5% above the eigenvalue (damping)."""
    for n in (1, 2, 4, 6):
        for scale in (1e-3, 1.0, 1e4):
            B = rng.normal(scale=scale, size=(20, n, 2 * n))
            rho = np.abs(np.linalg.eigvals(_full_state_matrices(B))).max(axis=1)
            x, y = np.empty(2 * n), np.empty(2 * n)
            pb = np.array([_perron_bound(b, x, y, False, 0.0) for b in B])
            assert np.all(pb >= rho) and np.all(pb <= _row_bounds(B))
    B = np.array([[-104.0, 100.0, -0.1, 0.0], [10000.0, -10000.0, 0.0, -10.0]])
    x, y = np.empty(4), np.empty(4)
    rho_abs = np.abs(np.linalg.eigvals(np.abs(_full_state_matrices(B[None])[0]))).max()
    assert _row_bound(B) > 1.38 * rho_abs
    assert rho_abs <= _perron_bound(B, x, y, False, 0.0) <= 1.001 * rho_abs
    # warm from the vector it ends with: converged at once; a bound asked for stops it early
    assert _perron_bound(B, x, y, True, 0.0) <= 1.001 * rho_abs
    assert _perron_bound(B, x, y, False, 200.0) == _row_bound(B)


def oscillator(k, c):
    """x'' + c x' + k x = cos(w t): a linear orbit (H = 1) whose A has |eigenvalues| sqrt(k) or the damping roots."""
    model = polynomial_model(["x"], {"k": k, "c": c, "w": 1.0}, mass=[[1.0]], damping=[["c"]], stiffness=[["k"]],
                             forcing=[{"dof": "x", "amplitude": 1.0}])
    hb = HarmonicBalance(model, "w", HBOptions(harmonics=1))
    return hb, hb.linear_solution(1.0)


def test_a_step_beyond_the_rk4_limit_is_refused():
    """sqrt(k) = 1000 and T = 2 pi: h |lambda| = 6283/S, beyond 2.78 below S = 2261.

    The advice is 2261 with the 5% margin (2375) rounded up to a fast FFT
    length, 2400 = 2^5 3 5^2; with ``max_steps`` the monodromy takes them itself.
    """
    hb, u = oscillator(1e6, 0.0)
    with pytest.raises(RK4StepError, match=r"too large for the stiffest mode.*use steps_per_period >= 2400") as info:
        monodromy_rk4(hb, u, 1.0, 2000)
    assert info.value.needed == 2400 and isinstance(info.value, ArithmeticError)
    assert np.isfinite(monodromy_rk4(hb, u, 1.0, 2300).matrix).all()
    refined = monodromy_rk4(hb, u, 1.0, 2000, max_steps=2400)
    assert refined.steps == 2400
    np.testing.assert_array_equal(refined.matrix, monodromy_rk4(hb, u, 1.0, 2400).matrix)
    with pytest.raises(RK4StepError, match=r"needs steps_per_period >= 2400, beyond max_steps_per_period = 2399"):
        monodromy_rk4(hb, u, 1.0, 2000, max_steps=2399)


def test_the_eigenvalues_decide_where_the_bound_is_not_sharp():
    """Overdamped: |lambda| = (c + sqrt(c^2 - 4k))/2 = 1000 while the bound is (c + sqrt(c^2 + 4k))/2 = 1024.

    A step between the two limits is accepted (the bound alone would refuse it),
    one beyond the eigenvalue's is refused as before.
    """
    k, c = 1000.0 * 24.0, 1024.0  # roots -1000 and -24: sum c, product k
    hb, u = oscillator(k, c)
    T = 2 * np.pi
    assert 1000.0 * T / RK4_STABILITY < 2270 < 1024.0 * T / RK4_STABILITY
    assert np.isfinite(monodromy_rk4(hb, u, 1.0, 2270).matrix).all()
    with pytest.raises(ArithmeticError, match="too large"):
        monodromy_rk4(hb, u, 1.0, 2200)


def test_batched_brent_is_scipy_brentq_bit_for_bit():
    """The side-by-side iteration gives every root exactly as brentq does for that bracket alone."""
    funcs = [lambda t: np.cos(3 * t) - 0.2, lambda t: t**3 - 2 * t - 5, lambda t: np.exp(t) - 1.5,
             lambda t: np.tanh(50 * (t - 0.31)) + 1e-3, lambda t: (t - 0.7) ** 3]
    a = np.array([0.0, 2.0, 0.0, 0.0, 0.0])
    b = np.array([0.6, 3.0, 1.0, 1.0, 1.3])

    def f(t, which):
        return np.array([funcs[r](ti) for ti, r in zip(t, which)])

    fa, fb = f(a, range(5)), f(b, range(5))
    for xtol, rtol in ((4 * np.finfo(float).eps, 4 * np.finfo(float).eps), (1e-6, 1e-10)):
        roots = _brentq_all(f, a, b, fa, fb, np.ones(5, dtype=bool), xtol, rtol, 200)
        for r in range(5):
            assert roots[r] == brentq(funcs[r], a[r], b[r], xtol=xtol, rtol=rtol, maxiter=200)
    with pytest.raises(RuntimeError, match="Failed to converge"):
        _brentq_all(f, a, b, fa, fb, np.ones(5, dtype=bool), 1e-300, 4 * np.finfo(float).eps, 3)


def test_blocked_synthesis_is_the_one_point_synthesis(rng):
    """Every point of a block gets exactly what it gets alone (the blocks and their remainders included)."""
    U = rng.normal(size=(2 * 13 + 1, 3)) / np.arange(1, 28)[:, None]
    th = rng.uniform(0, 20, size=150)
    z = _synthesize_at(U, 1.7, th)
    alone = np.concatenate([_synthesize_at(U, 1.7, th[j:j + 1]) for j in range(th.size)])
    np.testing.assert_array_equal(z, alone)
    # against the plain series
    k = np.arange(1, 14)
    x = U[0] + np.cos(np.outer(th, k)) @ U[1::2] + np.sin(np.outer(th, k)) @ U[2::2]
    xd = 1.7 * (np.cos(np.outer(th, k)) @ (k[:, None] * U[2::2]) - np.sin(np.outer(th, k)) @ (k[:, None] * U[1::2]))
    np.testing.assert_allclose(z, np.hstack([x, xd]), atol=1e-13)


def scalar_switching_events(hb, u, lam, samples):
    """The switch times by scipy's brentq, one sign change at a time (the straightforward form)."""
    n = hb.n
    p = hb.params_at(lam)
    w = float(p[hb.kw])
    T = 2 * np.pi * hb.nu / w
    t = T * np.arange(samples) / samples
    z = orbit_state(hb, u, lam, t)
    out = []
    for _, el, _ in _switching_elements(hb.model):
        on = el.switching_functions(z[:, :n], z[:, n:], w * t, p).value > 0.0
        after = np.roll(on, -1, axis=0)
        for j, i in zip(*np.nonzero(on != after)):
            def h(tt, el=el, i=i):
                zz = orbit_state(hb, u, lam, np.array([tt]))
                return float(el.switching_functions(zz[:, :n], zz[:, n:], np.array([w * tt]), p).value[0, i])

            a, b = t[j], (t[j + 1] if j + 1 < samples else T)
            tc = brentq(h, a, b, xtol=4 * np.finfo(float).eps * T, rtol=4 * np.finfo(float).eps, maxiter=200)
            out.append(tc - T if tc >= T else tc)
    return sorted(out)


def test_switching_events_are_located_as_by_scalar_brentq():
    """Two contact elements (a gap on x, a radial clearance on (x, y)): the same switch times to the bit."""
    model = polynomial_model(["x", "y"], {"c": 0.05, "F": 0.3, "w": 1.0}, mass=[[1.0, 0.0], [0.0, 1.0]],
                             damping=[["c", 0], [0, "c"]], stiffness=[[1.0, 0.2], [0.2, 1.3]],
                             forcing=[{"dof": "x", "amplitude": "F"}, {"dof": "y", "amplitude": "F", "phase": -1.2}])
    # the orbit (the linear response, r from 1.04 to 1.29, |x| up to 1.28) crosses both surfaces
    model.forces.append(GapForce(0, Monomial(0.9), Monomial(0.5), Monomial(0.05), sides="both"))
    model.forces.append(RadialGapForce((0, 1), Monomial(1.15), Monomial(0.8), Monomial(0.1), clip=True))
    hb = HarmonicBalance(model, "w", HBOptions(harmonics=7))
    u, w = hb.linear_solution(1.05), 1.05
    events = switching_events(hb, u, w, 512)
    assert {e.element for e in events} == {0, 1} and len(events) >= 6
    assert [e.time for e in events] == scalar_switching_events(hb, u, w, 512)


def test_state_matrices_and_workspace_reuse():
    """Calls of different sizes in turn reuse scratch arrays without leaking from one into the next."""
    hb, u = oscillator(4.0, 0.1)
    first = monodromy_rk4(hb, u, 1.0, 64).matrix
    monodromy_rk4(hb, u, 1.0, 100)
    np.testing.assert_array_equal(monodromy_rk4(hb, u, 1.0, 64).matrix, first)
    A, T = state_matrices(hb, u, 1.0, 16)
    np.testing.assert_array_equal(A, np.broadcast_to([[0.0, 1.0], [-4.0, -0.1]], (16, 2, 2)))
    assert T == 2 * np.pi
