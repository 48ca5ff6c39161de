"""AFT kernels against plain numpy references (dense trigonometric matrices)."""

import numpy as np
import pytest

from contin.hb import aft
from contin.hb.harmonics import coefficient_blocks, default_samples, embed, harmonic_amplitudes, index, sample_phases


def trig_matrix(H, N):
    """E with x(theta_j) = E @ U, columns ordered as the coefficient table."""
    th = sample_phases(N)
    cols = [np.ones(N)]
    for k in range(1, H + 1):
        cols += [np.cos(k * th), np.sin(k * th)]
    return np.column_stack(cols)


@pytest.mark.parametrize("H,N", [(1, 3), (3, 7), (4, 17), (5, 64)])
def test_synthesize_and_project_match_dense_transform(H, N, rng):
    n = 3
    U = rng.normal(size=(2 * H + 1, n))
    E = trig_matrix(H, N)
    x, xp = aft.synthesize(U, N)
    np.testing.assert_allclose(x, E @ U, atol=1e-13)
    # derivative: d/dtheta of cos k -> -k sin k, sin k -> k cos k
    D = np.zeros((2 * H + 1, 2 * H + 1))
    for k in range(1, H + 1):
        D[2 * k, 2 * k - 1] = -k  # a_k cos -> -k a_k sin
        D[2 * k - 1, 2 * k] = k
    np.testing.assert_allclose(xp, E @ (D @ U), atol=1e-12)
    np.testing.assert_allclose(aft.project(x, H), U, atol=1e-13)


@pytest.mark.parametrize("H,N", [(2, 5), (3, 13), (4, 9), (6, 40)])
def test_multiplication_matrix_equals_dense_galerkin_product(H, N, rng):
    """T = W E^T diag(G) E / N, W = diag(1, 2, 2, ...), including aliasing when N is small."""
    n = 2
    G = rng.normal(size=(N, n, n))
    T = np.zeros((n * (2 * H + 1),) * 2)
    aft.multiplication_matrix(G, H, T, 1.0)
    E = trig_matrix(H, N)
    W = np.diag([1.0] + [2.0] * (2 * H)) / N
    for a in range(n):
        for b in range(n):
            ref = W @ E.T @ (G[:, a, b][:, None] * E)
            np.testing.assert_allclose(T[a::n, b::n], ref, atol=1e-12)


def test_cubic_aft_is_exact_galerkin_projection_with_default_samples(rng):
    """With N = 4H+1 the projection of x^3 equals the exact integral (fine quadrature)."""
    for H in (1, 3, 7):
        N = default_samples(H, 3)
        assert N == 4 * H + 1
        U = rng.normal(size=(2 * H + 1, 1))
        x, _ = aft.synthesize(U, N)
        coarse = aft.project(x**3, H)
        Nf = 8 * 4 * H + 3  # far above aliasing: the exact Galerkin integral
        xf, _ = aft.synthesize(U, Nf)
        exact = aft.project(xf**3, H)
        np.testing.assert_allclose(coarse, exact, atol=1e-12 * np.abs(exact).max())
        # one sample fewer aliases: the projection is no longer exact
        x2, _ = aft.synthesize(U, N - 1)
        assert np.abs(aft.project(x2**3, H) - exact).max() > 1e-8


def test_ordering_helpers():
    n, H = 2, 3
    u = np.arange(n * (2 * H + 1), dtype=float)
    U = coefficient_blocks(u, n)
    assert U[0, 1] == u[index(1, 0, "c", n)]
    assert U[2 * 2 - 1, 0] == u[index(0, 2, "c", n)]
    assert U[2 * 3, 1] == u[index(1, 3, "s", n)]
    amp = harmonic_amplitudes(u, n)
    assert amp.shape == (H + 1, n)
    np.testing.assert_allclose(amp[2, 1], np.hypot(u[index(1, 2, "c", n)], u[index(1, 2, "s", n)]))
    with pytest.raises(ValueError, match="mean"):
        index(0, 0, "s", n)


def test_embed_doubles_the_period_representation(rng):
    n, H = 2, 3
    u = rng.normal(size=n * (2 * H + 1))
    v = embed(u, n, 2)
    x1, _ = aft.synthesize(coefficient_blocks(u, n).copy(), 64)
    x2, _ = aft.synthesize(coefficient_blocks(v, n).copy(), 128)
    # the nu=2 representation sampled over its period repeats the nu=1 orbit twice
    np.testing.assert_allclose(x2[:64], x1, atol=1e-12)
    np.testing.assert_allclose(x2[64:], x1, atol=1e-12)
    # odd harmonics are zero
    V = coefficient_blocks(v, n)
    for k in range(1, 2 * H + 1, 2):
        assert not V[2 * k - 1].any() and not V[2 * k].any()


def test_too_few_samples_is_an_error_not_a_write_past_the_spectrum():
    import pytest

    from contin.hb import aft

    with pytest.raises(ValueError, match="2H"):
        aft.synthesize(np.zeros((81, 4)), 64)
    with pytest.raises(ValueError, match="2H"):
        aft.project(np.zeros((64, 4)), 40)
