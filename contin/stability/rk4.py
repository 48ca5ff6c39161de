"""Fixed-step RK4 of the variational equations ``Phi' = A(t) Phi`` along the HB orbit: the compiled kernels.

``A = [[0, I], B]``, ``B = [-M^-1 (K + df/dx), -M^-1 (C + df/dx')]``.
:func:`rk4_propagate` and :func:`rk4_segments` take the full ``A`` at the
RK4 nodes (half steps included); :func:`variational_rk4`, the kernel of
:func:`contin.stability.monodromy.monodromy_rk4`, takes the element Jacobians
at the nodes (:func:`force_jacobians`, evaluated once on all of them into a
per-thread workspace) and builds ``B`` itself. Whether a step is within
RK4's stability limit along the orbit is decided in
:mod:`contin.stability.rk4_step_limit`.

The cost is in the products ``A Phi``. The kernel builds the lower block
row ``B = [-M^-1 (K + df/dx), -M^-1 (C + df/dx')]`` of ``A`` node by node
from the element Jacobians (``M^-1`` once per call, its zero entries
skipped) and multiplies by ``B`` only, the upper block row ``[0, I]``
being a copy: half the work of the full product, with every entry summed
in the same order, so the result is the same to the last bit.
"""

from __future__ import annotations

import threading

import numpy as np

from contin.util.jit import njit

__all__ = ["rk4_propagate", "rk4_segments", "force_jacobians", "full_state_matrices", "lower_blocks", "node_block",
           "nonzero_pattern", "variational_rk4"]



