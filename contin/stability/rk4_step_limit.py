"""RK4's stability limit along the orbit: a step too large for the stiffest mode is refused, with the steps it needs.

A step beyond RK4's stability limit for the stiffest eigenvalue of ``A``
along the orbit is refused (:func:`check_rk4_step`, raising
:class:`RK4StepError` with the step count that eigenvalue needs,
rounded up by :func:`fast_steps`).

The check looks at ``A`` on every node of the integration: a strided subset
would sample the orbit differently for each step count, so that the count
asked for after a refusal could be refused again. At each node an upper
bound of the spectral radius, the Collatz-Wielandt bound of ``|A|``
(:func:`_perron_bound`: a few power iterations, started from the previous
node's vector), settles most verdicts; the eigenvalues are computed only at
the nodes where it does not, in decreasing order of the bound. The step
count asked for takes the largest bound within the limit (with a margin),
so that the bound alone accepts it.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.fft import next_fast_len

from contin.stability.rk4 import full_state_matrices, node_block, nonzero_pattern
from contin.util.jit import njit

__all__ = ["RK4_STABILITY", "RK4StepError", "check_rk4_step", "fast_steps"]


#: largest h*|lambda| for which classical RK4 is stable (2 sqrt 2 on the imaginary axis, 2.785 on the real one)
RK4_STABILITY = 2.78

#: margin of a step count chosen for the stiffest mode: the nodes of another step count sample the
#: orbit elsewhere, so their largest bound differs a little from the one measured
STEP_SAFETY = 1.05

#: eigenvalue problems solved first, in decreasing order of the nodes' bounds (:func:`_step_verdict`);
#: each further round solves twice as many
_EIG_CHUNK = 64
#: most eigenvalue work of one check, in units of (2n)^3: 4096 nodes of a 4-dof model (its time:
#: docs/validation/stability-notes.md)
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


@njit(cache=True)
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
    close to the spectral radius, which the row sums overestimate (by how
    much: docs/validation/stability-notes.md).

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


@njit(cache=True)
def _row_bounds(B):
    """:func:`_row_bound` of each ``B[j]``: shape (K,)."""
    out = np.empty(B.shape[0])
    for j in range(B.shape[0]):
        out[j] = _row_bound(B[j])
    return out


@njit(cache=True)
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



@njit(cache=True)
def _node_bounds(Minv, K, C, dfdx, dfdxd, enough):
    """:func:`_perron_bound` of ``A`` at every node, shape (N,).

    The block rows are built one at a time (:func:`node_block`) and not
    stored; each node starts from the vector of the one before. A bound at
    most ``enough`` is not tightened further: where the step is within the
    limit everywhere that costs the row sums alone; where it is not, the
    nodes beyond ``enough``, which decide the largest bound, are tightened.
    """
    N = dfdx.shape[0]
    n = Minv.shape[0]
    count, cols = nonzero_pattern(Minv)
    Bj = np.empty((n, 2 * n))
    x = np.empty(2 * n)
    y = np.empty(2 * n)
    out = np.empty(N)
    for j in range(N):
        node_block(count, cols, Minv, K, C, dfdx, dfdxd, j, Bj)
        out[j] = _perron_bound(Bj, x, y, j > 0, enough)
    return out


@njit(cache=True)
def _blocks_at(Minv, K, C, dfdx, dfdxd, nodes):
    """The lower block rows of ``A`` at the given nodes: shape (len(nodes), n, 2n)."""
    n = Minv.shape[0]
    count, cols = nonzero_pattern(Minv)
    B = np.empty((nodes.shape[0], n, 2 * n))
    for q in range(nodes.shape[0]):
        node_block(count, cols, Minv, K, C, dfdx, dfdxd, nodes[q], B[q])
    return B


def fast_steps(steps: int) -> int:
    """The smallest step count ``>= steps`` with only the factors 2, 3 and 5.

    The ``2 steps`` orbit samples are synthesised by an inverse FFT, fastest
    for such lengths.
    """
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
        rate = max(rate, float(np.abs(np.linalg.eigvals(full_state_matrices(B))).max()))
        if rate * h > RK4_STABILITY:
            return False, rate, bounds
        k += nodes.size
        chunk *= 2  # few rounds where many nodes are close to the limit
    return True, rate, bounds


def check_rk4_step(Minv, K, C, dfdx, dfdxd, h, T, lam, steps):
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
