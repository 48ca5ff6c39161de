"""Alternating frequency-time (AFT) kernels, compiled with numba.

Coefficients follow the ordering table of :mod:`contin.hb.harmonics`: a matrix
``U`` of shape ``(2H+1, n)`` whose rows are ``a_0, a_1, b_1, ..., a_H, b_H``.
Transforms are real FFTs of length ``N`` (numba support for ``numpy.fft`` is
provided by ``rocket-fft``). ``N >= 2H+1`` is required so that every
retained harmonic is resolved.

The Jacobian is carried through the AFT analytically: the time samples of a
matrix field ``G(theta)`` (for example ``df/dx``) are transformed once, and the
coefficient-space matrix of "multiply by G" follows from the product-to-sum
identities

    <G cos k cos l> = (C(k-l) + C(k+l))/2     <G cos k sin l> = (S(k+l) - S(k-l))/2
    <G sin k cos l> = (S(k+l) + S(k-l))/2     <G sin k sin l> = (C(k-l) - C(k+l))/2

with ``C(m) = <G cos m theta>`` and ``S(m) = <G sin m theta>`` the discrete
averages over the ``N`` samples (aliasing included, so the result is the
exact derivative of the discrete residual). The cost is
``O(n^2 (N log N + H^2))`` instead of the ``O(n^2 N H^2)`` of the dense
``E^T diag(G) E`` product.
"""

from __future__ import annotations

import numpy as np
import rocket_fft  # noqa: F401  (registers numpy.fft for numba)

from contin.util.jit import njit

__all__ = [
    "synthesize",
    "project",
    "multiplication_matrix",
    "assemble_jacobian",
    "matvec_samples",
    "odd_multiplication_matrix",
    "odd_jacobian",
    "product_block",
]


