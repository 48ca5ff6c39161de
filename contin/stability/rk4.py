"""Fixed-step RK4 of the variational equations ``Phi' = A(t) Phi`` along the HB orbit: the compiled kernels.

``A = [[0, I], B]``, ``B = [-M^-1 (K + df/dx), -M^-1 (C + df/dx')]``.
:func:`rk4_propagate` and :func:`rk4_segments` take the full ``A`` at the
RK4 nodes (half steps included); :func:`_variational_rk4`, the kernel of
:func:`contin.stability.monodromy.monodromy_rk4`, takes the element Jacobians
at the nodes (:func:`_force_jacobians`, evaluated once on all of them into a
per-thread workspace) and builds ``B`` itself. A step beyond RK4's stability
limit for the stiffest eigenvalue of ``A`` along the orbit is refused
(:func:`_check_rk4_step`, raising :class:`RK4StepError` with the step count
that eigenvalue needs).

The cost is in the products ``A Phi``. The kernel builds the lower block
row ``B = [-M^-1 (K + df/dx), -M^-1 (C + df/dx')]`` of ``A`` node by node
from the element Jacobians (``M^-1`` once per call, its zero entries
skipped) and multiplies by ``B`` only, the upper block row ``[0, I]``
being a copy: half the work of the full product, with every entry summed
in the same order, so the result is the same to the last bit.

The stability check looks at ``A`` on every node of the integration: a
strided subset would sample the orbit differently for each step count, so
that the count asked for after a refusal could be refused again. At each
node an upper bound of the spectral radius, the Collatz-Wielandt bound of
``|A|`` (:func:`_perron_bound`: a few power iterations, started from the
previous node's vector), settles most verdicts; the eigenvalues are
computed only at the nodes where it does not, in decreasing order of the
bound. The step count asked for takes the largest bound within the limit
(with a margin), so that the bound alone accepts it.
"""

from __future__ import annotations

import math
import threading

import numba as nb
import numpy as np

__all__ = ["rk4_propagate", "rk4_segments", "RK4_STABILITY", "RK4StepError", "fast_steps"]


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


def _force_jacobians(hb, x, xd, tau, p, scratch=False):
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


@nb.njit(cache=True)
def _nonzero_pattern(Minv):
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


@nb.njit(cache=True)
def _node_block(count, cols, Minv, K, C, dfdx, dfdxd, j, out):
    """``out = [-Minv (K + dfdx[j]), -Minv (C + dfdxd[j])]``, shape (n, 2n).

    Each entry is the sum over ``b`` in ascending order; the terms with
    ``Minv[a, b] = 0`` (most of them: mass matrices are mostly diagonal or
    banded; ``count``, ``cols`` from :func:`_nonzero_pattern`) would add
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


@nb.njit(cache=True)
def _lower_blocks(Minv, K, C, dfdx, dfdxd):
    """``B[j] = [-Minv (K + dfdx[j]), -Minv (C + dfdxd[j])]`` (see :func:`_node_block`).

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
    count, cols = _nonzero_pattern(Minv)
    B = np.empty((N, n, 2 * n))
    for j in range(N):
        _node_block(count, cols, Minv, K, C, dfdx, dfdxd, j, B[j])
    return B


def _full_state_matrices(B):
    """``A = [[0, I], B]`` from its lower block rows ``B`` (N, n, 2n): shape (N, 2n, 2n)."""
    N, n = B.shape[0], B.shape[1]
    A = np.zeros((N, 2 * n, 2 * n))
    A[:, :n, n:] = np.eye(n)
    A[:, n:, :] = B
    return A


@nb.njit(cache=True)
def _matmul_into(A, B, out):
    d = A.shape[0]
    for i in range(d):
        for j in range(d):
            s = 0.0
            for k in range(d):
                s += A[i, k] * B[k, j]
            out[i, j] = s


@nb.njit(cache=True)
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


@nb.njit(cache=True)
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


@nb.njit(cache=True)
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


@nb.njit(cache=True)
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


@nb.njit(cache=True)
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


@nb.njit(cache=True)
def _row_bounds(B):
    """:func:`_row_bound` of each ``B[j]``: shape (K,)."""
    out = np.empty(B.shape[0])
    for j in range(B.shape[0]):
        out[j] = _row_bound(B[j])
    return out