class _Workspace(threading.local):
    """Scratch arrays of the orbit-wide evaluations, kept from one call to the next (one set per thread).

    The force Jacobians along the orbit take megabytes; allocated afresh on
    every call, their pages would be faulted in anew each time, at a cost
    comparable to the integration.
    """

    def __init__(self):
        self.buffers = {}

    def zeros(self, name, shape):
        """A zeroed array of ``shape`` on the buffer ``name`` (grown as needed, so that sizes may vary)."""
        size = int(np.prod(shape))
        buf = self.buffers.get(name)
        if buf is None or buf.size < size:
            # headroom: the node count of the piecewise path changes a little from one orbit to the next
            buf = self.buffers[name] = np.empty(size + size // 8)
        a = buf[:size].reshape(shape)
        a.fill(0.0)
        return a


_WORK = _Workspace()


def force_jacobians(hb, x, xd, tau, p, scratch=False):
    """Total internal force (N, n) and its Jacobians (N, n, n) at the states ``x``, ``xd`` (N, n).

    ``scratch``: return arrays of the thread's workspace, valid until the
    next such call (for results consumed at once).
    """
    N, n = x.shape
    if scratch:
        f, dfdx, dfdxd = _WORK.zeros("f", (N, n)), _WORK.zeros("dfdx", (N, n, n)), _WORK.zeros("dfdxd", (N, n, n))
    else:
        f, dfdx, dfdxd = np.zeros((N, n)), np.zeros((N, n, n)), np.zeros((N, n, n))
    for el in hb.model.forces:
        el.evaluate(x, xd, tau, p, f, dfdx, dfdxd)
    return f, dfdx, dfdxd


@njit(cache=True)
def nonzero_pattern(Minv):
    """Column indices of the nonzeros of each row of ``Minv``: ``(count (n,), cols (n, n))``."""
    n = Minv.shape[0]
    count = np.zeros(n, np.int64)
    cols = np.zeros((n, n), np.int64)
    for a in range(n):
        for b in range(n):
            if Minv[a, b] != 0.0:
                cols[a, count[a]] = b
                count[a] += 1
    return count, cols


@njit(cache=True)
def node_block(count, cols, Minv, K, C, dfdx, dfdxd, j, out):
    """``out = [-Minv (K + dfdx[j]), -Minv (C + dfdxd[j])]``, shape (n, 2n).

    Each entry is the sum over ``b`` in ascending order; the terms with
    ``Minv[a, b] = 0`` (most of them: mass matrices are mostly diagonal or
    banded; ``count``, ``cols`` from :func:`nonzero_pattern`) would add
    exact zeros and are skipped.
    """
    n = Minv.shape[0]
    for a in range(n):
        if count[a] == 1:
            b = cols[a, 0]
            m = Minv[a, b]
            for c in range(n):
                out[a, c] = -(m * (K[b, c] + dfdx[j, b, c]))
                out[a, n + c] = -(m * (C[b, c] + dfdxd[j, b, c]))
            continue
        for c in range(n):
            s1 = 0.0
            s2 = 0.0
            for q in range(count[a]):
                b = cols[a, q]
                m = Minv[a, b]
                s1 += m * (K[b, c] + dfdx[j, b, c])
                s2 += m * (C[b, c] + dfdxd[j, b, c])
            out[a, c] = -s1
            out[a, n + c] = -s2


@njit(cache=True)
def lower_blocks(Minv, K, C, dfdx, dfdxd):
    """``B[j] = [-Minv (K + dfdx[j]), -Minv (C + dfdxd[j])]`` (see :func:`node_block`).

    Parameters
    ----------
    Minv, K, C : ndarray, shape (n, n)
    dfdx, dfdxd : ndarray, shape (N, n, n)

    Returns
    -------
    ndarray, shape (N, n, 2n)
    """
    N = dfdx.shape[0]
    n = Minv.shape[0]
    count, cols = nonzero_pattern(Minv)
    B = np.empty((N, n, 2 * n))
    for j in range(N):
        node_block(count, cols, Minv, K, C, dfdx, dfdxd, j, B[j])
    return B


def full_state_matrices(B):
    """``A = [[0, I], B]`` from its lower block rows ``B`` (N, n, 2n): shape (N, 2n, 2n)."""
    N, n = B.shape[0], B.shape[1]
    A = np.zeros((N, 2 * n, 2 * n))
    A[:, :n, n:] = np.eye(n)
    A[:, n:, :] = B
    return A


@njit(cache=True)
def _matmul_into(A, B, out):
    d = A.shape[0]
    for i in range(d):
        for j in range(d):
            s = 0.0
            for k in range(d):
                s += A[i, k] * B[k, j]
            out[i, j] = s


@njit(cache=True)
def _rk4_step(A0, A1, A2, Phi, h, k1, k2, k3, k4, tmp):
    """One classical RK4 step of ``Phi' = A(t) Phi`` in place (``A1`` at the half step)."""
    d = Phi.shape[0]
    _matmul_into(A0, Phi, k1)
    for i in range(d):
        for j in range(d):
            tmp[i, j] = Phi[i, j] + 0.5 * h * k1[i, j]
    _matmul_into(A1, tmp, k2)
    for i in range(d):
        for j in range(d):
            tmp[i, j] = Phi[i, j] + 0.5 * h * k2[i, j]
    _matmul_into(A1, tmp, k3)
    for i in range(d):
        for j in range(d):
            tmp[i, j] = Phi[i, j] + h * k3[i, j]
    _matmul_into(A2, tmp, k4)
    for i in range(d):
        for j in range(d):
            Phi[i, j] += h / 6.0 * (k1[i, j] + 2.0 * k2[i, j] + 2.0 * k3[i, j] + k4[i, j])


@njit(cache=True)
def rk4_propagate(A, h):
    """Classical RK4 for ``Phi' = A(t) Phi``, ``Phi(0) = I``, over one period.

    Parameters
    ----------
    A : ndarray, shape (2S, d, d)
        ``A`` at ``t_j = j h / 2`` (periodic: ``A(S h) = A(0)``).
    h : float
        Step ``T / S``.

    Returns
    -------
    ndarray, shape (d, d)
        ``Phi(T)``.
    """
    S = A.shape[0] // 2
    d = A.shape[1]
    Phi = np.eye(d)
    k1, k2, k3, k4, tmp = np.empty((d, d)), np.empty((d, d)), np.empty((d, d)), np.empty((d, d)), np.empty((d, d))
    for step in range(S):
        _rk4_step(A[2 * step], A[2 * step + 1], A[(2 * step + 2) % (2 * S)], Phi, h, k1, k2, k3, k4, tmp)
    return Phi


@njit(cache=True)
def rk4_segments(A, starts, steps, h, jumps):
    """Classical RK4 for ``Phi' = A(t) Phi`` over consecutive segments, with a jump matrix after each.

    Segment ``s`` takes ``steps[s]`` steps of length ``h[s]`` with ``A`` read
    at its ``2 steps[s] + 1`` nodes ``A[starts[s] + j]``, ``j = 0 .. 2 steps[s]``
    (the half steps included; the end nodes are the one-sided limits at the
    segment ends). After the segment ``Phi <- jumps[s] Phi``.

    Parameters
    ----------
    A : ndarray, shape (K, d, d)
    starts, steps : ndarray of int64, shape (G,)
    h : ndarray, shape (G,)
    jumps : ndarray, shape (G, d, d)

    Returns
    -------
    ndarray, shape (d, d)
    """
    d = A.shape[1]
    Phi = np.eye(d)
    k1, k2, k3, k4, tmp = np.empty((d, d)), np.empty((d, d)), np.empty((d, d)), np.empty((d, d)), np.empty((d, d))
    for seg in range(steps.shape[0]):
        for step in range(steps[seg]):
            j0 = starts[seg] + 2 * step
            _rk4_step(A[j0], A[j0 + 1], A[j0 + 2], Phi, h[seg], k1, k2, k3, k4, tmp)
        _matmul_into(jumps[seg], Phi, tmp)
        for i in range(d):
            for j in range(d):
                Phi[i, j] = tmp[i, j]
    return Phi


@njit(cache=True)
def _block_stage(B, X, k):
    """``k = A X`` with ``A = [[0, I], B]``, ``B`` (n, d), ``X`` and ``k`` (d, d).

    The upper half of the product is a copy of the lower half of ``X``. Each
    entry of the lower half is the ascending sum of :func:`_matmul_into`;
    the columns are taken eight or four at a time, with the partial sums in
    registers, which is where the time of the monodromy goes.
    """
    n = B.shape[0]
    d = X.shape[0]
    for i in range(n):
        for j in range(d):
            k[i, j] = X[n + i, j]
    for a in range(n):
        j = 0
        while j + 8 <= d:
            s0 = s1 = s2 = s3 = s4 = s5 = s6 = s7 = 0.0
            for c in range(d):
                b = B[a, c]
                s0 += b * X[c, j]
                s1 += b * X[c, j + 1]
                s2 += b * X[c, j + 2]
                s3 += b * X[c, j + 3]
                s4 += b * X[c, j + 4]
                s5 += b * X[c, j + 5]
                s6 += b * X[c, j + 6]
                s7 += b * X[c, j + 7]
            k[n + a, j] = s0
            k[n + a, j + 1] = s1
            k[n + a, j + 2] = s2
            k[n + a, j + 3] = s3
            k[n + a, j + 4] = s4
            k[n + a, j + 5] = s5
            k[n + a, j + 6] = s6
            k[n + a, j + 7] = s7
            j += 8
        while j + 4 <= d:
            s0 = s1 = s2 = s3 = 0.0
            for c in range(d):
                b = B[a, c]
                s0 += b * X[c, j]
                s1 += b * X[c, j + 1]
                s2 += b * X[c, j + 2]
                s3 += b * X[c, j + 3]
            k[n + a, j] = s0
            k[n + a, j + 1] = s1
            k[n + a, j + 2] = s2
            k[n + a, j + 3] = s3
            j += 4
        while j < d:
            s0 = 0.0
            for c in range(d):
                s0 += B[a, c] * X[c, j]
            k[n + a, j] = s0
            j += 1


@njit(cache=True)
def _rk4_block_step(B0, B1, B2, Phi, h, k1, k2, k3, k4, tmp):
    """One classical RK4 step of ``Phi' = A(t) Phi`` in place, ``A = [[0, I], B]`` (``B1`` at the half step).

    The same operations, in the same order, as :func:`_rk4_step` on the full
    matrices; only the products with the ``[0, I]`` rows are skipped.
    """
    d = Phi.shape[0]
    hh = 0.5 * h
    _block_stage(B0, Phi, k1)
    for i in range(d):
        for j in range(d):
            tmp[i, j] = Phi[i, j] + hh * k1[i, j]
    _block_stage(B1, tmp, k2)
    for i in range(d):
        for j in range(d):
            tmp[i, j] = Phi[i, j] + hh * k2[i, j]
    _block_stage(B1, tmp, k3)
    for i in range(d):
        for j in range(d):
            tmp[i, j] = Phi[i, j] + h * k3[i, j]
    _block_stage(B2, tmp, k4)
    h6 = h / 6.0
    for i in range(d):
        for j in range(d):
            Phi[i, j] += h6 * (k1[i, j] + 2.0 * k2[i, j] + 2.0 * k3[i, j] + k4[i, j])



@njit(cache=True)
def variational_rk4(Minv, K, C, dfdx, dfdxd, starts, steps, h, jumps):
    """Classical RK4 for ``Phi' = A(t) Phi``, ``Phi(0) = I``, with ``A`` built node by node.

    ``A = [[0, I], [-Minv (K + dfdx[j]), -Minv (C + dfdxd[j])]]`` at node
    ``j`` (:func:`node_block`), each node's lower block row built once, as
    its step needs it, and never stored. Segment ``s`` takes ``steps[s]``
    steps of length ``h[s]`` on the nodes ``starts[s] + i``, ``i = 0 .. 2
    steps[s]`` (half steps included; node indices are taken modulo ``N``, so
    that one segment ``starts = [0]``, ``steps = [S]`` over ``N = 2S``
    nodes is the periodic orbit); after it ``Phi <- jumps[s] Phi`` if
    ``s < len(jumps)``. The arithmetic is that of :func:`rk4_segments` on the
    full matrices.

    Parameters
    ----------
    Minv, K, C : ndarray, shape (n, n)
    dfdx, dfdxd : ndarray, shape (N, n, n)
    starts, steps : ndarray of int64, shape (G,)
    h : ndarray, shape (G,)
    jumps : ndarray, shape (G or fewer, 2n, 2n)

    Returns
    -------
    ndarray, shape (2n, 2n)
    """
    N = dfdx.shape[0]
    n = Minv.shape[0]
    d = 2 * n
    count, cols = nonzero_pattern(Minv)
    Phi = np.eye(d)
    k1, k2, k3, k4, tmp = np.empty((d, d)), np.empty((d, d)), np.empty((d, d)), np.empty((d, d)), np.empty((d, d))
    Ba, Bm, Bb = np.empty((n, d)), np.empty((n, d)), np.empty((n, d))
    for seg in range(steps.shape[0]):
        if steps[seg] > 0:
            j0 = starts[seg]
            node_block(count, cols, Minv, K, C, dfdx, dfdxd, j0 % N, Ba)
            for step in range(steps[seg]):
                jm = j0 + 2 * step + 1
                node_block(count, cols, Minv, K, C, dfdx, dfdxd, jm % N, Bm)
                node_block(count, cols, Minv, K, C, dfdx, dfdxd, (jm + 1) % N, Bb)
                _rk4_block_step(Ba, Bm, Bb, Phi, h[seg], k1, k2, k3, k4, tmp)
                Ba, Bb = Bb, Ba
        if seg < jumps.shape[0]:
            _matmul_into(jumps[seg], Phi, tmp)
            for i in range(d):
                for j in range(d):
                    Phi[i, j] = tmp[i, j]
    return Phi


# the former private names, which code outside this package's layers still imports
_full_state_matrices = full_state_matrices
_lower_blocks = lower_blocks
_variational_rk4 = variational_rk4