@njit(cache=True)
def synthesize(U, N):
    """Time samples of ``x`` and of ``dx/dtheta``.

    Parameters
    ----------
    U : ndarray, shape (2H+1, n)
    N : int
        Sample count, ``N >= 2H+1``.

    Returns
    -------
    x, xp : ndarray, shape (N, n)
        ``x(theta_j)`` and its derivative with respect to ``theta``.
    """
    H = (U.shape[0] - 1) // 2
    n = U.shape[1]
    if N < 2 * H + 1:
        # numba does not check bounds: fewer samples would write past the spectrum
        raise ValueError("synthesize needs N >= 2H+1 samples")
    X = np.zeros((N // 2 + 1, n), dtype=np.complex128)
    Xp = np.zeros((N // 2 + 1, n), dtype=np.complex128)
    half = 0.5 * N
    for i in range(n):
        X[0, i] = N * U[0, i]
    for k in range(1, H + 1):
        for i in range(n):
            a = U[2 * k - 1, i]
            b = U[2 * k, i]
            X[k, i] = half * (a - 1j * b)
            # d/dtheta: a cos + b sin -> k(b cos - a sin)
            Xp[k, i] = half * k * (b + 1j * a)
    x = np.fft.irfft(X, N, axis=0)
    xp = np.fft.irfft(Xp, N, axis=0)
    return x, xp


@njit(cache=True)
def project(f, H):
    """Fourier coefficients of sampled values (the discrete Galerkin projection).

    Parameters
    ----------
    f : ndarray, shape (N, n)
    H : int

    Returns
    -------
    ndarray, shape (2H+1, n)
        ``a_0 = mean``, ``a_k = (2/N) sum f cos``, ``b_k = (2/N) sum f sin``.
    """
    N = f.shape[0]
    n = f.shape[1]
    if N < 2 * H + 1:
        raise ValueError("project needs N >= 2H+1 samples")  # numba does not check bounds
    F = np.fft.rfft(f, axis=0)
    out = np.empty((2 * H + 1, n))
    inv = 1.0 / N
    for i in range(n):
        out[0, i] = F[0, i].real * inv
    for k in range(1, H + 1):
        for i in range(n):
            out[2 * k - 1, i] = 2.0 * inv * F[k, i].real
            out[2 * k, i] = -2.0 * inv * F[k, i].imag
    return out


@njit(cache=True)
def _cs(Ghat, m, N):
    """``C(m), S(m)`` from the rfft of a real signal, folded for aliasing."""
    mm = m % N
    if mm <= N // 2:
        z = Ghat[mm]
        return z.real / N, -z.imag / N
    z = Ghat[N - mm]
    return z.real / N, z.imag / N


@njit(cache=True, inline="always")  # in the innermost loop of every Jacobian: no call
def product_block(T, rc, rs, cc, cs, row_sine, col_sine, h, Cm, Sm, Cp, Sp):
    """Add the product-to-sum entries of one (row harmonic, column harmonic) pair, weighted by ``h``.

    Rows ``rc``/``rs`` (cosine/sine of the row harmonic; no sine row for the mean), columns ``cc``/``cs``;
    ``Cm, Sm`` at the difference and ``Cp, Sp`` at the sum of the two harmonics (vector indices on a torus,
    :mod:`contin.hb.aft2d`).
    """
    T[rc, cc] += h * (Cm + Cp)
    if col_sine:
        T[rc, cs] += h * (Sp - Sm)
    if row_sine:
        T[rs, cc] += h * (Sp + Sm)
        if col_sine:
            T[rs, cs] += h * (Cm - Cp)


@njit(cache=True)
def _fill_block(Ghat, N, H, n, a, b, T, scale):
    # Block of "multiply by G_ab" between dof a (rows) and dof b (columns).
    for k in range(H + 1):
        wk = scale if k == 0 else 2.0 * scale
        rc = (0 if k == 0 else 2 * k - 1) * n + a
        rs = 2 * k * n + a
        for l in range(H + 1):
            cc = (0 if l == 0 else 2 * l - 1) * n + b
            cs = 2 * l * n + b
            Cm, Sm = _cs(Ghat, k - l, N)
            Cp, Sp = _cs(Ghat, k + l, N)
            product_block(T, rc, rs, cc, cs, k > 0, l > 0, 0.5 * wk, Cm, Sm, Cp, Sp)


@njit(cache=True)
def multiplication_matrix(G, H, T, scale):
    """Accumulate the coefficient-space matrix of ``g(theta) = G(theta) v(theta)``.

    Parameters
    ----------
    G : ndarray, shape (N, n, n)
        Samples of the matrix field.
    H : int
    T : ndarray, shape (n(2H+1), n(2H+1))
        Accumulated in place: ``T += scale * [v -> proj(G v)]``.
    scale : float
    """
    N = G.shape[0]
    n = G.shape[1]
    for a in range(n):
        for b in range(n):
            g = np.ascontiguousarray(G[:, a, b])
            if np.max(np.abs(g)) == 0.0:
                continue  # skip uncoupled dof pairs (common for local contacts)
            Ghat = np.fft.rfft(g)
            _fill_block(Ghat, N, H, n, a, b, T, scale)


@njit(cache=True)
def _fill_velocity_block(Ghat, N, H, n, a, b, Omega, J):
    # Block of "multiply by G_ab, then by Omega d/dtheta" between dof a (rows) and dof b (columns):
    # the columns of harmonic l of the block of _fill_block, combined as (a_l, b_l) <- Omega l (-b_l, a_l).
    # Filled in place so that no second dense matrix is allocated and swept.
    for k in range(H + 1):
        h = 0.5 if k == 0 else 1.0
        rc = (0 if k == 0 else 2 * k - 1) * n + a
        rs = 2 * k * n + a
        for l in range(1, H + 1):
            s = Omega * l * h
            cc = (2 * l - 1) * n + b
            cs = 2 * l * n + b
            Cm, Sm = _cs(Ghat, k - l, N)
            Cp, Sp = _cs(Ghat, k + l, N)
            J[rc, cc] -= s * (Sp - Sm)
            J[rc, cs] += s * (Cm + Cp)
            if k > 0:
                J[rs, cc] -= s * (Cm - Cp)
                J[rs, cs] += s * (Sp + Sm)


@njit(cache=True)
def _coupled(dfdx, dfdxd, a, b):
    """Whether dofs ``a, b`` are coupled through ``df/dx`` and through ``df/dx'`` at any sample.

    Uncoupled pairs (common for local contacts) are skipped; a NaN counts as coupled.
    """
    hx = False
    hv = False
    for j in range(dfdx.shape[0]):
        hx = hx or dfdx[j, a, b] != 0.0
        hv = hv or dfdxd[j, a, b] != 0.0
    return hx, hv


@njit(cache=True)
def assemble_jacobian(dfdx, dfdxd, Omega, H, J):
    """Accumulate ``d proj(f(x, xdot)) / du`` into ``J``.

    ``xdot = Omega * D u`` with ``D`` the ``d/dtheta`` operator, whose action on
    harmonic ``l`` maps ``(a_l, b_l) -> (l b_l, -l a_l)``. Hence the velocity
    part is the matrix of ``dfdxd`` with columns ``a_l <- -Omega l (b_l column)``
    and ``b_l <- Omega l (a_l column)``, written straight into ``J``.

    Parameters
    ----------
    dfdx, dfdxd : ndarray, shape (N, n, n)
    Omega : float
        Base frequency ``w/nu``.
    H : int
    J : ndarray, shape (n(2H+1), n(2H+1)), accumulated in place.
    """
    N = dfdx.shape[0]
    n = dfdx.shape[1]
    g = np.empty(N)
    for a in range(n):
        for b in range(n):
            hx, hv = _coupled(dfdx, dfdxd, a, b)
            if hx:
                for j in range(N):
                    g[j] = dfdx[j, a, b]
                _fill_block(np.fft.rfft(g), N, H, n, a, b, J, 1.0)
            if hv:
                for j in range(N):
                    g[j] = dfdxd[j, a, b]
                _fill_velocity_block(np.fft.rfft(g), N, H, n, a, b, Omega, J)


@njit(cache=True)
def odd_multiplication_matrix(G, H, T, scale):
    """Odd-harmonic block of "multiply by G" in the doubled representation.

    ``G(theta)`` is a ``2 pi``-periodic matrix field sampled at the ``N``
    phases ``theta_j`` of an order-``nu`` solution. Seen in the order-``2 nu``
    representation (base phase ``theta' = theta/2``, ``2H`` harmonics,
    ``2N`` samples) it has only even harmonics of ``theta'``, so
    multiplication by it maps odd harmonics of ``theta'`` to odd harmonics.
    This is that odd-to-odd block, computed from the ``N`` samples alone:
    the averages over the ``2N`` doubled samples of ``G cos(m theta')`` are
    ``C(m/2)`` (``N``-sample averages in ``theta``) for even ``m`` and vanish
    for odd ``m``, so the block equals the odd rows and columns of the
    order-``2 nu`` Jacobian exactly (aliasing included).

    Parameters
    ----------
    G : ndarray, shape (N, n, n)
    H : int
        Harmonics of the order-``nu`` problem; the block has the ``H`` odd
        harmonics ``1, 3, ..., 2H-1`` of ``theta'``.
    T : ndarray, shape (2nH, 2nH)
        Accumulated in place; rows and columns ordered
        ``[a_1; b_1; a_3; b_3; ...]`` (each block the ``n`` dofs), the order of
        :func:`contin.bifurcation.switching.odd_indices` on the ``2H`` harmonics.
    scale : float
    """
    N = G.shape[0]
    n = G.shape[1]
    for a in range(n):
        for b in range(n):
            g = np.ascontiguousarray(G[:, a, b])
            if np.max(np.abs(g)) == 0.0:
                continue
            _fill_odd_block(np.fft.rfft(g), N, H, n, a, b, T, scale, 0.0, False)


@njit(cache=True)
def _fill_odd_block(Ghat, N, H, n, a, b, T, scale, Omega2, velocity):
    # Odd-to-odd block of "multiply by G_ab" (velocity=False) or of "multiply by G_ab after
    # Omega2 d/dtheta'" (velocity=True: columns (a_l, b_l) <- Omega2 l (-b_l, a_l)), in place.
    for i in range(H):
        k = 2 * i + 1
        rc = 2 * i * n + a
        rs = (2 * i + 1) * n + a
        for j in range(H):
            l = 2 * j + 1
            cc = 2 * j * n + b
            cs = (2 * j + 1) * n + b
            Cm, Sm = _cs(Ghat, (k - l) // 2, N)
            Cp, Sp = _cs(Ghat, (k + l) // 2, N)
            if velocity:
                v = scale * Omega2 * l
                T[rc, cc] -= v * (Sp - Sm)
                T[rc, cs] += v * (Cm + Cp)
                T[rs, cc] -= v * (Cm - Cp)
                T[rs, cs] += v * (Sp + Sm)
            else:
                T[rc, cc] += scale * (Cm + Cp)
                T[rc, cs] += scale * (Sp - Sm)
                T[rs, cc] += scale * (Sp + Sm)
                T[rs, cs] += scale * (Cm - Cp)


@njit(cache=True)
def odd_jacobian(dfdx, dfdxd, Omega2, H, B):
    """Accumulate the odd-harmonic block of the order-``2 nu`` force Jacobian.

    The counterpart of :func:`assemble_jacobian` for
    :func:`odd_multiplication_matrix`: the velocity part acts through
    ``Omega2 d/dtheta'`` on odd harmonic ``l``.

    Parameters
    ----------
    dfdx, dfdxd : ndarray, shape (N, n, n)
        Sampled on the order-``nu`` grid.
    Omega2 : float
        Base frequency of the doubled representation, ``w / (2 nu)``.
    H : int
    B : ndarray, shape (2nH, 2nH), accumulated in place.
    """
    N = dfdx.shape[0]
    n = dfdx.shape[1]
    g = np.empty(N)
    for a in range(n):
        for b in range(n):
            hx, hv = _coupled(dfdx, dfdxd, a, b)
            if hx:
                for j in range(N):
                    g[j] = dfdx[j, a, b]
                _fill_odd_block(np.fft.rfft(g), N, H, n, a, b, B, 1.0, 0.0, False)
            if hv:
                for j in range(N):
                    g[j] = dfdxd[j, a, b]
                _fill_odd_block(np.fft.rfft(g), N, H, n, a, b, B, 1.0, Omega2, True)


@njit(cache=True)
def matvec_samples(G, v):
    """Per-sample product ``G_j v_j``; shapes (N, n, n) x (N, n) -> (N, n)."""
    N = G.shape[0]
    n = G.shape[1]
    out = np.zeros((N, n))
    for j in range(N):
        for a in range(n):
            s = 0.0
            for b in range(n):
                s += G[j, a, b] * v[j, b]
            out[j, a] = s
    return out


@njit(cache=True)
def nonlinear_terms(f, dfdx, dfdxd, dfdp, xp, Omega, nu, H, with_w, J):
    """Project the force and assemble its Jacobians in one call (the Newton hot path).

    Parameters
    ----------
    f : ndarray, shape (N, n)
        Sampled nonlinear force.
    dfdx, dfdxd : ndarray, shape (N, n, n)
    dfdp : ndarray, shape (N, n)
        Explicit derivative of the force with respect to lambda.
    xp : ndarray, shape (N, n)
        ``dx/dtheta`` at the samples.
    Omega : float
        Base frequency ``w/nu``.
    nu : int
    H : int
    with_w : bool
        Lambda is the frequency: add ``df/dx' * x'(theta)/nu`` to ``dfdp``.
    J : ndarray, shape (n(2H+1), n(2H+1))
        Accumulated in place with ``dR/du``.

    Returns
    -------
    R, Jlam : ndarray, shape (n(2H+1),)
        Projected force and its ``lambda`` derivative.
    """
    assemble_jacobian(dfdx, dfdxd, Omega, H, J)
    if with_w:
        dfdp = dfdp + matvec_samples(dfdxd, xp) / nu
    return project(f, H).ravel(), project(dfdp, H).ravel()