@nb.njit(cache=True)
def _row_bound(Bj):
    """Upper bound of the spectral radius of ``A = [[0, I], [B1, B2]]`` from ``Bj = [B1, B2]`` (n, 2n).

    ``A`` is similar to ``[[0, s I], [B1 / s, B2]]`` for any ``s > 0``, whose
    row-sum norm bounds the spectral radius by ``max(s, max_a(r1_a / s + r2_a))``
    with ``r1_a``, ``r2_a`` the absolute row sums of ``B1``, ``B2``. With
    ``s = (r2 + sqrt(r2^2 + 4 r1)) / 2`` for the largest row sums ``r1``,
    ``r2`` both terms are at most ``s``: for a mass-spring row this is its
    natural frequency plus half its damping rate, close to the eigenvalue
    itself, where the plain norm of ``A`` would give the stiffness. NaN if an
    entry is not a number.
    """
    n = Bj.shape[0]
    r1 = 0.0
    r2 = 0.0
    for a in range(n):
        s1 = 0.0
        s2 = 0.0
        for c in range(n):
            s1 += abs(Bj[a, c])
            s2 += abs(Bj[a, n + c])
        if s1 != s1 or s2 != s2:
            return np.nan
        r1 = max(r1, s1)
        r2 = max(r2, s2)
    # the factor covers the rounding of the sums and of the root: the bound stays an upper bound
    return 0.5 * (r2 + np.sqrt(r2 * r2 + 4.0 * r1)) * (1.0 + 1e-12)


@nb.njit(cache=True)
def _variational_rk4(Minv, K, C, dfdx, dfdxd, starts, steps, h, jumps):
    """Classical RK4 for ``Phi' = A(t) Phi``, ``Phi(0) = I``, with ``A`` built node by node.

    ``A = [[0, I], [-Minv (K + dfdx[j]), -Minv (C + dfdxd[j])]]`` at node
    ``j`` (:func:`_node_block`), each node's lower block row built once, as
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
    count, cols = _nonzero_pattern(Minv)
    Phi = np.eye(d)
    k1, k2, k3, k4, tmp = np.empty((d, d)), np.empty((d, d)), np.empty((d, d)), np.empty((d, d)), np.empty((d, d))
    Ba, Bm, Bb = np.empty((n, d)), np.empty((n, d)), np.empty((n, d))
    for seg in range(steps.shape[0]):
        if steps[seg] > 0:
            j0 = starts[seg]
            _node_block(count, cols, Minv, K, C, dfdx, dfdxd, j0 % N, Ba)
            for step in range(steps[seg]):
                jm = j0 + 2 * step + 1
                _node_block(count, cols, Minv, K, C, dfdx, dfdxd, jm % N, Bm)
                _node_block(count, cols, Minv, K, C, dfdx, dfdxd, (jm + 1) % N, Bb)
                _rk4_block_step(Ba, Bm, Bb, Phi, h[seg], k1, k2, k3, k4, tmp)
                Ba, Bb = Bb, Ba
        if seg < jumps.shape[0]:
            _matmul_into(jumps[seg], Phi, tmp)
            for i in range(d):
                for j in range(d):
                    Phi[i, j] = tmp[i, j]
    return Phi


#: largest h*|lambda| for which classical RK4 is stable (2 sqrt 2 on the imaginary axis, 2.785 on the real one)
RK4_STABILITY = 2.78

#: margin of a step count chosen for the stiffest mode: the nodes of another step count sample the
#: orbit elsewhere, so their largest bound differs a little from the one measured
STEP_SAFETY = 1.05

#: eigenvalue problems solved first, in decreasing order of the nodes' bounds (:func:`_step_verdict`);
#: each further round solves twice as many
_EIG_CHUNK = 64
#: most eigenvalue work of one check, in units of (2n)^3 (about 0.1 s): 4096 nodes of a 4-dof model
_EIG_BUDGET = 2 ** 21


class RK4StepError(ArithmeticError):
    """A step beyond RK4's stability limit for the stiffest eigenvalue of ``A`` along the orbit.

    Attributes
    ----------
    rate : float
        The largest bound of ``|eigenvalue|`` of ``A`` over all nodes of the
        orbit (:func:`_perron_bound`), which ``needed`` takes within the limit.
    steps : int
        The steps per period that were refused.
    needed : int
        Steps per period that take that mode within the limit, with the
        margin :data:`STEP_SAFETY`, rounded up to a fast FFT length.
    phase : float
        ``T`` times the mean over the nodes of that bound: about
        ``int |eigenvalue| dt`` of the stiffest mode over the period (what an
        adaptive explicit integration pays for).
    """

    def __init__(self, message: str, rate: float, steps: int, needed: int, phase: float = math.nan):
        super().__init__(message)
        self.rate = float(rate)
        self.steps = int(steps)
        self.needed = int(needed)
        self.phase = float(phase)


#: most shifted power iterations of :func:`_perron_bound` at one node
_PERRON_ITERATIONS = 32
#: they stop where the upper and lower Collatz-Wielandt bounds agree to this, or where the upper one
#: has not improved by a tenth of it in four iterations
_PERRON_GAP = 1e-3


@nb.njit(cache=True)
def _perron_bound(Bj, x, y, warm, enough):
    """Upper bound of the spectral radius of ``A = [[0, I], [B1, B2]]`` from ``Bj = [B1, B2]`` (n, 2n).

    ``rho(A) <= rho(|A|)``, and for any positive vector ``x``
    ``min_i (|A| x)_i / x_i <= rho(|A|) <= max_i (|A| x)_i / x_i``
    (Collatz-Wielandt). With ``x = (1, s)`` the upper one is
    :func:`_row_bound`; shifted power iterations (of ``|A| + sigma I``,
    ``sigma`` the bound so far: the shift keeps them converging where
    ``|A|`` has eigenvalues ``+-rho``, as for an undamped oscillator) move
    ``x`` towards the Perron vector of ``|A|``, and the smallest upper bound
    met is returned. For a stiffness with the sign pattern of a mass-spring
    chain, or a rank-one contact stiffness ``k n n^T``, ``rho(|A|)`` is
    close to the spectral radius, which the row sums overestimate (by up to
    10% for a radial contact, 40% for a light mass on a stiff spring).

    Parameters
    ----------
    Bj : ndarray, shape (n, 2n)
    x : ndarray, shape (2n,)
        The positive start vector if ``warm`` (that of the previous node:
        the orbit's neighbouring nodes have nearly the same one), else
        overwritten; on return the last iterate (positive).
    y : ndarray, shape (2n,)
        Work array.
    warm : bool
    enough : float
        The iterations stop once the bound is at most this (the bound the
        verdict needs; 0 for the tightest).

    Returns
    -------
    float
        NaN if an entry is not a number.
    """
    n = Bj.shape[0]
    bound = _row_bound(Bj)
    if bound != bound:
        return bound
    if not warm:
        s = bound / (1.0 + 1e-12)
        for i in range(n):
            x[i] = 1.0
            x[n + i] = s if s > 0.0 else 1.0
    if bound <= enough:
        return bound
    ref = bound  # the bound four iterations back
    for it in range(_PERRON_ITERATIONS):
        # y = |A| x: the upper rows are a copy, the lower ones |B1| x1 + |B2| x2
        for i in range(n):
            y[i] = x[n + i]
        for a in range(n):
            acc = 0.0
            for c in range(2 * n):
                acc += abs(Bj[a, c]) * x[c]
            y[n + a] = acc
        hi = 0.0
        lo = np.inf
        for i in range(2 * n):
            r = y[i] / x[i]
            hi = max(hi, r)
            lo = min(lo, r)
        hi *= 1.0 + 1e-12  # covers the rounding of the sums: the bound stays one
        bound = min(bound, hi)
        if bound <= enough or hi - lo <= _PERRON_GAP * hi:
            break
        if it % 4 == 3:
            if ref - bound <= 0.1 * _PERRON_GAP * bound:
                break
            ref = bound
        big = 0.0
        for i in range(2 * n):
            y[i] += bound * x[i]
            big = max(big, y[i])
        if not big > 0.0:
            break
        tiny = 1e-300 / big
        for i in range(2 * n):
            x[i] = max(y[i] / big, tiny)  # stays positive
    return bound


@nb.njit(cache=True)
def _node_bounds(Minv, K, C, dfdx, dfdxd, enough):
    """:func:`_perron_bound` of ``A`` at every node, shape (N,).

    The block rows are built one at a time (:func:`_node_block`) and not
    stored; each node starts from the vector of the one before. A bound at
    most ``enough`` is not tightened further: where the step is within the
    limit everywhere that costs the row sums alone; where it is not, the
    nodes beyond ``enough``, which decide the largest bound, are tightened.
    """
    N = dfdx.shape[0]
    n = Minv.shape[0]
    count, cols = _nonzero_pattern(Minv)
    Bj = np.empty((n, 2 * n))
    x = np.empty(2 * n)
    y = np.empty(2 * n)
    out = np.empty(N)
    for j in range(N):
        _node_block(count, cols, Minv, K, C, dfdx, dfdxd, j, Bj)
        out[j] = _perron_bound(Bj, x, y, j > 0, enough)
    return out


@nb.njit(cache=True)
def _blocks_at(Minv, K, C, dfdx, dfdxd, nodes):
    """The lower block rows of ``A`` at the given nodes: shape (len(nodes), n, 2n)."""
    n = Minv.shape[0]
    count, cols = _nonzero_pattern(Minv)
    B = np.empty((nodes.shape[0], n, 2 * n))
    for q in range(nodes.shape[0]):
        _node_block(count, cols, Minv, K, C, dfdx, dfdxd, nodes[q], B[q])
    return B


def fast_steps(steps: int) -> int:
    """The smallest step count ``>= steps`` with only the factors 2, 3 and 5.

    The ``2 steps`` orbit samples are synthesised by an inverse FFT, fastest
    for such lengths.
    """
    from scipy.fft import next_fast_len

    return int(next_fast_len(int(steps), real=True))


def _step_verdict(Minv, K, C, dfdx, dfdxd, h):
    """Whether the step ``h`` is within RK4's stability limit for ``A`` at every node.

    The bound of :func:`_perron_bound` is computed at every node; where it
    allows ``h`` everywhere, the step is accepted. Otherwise the
    eigenvalues decide, computed at the nodes whose bound exceeds the limit
    in decreasing order of their bounds, until one is beyond the limit
    (refused) or all are within it (accepted); past
    :data:`_EIG_BUDGET` (in units of ``(2n)^3``) the rest are taken as beyond.

    Returns
    -------
    ok : bool
    rate : float
        The largest ``|eigenvalue|`` found (0 if none was computed); NaN if
        a Jacobian entry is not a number.
    bounds : ndarray, shape (N,)
        The bound at every node (tightened only where above the limit, so
        that their largest is tight where the step is refused).
    """
    bounds = _node_bounds(Minv, K, C, dfdx, dfdxd, RK4_STABILITY / h)
    top = float(bounds.max()) if bounds.size else 0.0
    if not np.isfinite(top):
        return False, math.nan, bounds
    if top * h <= RK4_STABILITY:
        return True, 0.0, bounds
    cand = np.flatnonzero(bounds * h > RK4_STABILITY)
    cand = cand[np.argsort(-bounds[cand], kind="stable")].astype(np.int64)
    most = max(_EIG_CHUNK, _EIG_BUDGET // (2 * Minv.shape[0]) ** 3)
    rate, k, chunk = 0.0, 0, _EIG_CHUNK
    while k < cand.size:
        if k >= most:
            return False, rate, bounds
        nodes = cand[k:k + min(chunk, most - k)]
        B = _blocks_at(Minv, K, C, dfdx, dfdxd, nodes)
        rate = max(rate, float(np.abs(np.linalg.eigvals(_full_state_matrices(B))).max()))
        if rate * h > RK4_STABILITY:
            return False, rate, bounds
        k += nodes.size
        chunk *= 2  # few rounds where many nodes are close to the limit
    return True, rate, bounds


def _check_rk4_step(Minv, K, C, dfdx, dfdxd, h, T, lam, steps):
    """Refuse a step beyond RK4's stability limit for the stiffest eigenvalue of ``A`` along the orbit.

    Beyond it the fixed-step monodromy blows up or, worse, returns finite
    garbage. The verdict is that of :func:`_step_verdict`, over all the nodes.

    Parameters
    ----------
    Minv, K, C : ndarray, shape (n, n)
    dfdx, dfdxd : ndarray, shape (N, n, n)
        The force Jacobians at all the nodes of the integration.
    h : float
        The largest step.
    T, lam : float
        The period and the parameter (for the message).
    steps : int
        The steps per period asked for (the step count the advice scales).

    Raises
    ------
    RK4StepError
        The step is too large. Its ``needed`` takes the largest bound
        ``rho`` over all the nodes within the limit: no step is longer than
        ``T / steps`` (on the piecewise path too), so ``needed`` is
        ``rho T / RK4_STABILITY`` with the margin :data:`STEP_SAFETY`,
        rounded up by :func:`fast_steps`. With ``needed`` steps or more the
        bound alone accepts the step (another sampling of the same orbit
        moves its maximum by far less than the margin), so the advice holds.
    ArithmeticError
        A Jacobian entry along the orbit is not a number.
    """
    ok, rate, bounds = _step_verdict(Minv, K, C, dfdx, dfdxd, h)
    if ok:
        return
    if not np.isfinite(rate):
        raise ArithmeticError(f"monodromy at lambda = {lam:.10g}: the force Jacobian along the orbit is not finite")
    top = float(bounds.max())
    needed = fast_steps(max(int(np.ceil(top * T / RK4_STABILITY * STEP_SAFETY)), steps + 1))
    if rate * h > RK4_STABILITY:
        found = f"|eigenvalue| {rate:.4g}, h |eigenvalue| = {rate * h:.3g} > {RK4_STABILITY}"
    else:  # the eigenvalue budget ran out first
        found = f"h |eigenvalue| up to {top * h:.3g} > {RK4_STABILITY} by its bound"
    raise RK4StepError(
        f"monodromy at lambda = {lam:.10g}: the RK4 step T/{steps} is too large for the stiffest mode along the "
        f"orbit ({found}; |eigenvalue| <= {top:.4g} over the period {T:.6g}); use steps_per_period >= {needed}",
        top, steps, needed, float(bounds.mean()) * T)
