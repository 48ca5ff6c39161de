"""Monodromy matrix of a harmonic-balance solution by time integration.

The first-order variational equations of ``M x'' + C x' + K x + f(x, x', tau) = f_ext(tau)``
about the periodic solution ``x*(t)`` are

    z' = A(t) z,    A = [[0, I], [-M^-1 (K + df/dx), -M^-1 (C + df/dx')]],    z = (dx, dx'),

and the monodromy matrix is ``Phi(T)`` with ``Phi(0) = I``, ``T = 2 pi nu / w``;
its eigenvalues are the Floquet multipliers.

Two paths are provided:

- :func:`monodromy_rk4` (production): the force elements are evaluated once,
  in one vectorised call per element, on ``2S`` points of the HB orbit
  (``S`` steps per period, the RK4 stages need the half steps), and
  ``Phi`` is propagated by a numba-compiled fixed-step classical Runge-Kutta
  scheme. For smooth forces the error is ``O(h^4)``, ``h = T/S``; a step
  beyond RK4's stability limit for the stiffest eigenvalue of ``A`` along the
  orbit is refused (``ArithmeticError`` naming the step count needed).

  The cost is in the products ``A Phi``. The kernel builds the lower block
  row ``B = [-M^-1 (K + df/dx), -M^-1 (C + df/dx')]`` of ``A`` node by node
  from the element Jacobians (``M^-1`` once per call, its zero entries
  skipped) and multiplies by ``B`` only, the upper block row ``[0, I]``
  being a copy: half the work of the full product, with every entry summed
  in the same order, so the result is the same to the last bit. The
  stability check looks at ``A`` on 256 nodes as before, but computes
  their eigenvalues only when a cheap upper bound of the spectral radius
  (:func:`_row_bound`) does not already settle the verdict.
- :func:`monodromy_reference`: ``scipy.integrate.solve_ivp`` (DOP853, tight
  tolerances) of the *full nonlinear* state together with the variational
  equations, started from the HB state at ``t = 0``. It measures the HB
  truncation error too (``orbit_error``: how far the true flow is from
  returning to the start after one period). :func:`monodromy_orbit_ivp`
  integrates the variational equations along the HB orbit itself with the
  same adaptive scheme, isolating the error of the fixed-step scheme.

Non-smooth forces: switches and saltation matrices
--------------------------------------------------
A contact law is piecewise: each force element with a switching surface
reports it through :meth:`contin.model.ForceElement.switching_functions`
(value ``h``, gradient ``n = (dh/dx, dh/dx')`` and the jump of the force
across the surface; the gap and radial-gap contacts do, ``h = r - delta`` or,
with ``clip``, ``min(r - delta, Fn/k)`` so that the end of contact where the
clipped force reaches zero is a switch too). The monodromy knows no element
type: :func:`switching_events` samples every switching function on the
orbit, refines each sign change by Brent's method on the orbit's
trigonometric series (exact at any ``t``) to ``4 eps T`` (all the sign
changes at once, each round of the iteration one call per element), and
builds the saltation matrix there,

    S = I + (f+ - f-) n^T / (n^T f-),     f+ - f- = (0, -M^-1 [f_nl]),

``f-``, ``f+`` the first-order vector fields before and after the switch and
``[f_nl]`` the jump of the contact force (Aizerman & Gantmakher, PMM 22
(1958); Leine & Nijmeijer, *Dynamics and Bifurcations of Non-Smooth
Mechanical Systems*, Springer 2004, ch. 7). For the paper's contact law,
``Fn = kbn (r - delta) + cbn r'`` switched on and off at ``r = delta``, the
force jumps by ``cbn r' e`` and ``S - I`` has the entries ``cbn/beta`` (the
jump divided by ``r' = n^T f-``: finite even at grazing incidence); with the
clipped law contact starts with that jump and ends continuously (``S = I``).
The variational equations are then integrated piecewise, segment by segment
between the switches (about ``S`` steps in all, their ends evaluated on the
segment's side of the surface), with ``Phi <- S Phi`` at each switch: fourth
order again where fixed steps straight across a switch are first order
(``switches='ignore'``, the former behaviour; ``'piecewise'`` drops the
saltation matrices, for comparison). An orbit without switches takes the
fixed-step path with the same result as before. :func:`monodromy_orbit_ivp`
uses the same switches; :func:`monodromy_reference` finds its own on the
nonlinear trajectory (terminal events of ``solve_ivp``, each contact law
frozen between them) and applies the same saltation matrices.

Checks (``tests/stability/test_saltation.py``): against central finite
differences of the flow map of the independent simulator
(:func:`contin.simulation.simulate`), the reference monodromy of a
clearance oscillator with contact damping agrees to 1e-8 with saltation and
is off by 0.5 without, clipped and unclipped; on the rotor with ``c2 = 5``
(impacts) 9e-9 against 1.6e-5 without (the bearing damping wipes the kick
out within a period). Along the HB orbit the agreement is limited by the HB
truncation, algebraic in ``H`` for impacting orbits (2e-2 in ``Phi`` for the
rotor at ``H = 40``). Limits: a contact shorter than ``T/(2S)`` is not seen;
a switch where the force jumps while the orbit does not cross transversally
(grazing with a jump, sliding) raises ``ArithmeticError``; switching inside
expression forces (``abs``, ``min``, ...) is not located. Hill's method uses
the sampled Jacobian, which misses the jump (its derivative is a delta at
the surface): on impacting orbits its selection of exponents fails (flagged
ambiguous), though its spectrum holds the critical multipliers
(``tests/models/test_rotor_floquet.py``).
"""

from __future__ import annotations

import dataclasses
import threading

import numba as nb
import numpy as np
from scipy.integrate import solve_ivp

from contin import aft
from contin.harmonics import coefficient_blocks

__all__ = [
    "Monodromy",
    "SwitchEvent",
    "switching_events",
    "state_matrices",
    "rk4_propagate",
    "monodromy_rk4",
    "monodromy_orbit_ivp",
    "monodromy_reference",
    "orbit_state",
]


@dataclasses.dataclass(frozen=True, eq=False)
class Monodromy:
    """A monodromy matrix and how it was obtained.

    Attributes
    ----------
    matrix : ndarray, shape (2n, 2n)
        ``Phi(T)`` for the state ``z = (x, x')``.
    period : float
    method : str
        ``"rk4"``, ``"orbit-dop853"`` or ``"dop853"``.
    steps : int
        RK4 steps per period (0 for the adaptive paths; then the number of
        right-hand-side evaluations is in ``evaluations``).
    evaluations : int
    orbit_error : float
        For ``"dop853"`` only: ``max |z(T) - z(0)|`` of the nonlinear flow
        started on the HB state (NaN otherwise).
    switches : tuple of SwitchEvent
        The switching events located along the orbit, in time order (empty
        for a smooth orbit, or when location was not asked for).
    saltation : bool
        Whether saltation matrices were applied at the switches.
    """

    matrix: np.ndarray
    period: float
    method: str
    steps: int = 0
    evaluations: int = 0
    orbit_error: float = float("nan")
    switches: tuple = ()
    saltation: bool = False

    @property
    def multipliers(self) -> np.ndarray:
        """Eigenvalues of :attr:`matrix`, shape (2n,) complex."""
        return np.linalg.eigvals(self.matrix)


def _frequency(hb, lam: float) -> float:
    Omega = float(hb.params_at(lam)[hb.kw]) / hb.nu
    if not Omega > 0:
        raise ValueError(f"the monodromy needs a positive excitation frequency, got w/nu = {Omega}")
    return Omega


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


def state_matrices(hb, u: np.ndarray, lam: float, samples: int):
    """``A(t_j)`` on ``t_j = j T / samples`` along the HB orbit.

    The force elements are called once each, on all samples.

    Parameters
    ----------
    hb : HarmonicBalance
    u : ndarray, shape (hb.size,)
    lam : float
    samples : int
        ``>= 2H+1``.

    Returns
    -------
    A : ndarray, shape (samples, 2n, 2n)
    period : float
    """
    if samples < 2 * hb.H + 1:
        raise ValueError(f"need at least 2H+1 = {2 * hb.H + 1} orbit samples, got {samples}")
    p = hb.params_at(lam)
    x, xd, tau, T = _orbit_samples(hb, u, lam, samples)
    return _full_state_matrices(_lower_blocks_at(hb, p, x, xd, tau)), T


def _orbit_samples(hb, u, lam, samples):
    """The HB orbit on ``samples`` equidistant points of the period.

    Returns ``(x, xd, tau, T)``: states (samples, n) each, the excitation
    phases ``nu theta_j`` (samples,) and the period.
    """
    Omega = _frequency(hb, lam)
    U = np.ascontiguousarray(coefficient_blocks(u, hb.n))
    x, xp = aft.synthesize(U, samples)
    xd = Omega * xp
    theta = 2.0 * np.pi * np.arange(samples) / samples
    return x, xd, hb.nu * theta, 2.0 * np.pi / Omega


def _lower_blocks_at(hb, p, x, xd, tau):
    """The lower block row ``[-M^-1 (K + df/dx), -M^-1 (C + df/dx')]`` of ``A`` at the states ``(x, xd)``.

    Parameters
    ----------
    x, xd : ndarray, shape (N, n)
    tau : ndarray, shape (N,)
        Excitation phases.

    Returns
    -------
    ndarray, shape (N, n, 2n)
        The upper block row of ``A`` is ``[0, I]`` everywhere and is not stored.
    """
    _, dfdx, dfdxd = _force_jacobians(hb, x, xd, tau, p, scratch=True)
    return _lower_blocks(*_linear_terms(hb, p), dfdx, dfdxd)


def _linear_terms(hb, p):
    """``(M^-1, K, C)`` as contiguous float arrays."""
    M, C, K = hb.model.linear(p)
    return np.linalg.inv(M), np.ascontiguousarray(K, dtype=float), np.ascontiguousarray(C, dtype=float)


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


def _max_row_bound(B):
    """Largest :func:`_row_bound` over ``B`` (K, n, 2n); NaN if any is NaN."""
    return _row_bounds(B).max()


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


def _integrate(hb, p, x, xd, tau, starts, steps, h, jumps, T, lam):
    """``Phi(T)`` of the variational equations on the orbit nodes ``(x, xd, tau)`` (see :func:`_variational_rk4`).

    The step is first checked against RK4's stability limit (:func:`_check_rk4_step`).
    """
    _, dfdx, dfdxd = _force_jacobians(hb, x, xd, tau, p, scratch=True)
    Minv, K, C = _linear_terms(hb, p)
    stride = max(1, dfdx.shape[0] // 256)
    _check_rk4_step(_lower_blocks(Minv, K, C, np.ascontiguousarray(dfdx[::stride]),
                                  np.ascontiguousarray(dfdxd[::stride])), float(np.max(h)), T, lam)
    return _variational_rk4(Minv, K, C, dfdx, dfdxd, starts, steps, h, jumps)


def monodromy_rk4(hb, u: np.ndarray, lam: float, steps: int = 512, switches: str = "saltation") -> Monodromy:
    """Monodromy matrix by fixed-step RK4 on the sampled HB orbit.

    Parameters
    ----------
    hb : HarmonicBalance
    u : ndarray, shape (hb.size,)
    lam : float
    steps : int
        RK4 steps per period ``S`` (at least ``H+1``, so that the ``2S``
        orbit samples resolve every harmonic).
    switches : {'saltation', 'piecewise', 'ignore'}
        ``'saltation'`` (default): the switches of the force elements'
        switching functions (:meth:`contin.model.ForceElement.switching_functions`)
        are located on the orbit, the variational equations are integrated
        piecewise between them (about ``S`` steps in all, distributed by
        segment length) and the saltation matrix is applied at each switch.
        ``'piecewise'``: the same without saltation matrices (wrong where the
        force law jumps; for comparison). ``'ignore'``: fixed steps straight
        across the switches (first order in ``h`` where the Jacobian jumps,
        and no saltation). An orbit without switches takes the fixed-step
        path in every mode, with the same result.

    Returns
    -------
    Monodromy

    Raises
    ------
    ArithmeticError
        A step beyond RK4's stability limit for the stiffest eigenvalue of
        ``A`` along the orbit (the message gives the step count needed), or a
        switch that cannot be resolved (see :func:`switching_events`).
    """
    steps = int(steps)
    if steps < hb.H + 1:
        raise ValueError(f"steps_per_period must be >= H+1 = {hb.H + 1}, got {steps}")
    if switches not in _SWITCH_MODES:
        raise ValueError(f"switches must be one of {list(_SWITCH_MODES)}, got {switches!r}")
    p = hb.params_at(lam)
    x, xd, tau, T = _orbit_samples(hb, u, lam, 2 * steps)
    if switches != "ignore":
        sw = _switching_elements(hb.model)
        events = _switching_events(hb, u, lam, 2 * steps, switches == "saltation", sw, (x, xd)) if sw else []
        if events:
            return _piecewise_rk4(hb, u, lam, steps, events, switches == "saltation")
    Phi = _integrate(hb, p, x, xd, tau, np.zeros(1, np.int64), np.array([steps], np.int64), np.array([T / steps]),
                     np.zeros((0, 2 * hb.n, 2 * hb.n)), T, lam)
    return Monodromy(Phi, T, "rk4", steps=steps, evaluations=2 * steps)


#: largest h*|lambda| for which classical RK4 is stable (2 sqrt 2 on the imaginary axis, 2.785 on the real one)
RK4_STABILITY = 2.78


def _check_rk4_step(B, h, T, lam):
    """Refuse a step beyond RK4's stability limit for the stiffest eigenvalue of ``A`` along the orbit.

    Beyond it the fixed-step monodromy blows up or, worse, returns finite
    garbage. The eigenvalues of ``A`` are taken at the given nodes
    (:func:`_integrate` passes at most 256, evenly strided), and only when
    the upper bound of :func:`_row_bound` there does not already settle it:
    the bound changes no verdict, only the cost.

    Parameters
    ----------
    B : ndarray, shape (K, n, 2n)
        Lower block rows of ``A = [[0, I], B]``.
    h, T, lam : float
        The (largest) step, the period and the parameter (for the message).
    """
    if _max_row_bound(B) * h <= RK4_STABILITY:
        return
    rate = float(np.abs(np.linalg.eigvals(_full_state_matrices(B))).max())
    if rate * h > RK4_STABILITY:
        need = int(np.ceil(rate * T / RK4_STABILITY))
        raise ArithmeticError(
            f"monodromy at lambda = {lam:.10g}: the RK4 step T/{round(T / h)} is too large for the stiffest "
            f"mode along the orbit (|eigenvalue| {rate:.4g}, h |eigenvalue| = {rate * h:.3g} > {RK4_STABILITY}); "
            f"use steps_per_period >= {need}")


# ---------------------------------------------------------------- switching events and saltation matrices
_SWITCH_MODES = ("saltation", "piecewise", "ignore")
_EPS = np.finfo(float).eps


@dataclasses.dataclass(frozen=True, eq=False)
class SwitchEvent:
    """A crossing of a switching surface ``h(x, x') = 0`` by the periodic orbit.

    Attributes
    ----------
    time : float
        ``t_c`` in ``[0, T)``.
    element : int
        Index of the force element in ``model.forces``.
    label : str
        The element's label (or kind).
    function : int
        Index of the switching function within the element.
    direction : int
        ``+1`` where the element's law switches on (``h`` turns positive),
        ``-1`` where it switches off.
    state : ndarray, shape (2n,)
        ``z(t_c) = (x, x')``.
    normal : ndarray, shape (2n,)
        ``n = (dh/dx, dh/dx')`` at ``z(t_c)``.
    field_before, field_after : ndarray, shape (2n,)
        The first-order vector field ``f^-``, ``f^+`` at ``(z(t_c), t_c)``
        with the laws before and after the switch.
    transversality : float
        ``n^T f^-``, the rate ``dh/dt`` at which the orbit meets the surface.
    saltation : ndarray, shape (2n, 2n)
        ``S = I + (f^+ - f^-) n^T / (n^T f^-)``; the identity where the
        force is continuous across the surface (or when saltation was not
        asked for).
    """

    time: float
    element: int
    label: str
    function: int
    direction: int
    state: np.ndarray
    normal: np.ndarray
    field_before: np.ndarray
    field_after: np.ndarray
    transversality: float
    saltation: np.ndarray


def _switching_elements(model):
    """``[(index, element, number of functions)]`` of the force elements with switching functions."""
    out = []
    n = model.n_dof
    p = model.parameter_vector()
    for e, el in enumerate(model.forces):
        sw = el.switching_functions(np.zeros((0, n)), np.zeros((0, n)), np.zeros(0), p)
        if sw is not None:
            out.append((e, el, int(sw.value.shape[1])))
    return out


#: states per call of an element's switching functions in the orbit-wide evaluations
_SWITCH_BLOCK = 4096


def _switch_values(el, x, xd, tau, p):
    """``el.switching_functions(x, xd, tau, p).value`` (N, m), evaluated in blocks of states.

    The elements return seven arrays per call, up to (N, m, n, n) each; in
    blocks they stay small enough for the allocator to recycle, where at full
    length their pages would be faulted in afresh on every call.
    """
    N = x.shape[0]
    if N <= _SWITCH_BLOCK:
        return el.switching_functions(x, xd, tau, p).value
    parts = [el.switching_functions(x[a:a + _SWITCH_BLOCK], xd[a:a + _SWITCH_BLOCK], tau[a:a + _SWITCH_BLOCK], p).value
             for a in range(0, N, _SWITCH_BLOCK)]
    return np.concatenate(parts, axis=0)


def _mode_columns(model) -> dict:
    """Column of each ``(element index, function)`` in :func:`_modes`."""
    cols, k = {}, 0
    for e, _, m in _switching_elements(model):
        for i in range(m):
            cols[(e, i)] = k
            k += 1
    return cols


def _excitation_at(hb, p, tau):
    fe = np.zeros((len(tau), hb.n))
    for el in hb.model.excitations:
        el.evaluate(tau, p, fe)
    return fe


def _saltation(hb, p, el, e, i, direction, t, z, force_before, saltation=True) -> SwitchEvent:
    """The :class:`SwitchEvent` of function ``i`` of element ``el`` at ``(t, z)``.

    ``force_before`` (shape (n,)) is the total internal force with the laws
    in force just before the switch. ``f^+ - f^- = (0, -M^-1 direction * jump)``.
    """
    n = hb.n
    w = float(p[hb.kw])
    x, xd = z[:n], z[n:]
    sw = el.switching_functions(x[None], xd[None], np.array([w * t]), p)
    normal = np.concatenate([sw.grad_x[0, i], sw.grad_xd[0, i]])
    M, C, K = hb.model.linear(p)
    Minv = np.linalg.inv(M)
    fe = _excitation_at(hb, p, np.array([w * t]))[0]
    acc = Minv @ (fe - C @ xd - K @ x - force_before)
    f_minus = np.concatenate([xd, acc])
    f_plus = np.concatenate([xd, acc - Minv @ (direction * sw.jump[0, i])])
    nf = float(normal @ f_minus)
    nf_plus = float(normal @ f_plus)
    S = np.eye(2 * n)
    label = getattr(el, "label", "") or el.kind
    dfield = f_plus - f_minus
    continuous = np.abs(dfield).max() <= 64 * _EPS * max(np.abs(f_minus).max(), np.abs(f_plus).max(), 1e-300)
    if not continuous and not (direction * nf > 0 and direction * nf_plus > 0):
        raise ArithmeticError(
            f"switch of '{label}' (function {i}) at t = {t:.12g}: the orbit does not cross the surface "
            f"transversally (n^T f- = {nf:.3g}, n^T f+ = {nf_plus:.3g} for a switch "
            f"{'on' if direction > 0 else 'off'}) while the force jumps there; the saltation matrix is undefined "
            "(grazing, or sliding along the surface)")
    if saltation and not continuous:
        S += np.outer(dfield, normal) / nf
    return SwitchEvent(float(t), int(e), str(label), int(i), int(direction), z.copy(), normal, f_minus, f_plus, nf, S)


def switching_events(hb, u: np.ndarray, lam: float, samples: int = 4096, saltation: bool = True) -> list:
    """Locate where the HB orbit crosses the switching surfaces of its force elements.

    The switching functions ``h(x(t), x'(t))`` of every element that has
    them (:meth:`contin.model.ForceElement.switching_functions`) are sampled
    on ``samples`` equidistant points of the period; each sign change is
    refined by Brent's method on the orbit's trigonometric series (evaluated
    exactly at any ``t``) to ``|dt| <= 4 eps T``, and the saltation matrix
    ``S = I + (f^+ - f^-) n^T / (n^T f^-)`` (Leine & Nijmeijer, *Dynamics and
    Bifurcations of Non-Smooth Mechanical Systems*, Springer 2004, ch. 7;
    Aizerman & Gantmakher, PMM 22 (1958)) is built there.

    All the sign changes are refined together: the iterations of Brent's
    method (the algorithm of ``scipy.optimize.brentq``, step for step, see
    :func:`_brent_advance`) run side by side, each round evaluating the
    switching functions at all the trial times in one call per element.

    Parameters
    ----------
    hb : HarmonicBalance
    u : ndarray, shape (hb.size,)
    lam : float
    samples : int
        Detection grid. A contact that starts and ends between two samples
        (shorter than ``T / samples``) is not seen.
    saltation : bool
        Build the saltation matrices (else they are the identity).

    Returns
    -------
    list of SwitchEvent
        In time order.

    Raises
    ------
    ArithmeticError
        A switch at which the force jumps but the orbit does not cross the
        surface transversally (grazing or sliding), or whose side cannot be
        resolved.
    """
    sw_elements = _switching_elements(hb.model)
    if not sw_elements:
        return []
    return _switching_events(hb, u, lam, int(samples), saltation, sw_elements)


def _switching_events(hb, u, lam, samples, saltation, sw_elements, orbit=None):
    """:func:`switching_events` for the elements ``sw_elements`` (see :func:`_switching_elements`).

    ``orbit``: the states ``(x, xd)`` (each (samples, n)) on the detection
    grid, if already synthesised.
    """
    n = hb.n
    p = hb.params_at(lam)
    Omega = _frequency(hb, lam)
    T = 2.0 * np.pi / Omega
    w = float(p[hb.kw])
    if orbit is None:
        U = np.ascontiguousarray(coefficient_blocks(u, n))
        x, xp = aft.synthesize(U, samples)
        xd = Omega * xp
    else:
        x, xd = orbit
    t = T * np.arange(samples) / samples
    tau = w * t
    # the brackets, in the order (element, sample, function) in which they are reported at equal times
    rows, elems, funcs, dirs = [], [], [], []
    for q, (_, el, _) in enumerate(sw_elements):
        on = _switch_values(el, x, xd, tau, p) > 0.0
        after = np.roll(on, -1, axis=0)
        j, i = np.nonzero(on != after)
        rows.append(j)
        funcs.append(i)
        elems.append(np.full(j.shape, q))
        dirs.append(np.where(after[j, i], 1, -1))
    j, fun, elem, direction = (np.concatenate(v) for v in (rows, funcs, elems, dirs))
    if not j.size:
        return []
    a = t[j]
    b = np.append(t, T)[j + 1]
    values = _SwitchValues(hb, u, lam, p, sw_elements, elem, fun)
    ha, hb_ = values(a), values(b)
    tc = np.where(np.abs(ha) <= np.abs(hb_), a, b)  # a root at rounding level on a node
    bracket = (ha != 0.0) & (hb_ != 0.0) & ((ha > 0) != (hb_ > 0))
    if bracket.any():
        tc[bracket] = _brentq_all(values, a, b, ha, hb_, bracket, 4 * _EPS * T, 4 * _EPS, 200)
    tc = np.where(tc >= T, tc - T, tc)
    order = np.argsort(tc, kind="stable")
    return _switch_events_at(hb, u, lam, p, sw_elements, tc[order], elem[order], fun[order], direction[order],
                             saltation)


class _SwitchValues:
    """``h_i(z(t))`` of the bracketed functions at trial times, one element call per round.

    Bracket ``r`` is function ``fun[r]`` of element ``sw_elements[elem[r]]``;
    calling with times for the brackets ``which`` (default all) returns
    their values. Each value is computed exactly as a call at the single time.
    """

    def __init__(self, hb, u, lam, p, sw_elements, elem, fun):
        self.hb, self.u, self.lam, self.p = hb, u, lam, p
        self.w = float(p[hb.kw])
        self.elements = [el for _, el, _ in sw_elements]
        self.elem, self.fun = elem, fun

    def __call__(self, t, which=None):
        which = np.arange(len(self.elem)) if which is None else which
        n = self.hb.n
        z = orbit_state(self.hb, self.u, self.lam, t)
        out = np.empty(len(t))
        elem, fun = self.elem[which], self.fun[which]
        for q in np.unique(elem):
            sel = np.nonzero(elem == q)[0]
            val = self.elements[q].switching_functions(z[sel, :n], z[sel, n:], self.w * t[sel], self.p).value
            out[sel] = val[np.arange(sel.size), fun[sel]]
        return out


def _brentq_all(f, a, b, fa, fb, active, xtol, rtol, maxiter):
    """Roots of ``f`` in the brackets ``[a[r], b[r]]`` with ``r`` in ``active``, by Brent's method side by side.

    ``f(t, which)`` returns the values at the times ``t`` of the brackets
    ``which``. ``fa``, ``fb``: the values at the ends (nonzero, of opposite
    signs). The iterates are those of ``scipy.optimize.brentq(f_r, a, b,
    xtol, rtol, maxiter)`` for each bracket alone.

    Returns
    -------
    ndarray
        The roots of the active brackets, in their order.

    Raises
    ------
    RuntimeError
        A bracket not converged in ``maxiter`` iterations (as ``brentq``).
    """
    idx = np.nonzero(active)[0]
    xpre, xcur = a[idx].astype(float), b[idx].astype(float)
    fpre, fcur = fa[idx].astype(float), fb[idx].astype(float)
    xblk, fblk, spre, scur = (np.zeros(idx.size) for _ in range(4))
    done = np.zeros(idx.size, dtype=np.bool_)
    for _ in range(maxiter):
        _brent_advance(xpre, xcur, xblk, fpre, fcur, fblk, spre, scur, done, xtol, rtol)
        pending = np.nonzero(~done)[0]
        if not pending.size:
            return xcur
        fcur[pending] = f(xcur[pending], idx[pending])
    raise RuntimeError(f"Failed to converge after {maxiter} iterations, value is {xcur[~done][0]}")


@nb.njit(cache=True)
def _brent_advance(xpre, xcur, xblk, fpre, fcur, fblk, spre, scur, done, xtol, rtol):
    """One iteration of Brent's method for every bracket not yet ``done``, up to its next evaluation.

    The state arrays are updated in place; a bracket that has converged is
    marked ``done`` with its root in ``xcur``, the others hold their next
    trial point in ``xcur`` and wait for ``fcur`` there. The arithmetic is
    that of SciPy's ``brentq`` (``scipy/optimize/Zeros/brentq.c``), operation
    for operation, so that the roots are the same to the last bit.
    """
    for r in range(xcur.shape[0]):
        if done[r]:
            continue
        if fpre[r] != 0.0 and fcur[r] != 0.0 and ((fpre[r] < 0.0) != (fcur[r] < 0.0)):
            xblk[r] = xpre[r]
            fblk[r] = fpre[r]
            spre[r] = xcur[r] - xpre[r]
            scur[r] = spre[r]
        if abs(fblk[r]) < abs(fcur[r]):
            xpre[r] = xcur[r]
            xcur[r] = xblk[r]
            xblk[r] = xpre[r]
            fpre[r] = fcur[r]
            fcur[r] = fblk[r]
            fblk[r] = fpre[r]
        delta = (xtol + rtol * abs(xcur[r])) / 2
        sbis = (xblk[r] - xcur[r]) / 2
        if fcur[r] == 0.0 or abs(sbis) < delta:
            done[r] = True
            continue
        if abs(spre[r]) > delta and abs(fcur[r]) < abs(fpre[r]):
            if xpre[r] == xblk[r]:
                stry = -fcur[r] * (xcur[r] - xpre[r]) / (fcur[r] - fpre[r])
            else:
                dpre = (fpre[r] - fcur[r]) / (xpre[r] - xcur[r])
                dblk = (fblk[r] - fcur[r]) / (xblk[r] - xcur[r])
                stry = -fcur[r] * (fblk[r] * dblk - fpre[r] * dpre) / (dblk * dpre * (fblk[r] - fpre[r]))
            lim = abs(spre[r])
            if 3 * abs(sbis) - delta < lim:
                lim = 3 * abs(sbis) - delta
            if 2 * abs(stry) < lim:
                spre[r] = scur[r]
                scur[r] = stry
            else:
                spre[r] = sbis
                scur[r] = sbis
        else:
            spre[r] = sbis
            scur[r] = sbis
        xpre[r] = xcur[r]
        fpre[r] = fcur[r]
        if abs(scur[r]) > delta:
            xcur[r] += scur[r]
        else:
            xcur[r] += delta if sbis > 0 else -delta


def _switch_events_at(hb, u, lam, p, sw_elements, tc, elem, fun, direction, saltation):
    """The :class:`SwitchEvent` list for the switches at the times ``tc`` (E,), in that order.

    ``elem`` indexes ``sw_elements``; ``fun``, ``direction`` as in
    :class:`SwitchEvent`. The elements are evaluated once each on all the
    switch states; each event is then what :func:`_saltation` gives, with
    the force before the switch ``f_nl + (on - [h_i > 0]) difference_i``
    (law ``i`` taken on for a switch off and off for a switch on, the rest
    as evaluated): exact on the surface, where the elements' own choice of
    law is a matter of rounding.
    """
    n = hb.n
    w = float(p[hb.kw])
    z = orbit_state(hb, u, lam, tc)
    x, xd = np.ascontiguousarray(z[:, :n]), np.ascontiguousarray(z[:, n:])
    tau = w * tc
    F = _force_jacobians(hb, x, xd, tau, p)[0]
    fe = _excitation_at(hb, p, tau)
    M, C, K = hb.model.linear(p)
    Minv = np.linalg.inv(M)
    E = tc.shape[0]
    force_before = np.empty((E, n))
    normal = np.empty((E, 2 * n))
    jump = np.empty((E, n))
    for q in np.unique(elem):
        sel = np.nonzero(elem == q)[0]
        r, i = np.arange(sel.size), fun[sel]
        sw = sw_elements[q][1].switching_functions(x[sel], xd[sel], tau[sel], p)
        on = (direction[sel] < 0).astype(float)
        force_before[sel] = F[sel] + (on - (sw.value[r, i] > 0.0))[:, None] * sw.difference[r, i]
        normal[sel, :n] = sw.grad_x[r, i]
        normal[sel, n:] = sw.grad_xd[r, i]
        jump[sel] = sw.jump[r, i]
    f_minus, f_plus, nf, nf_plus = _fields(z, normal, jump, fe, force_before, direction.astype(float), Minv,
                                           np.ascontiguousarray(C, dtype=float), np.ascontiguousarray(K, dtype=float))
    dfield = f_plus - f_minus
    scale = np.maximum(np.maximum(np.abs(f_minus).max(axis=1), np.abs(f_plus).max(axis=1)), 1e-300)
    continuous = np.abs(dfield).max(axis=1) <= 64 * _EPS * scale
    crossing = (direction * nf > 0) & (direction * nf_plus > 0)
    S = np.broadcast_to(np.eye(2 * n), (E, 2 * n, 2 * n)).copy()
    kick = ~continuous if saltation else np.zeros(E, dtype=bool)
    S[kick] += dfield[kick, :, None] * normal[kick, None, :] / nf[kick, None, None]
    events = []
    for k in range(E):
        e, el, _ = sw_elements[elem[k]]
        label = getattr(el, "label", "") or el.kind
        if not continuous[k] and not crossing[k]:
            raise ArithmeticError(
                f"switch of '{label}' (function {fun[k]}) at t = {tc[k]:.12g}: the orbit does not cross the surface "
                f"transversally (n^T f- = {nf[k]:.3g}, n^T f+ = {nf_plus[k]:.3g} for a switch "
                f"{'on' if direction[k] > 0 else 'off'}) while the force jumps there; the saltation matrix is "
                "undefined (grazing, or sliding along the surface)")
        events.append(SwitchEvent(float(tc[k]), int(e), str(label), int(fun[k]), int(direction[k]), z[k].copy(),
                                  normal[k], f_minus[k], f_plus[k], float(nf[k]), S[k]))
    return events


@nb.njit(cache=True)
def _fields(z, normal, jump, fe, force_before, direction, Minv, C, K):
    """The vector fields before and after each switch and their rates across the surface.

    Parameters
    ----------
    z, normal : ndarray, shape (E, 2n)
    jump, fe, force_before : ndarray, shape (E, n)
    direction : ndarray, shape (E,)
    Minv, C, K : ndarray, shape (n, n)

    Returns
    -------
    f_minus, f_plus : ndarray, shape (E, 2n)
        ``(x', M^-1 (fe - C x' - K x - force_before))`` and the same with the
        acceleration less ``M^-1 direction jump``.
    nf, nf_plus : ndarray, shape (E,)
        ``normal . f_minus``, ``normal . f_plus``.
    """
    E = z.shape[0]
    n = Minv.shape[0]
    f_minus = np.empty((E, 2 * n))
    f_plus = np.empty((E, 2 * n))
    nf = np.empty(E)
    nf_plus = np.empty(E)
    r = np.empty(n)
    for k in range(E):
        for a in range(n):
            cx = 0.0
            kx = 0.0
            for b in range(n):
                cx += C[a, b] * z[k, n + b]
                kx += K[a, b] * z[k, b]
            r[a] = fe[k, a] - cx - kx - force_before[k, a]
        for a in range(n):
            acc = 0.0
            dj = 0.0
            for b in range(n):
                acc += Minv[a, b] * r[b]
                dj += Minv[a, b] * (direction[k] * jump[k, b])
            f_minus[k, a] = z[k, n + a]
            f_plus[k, a] = z[k, n + a]
            f_minus[k, n + a] = acc
            f_plus[k, n + a] = acc - dj
        s1 = 0.0
        s2 = 0.0
        for a in range(2 * n):
            s1 += normal[k, a] * f_minus[k, a]
            s2 += normal[k, a] * f_plus[k, a]
        nf[k] = s1
        nf_plus[k] = s2
    return f_minus, f_plus, nf, nf_plus


def _segments(events, T):
    """Segment bounds ``[(a, b)]`` between the switch times over ``[0, T]``."""
    bounds = [0.0] + [ev.time for ev in events] + [T]
    return list(zip(bounds[:-1], bounds[1:]))


def _modes(hb, u, lam, p, t, z=None, sw_elements=None):
    """Signs ``h > 0`` of every switching function at the orbit times ``t``: shape (len(t), total m).

    ``z`` (shape (len(t), 2n)): the orbit states there, if already known;
    ``sw_elements``: :func:`_switching_elements` of the model, if known.
    """
    n = hb.n
    if z is None:
        z = orbit_state(hb, u, lam, np.asarray(t, dtype=float))
    if sw_elements is None:
        sw_elements = _switching_elements(hb.model)
    tau = float(p[hb.kw]) * np.asarray(t, dtype=float)
    cols = [_switch_values(el, z[:, :n], z[:, n:], tau, p) > 0.0 for _, el, _ in sw_elements]
    return np.concatenate(cols, axis=1) if cols else np.zeros((len(t), 0), dtype=bool)


def _piecewise_nodes(hb, u, lam, p, events, T, steps):
    """RK4 nodes of each segment between switches, with one-sided end nodes.

    Returns ``(t, z, starts, nsteps, h)``: node times (K,), the orbit there
    (K, 2n), the first node and the step count of each segment, and its step. End nodes at a switch are
    moved into their segment by ``1e-9`` (up to ``1e-3``) of the half step, so
    that the elements evaluate the segment's law there; every node of a
    segment is checked to be in the segment's contact mode.
    """
    sw_elements = _switching_elements(hb.model)
    bounds = np.array([0.0] + [ev.time for ev in events] + [T])
    a, b = bounds[:-1], bounds[1:]
    G = a.size
    L = b - a
    nsteps = np.where(L <= 0.0, 0, np.maximum(1, np.rint(steps * L / T))).astype(np.int64)
    hs = np.where(nsteps > 0, L / np.maximum(nsteps, 1), 0.0)
    count = np.where(nsteps > 0, 2 * nsteps + 1, 0)
    starts = np.concatenate([[0], np.cumsum(count)[:-1]]).astype(np.int64)
    seg = np.repeat(np.arange(G), count)
    k = np.arange(seg.size) - starts[seg]
    t = a[seg] + L[seg] * k / (2 * nsteps[seg])
    live = np.nonzero(nsteps > 0)[0]
    last = starts[live] + 2 * nsteps[live]
    t[last] = b[live]
    z = orbit_state(hb, u, lam, t)
    mode = _modes(hb, u, lam, p, t, z, sw_elements)
    # the expected mode of each segment: that of its middle node
    mid_node = starts + nsteps
    expected = mode[mid_node[seg]]
    # the end nodes at a switch, in the order (segment, first, last); each moves into its segment
    half = L / np.maximum(2 * nsteps, 1)
    ends = np.stack([starts[live], last], axis=1)
    sign = np.broadcast_to([1.0, -1.0], ends.shape)
    move = np.stack([live > 0, live < G - 1], axis=1)
    node, sign, half = ends[move], sign[move], np.repeat(half[live], 2).reshape(-1, 2)[move]
    base = t[node]
    pending = np.arange(node.size)
    for q in range(7):
        if not pending.size:
            break
        tq = base[pending] + sign[pending] * 1e-9 * 10.0**q * half[pending]
        zq = orbit_state(hb, u, lam, tq)
        ok = np.all(_modes(hb, u, lam, p, tq, zq, sw_elements) == expected[node[pending]], axis=1)
        t[node[pending[ok]]] = tq[ok]
        z[node[pending[ok]]] = zq[ok]
        pending = pending[~ok]
    if pending.size:
        raise ArithmeticError(f"the contact mode next to the switch at t = {base[pending[0]]:.12g} cannot be resolved")
    mode[node] = expected[node]
    bad = np.nonzero(np.any(mode != expected, axis=1))[0]
    if bad.size:
        raise ArithmeticError(
            f"the orbit switches at t = {t[bad[0]]:.9g} between the located switches (a contact shorter than "
            f"T/{2 * steps}, or a grazing); raise steps_per_period")
    # each switch flips its own function and nothing else, and the mode is periodic
    cols = _mode_columns(hb.model)
    mid = [mode[mid_node[s]] if nsteps[s] else None for s in range(G)]
    current = (mid[0] if mid[0] is not None else mid[-1]).copy()
    for s, ev in enumerate(events):
        current[cols[(ev.element, ev.function)]] ^= True
        if mid[s + 1] is not None and not np.array_equal(current, mid[s + 1]):
            raise ArithmeticError(f"the contact mode after the switch at t = {ev.time:.12g} is not the one the "
                                  "switch leads to: an unlocated switch; raise steps_per_period")
    if mid[0] is not None and not np.array_equal(current, mid[0]):
        raise ArithmeticError("the contact mode at the end of the period differs from the start: an unlocated switch")
    return t, z, starts, nsteps, hs


def _piecewise_rk4(hb, u, lam, steps, events, saltation):
    n = hb.n
    p = hb.params_at(lam)
    T = 2.0 * np.pi / _frequency(hb, lam)
    t, z, starts, nsteps, h = _piecewise_nodes(hb, u, lam, p, events, T, steps)
    jumps = np.array([ev.saltation for ev in events])
    Phi = _integrate(hb, p, np.ascontiguousarray(z[:, :n]), np.ascontiguousarray(z[:, n:]), float(p[hb.kw]) * t,
                     starts, nsteps, h, jumps, T, lam)
    return Monodromy(Phi, T, "rk4", steps=int(nsteps.sum()), evaluations=len(t), switches=tuple(events),
                     saltation=bool(saltation))


def orbit_state(hb, u: np.ndarray, lam: float, t) -> np.ndarray:
    """State ``(x, x')`` of the HB solution at times ``t``.

    Parameters
    ----------
    t : float or ndarray, shape (K,)

    Returns
    -------
    ndarray, shape (2n,) or (K, 2n)
    """
    Omega = _frequency(hb, lam)
    U = np.ascontiguousarray(coefficient_blocks(u, hb.n), dtype=float)
    tt = np.atleast_1d(np.asarray(t, dtype=float))
    z = _synthesize_at(U, Omega, np.ascontiguousarray(Omega * tt))
    return z[0] if np.ndim(t) == 0 else z


@nb.njit(cache=True)
def _synthesize_at(U, Omega, th):
    """``(x, x')`` at the phases ``th`` (K,) from ``U`` (2H+1, n): shape (K, 2n).

    ``cos k th``, ``sin k th`` by the rotation recurrence from ``cos th``,
    ``sin th`` (rounding error growing like ``k eps``). The phases are taken
    in blocks, the recurrence and the sums running across a block so that
    they vectorise; each point still sees the same operations in the same
    order as when it is synthesised alone.
    """
    H = (U.shape[0] - 1) // 2
    n = U.shape[1]
    K = th.shape[0]
    z = np.empty((K, 2 * n))
    nb_ = 64
    c1 = np.empty(nb_)
    s1 = np.empty(nb_)
    ck = np.empty(nb_)
    sk = np.empty(nb_)
    acc = np.empty((2 * n, nb_))
    for j0 in range(0, K, nb_):
        m = min(nb_, K - j0)
        for j in range(m):
            c1[j] = np.cos(th[j0 + j])
            s1[j] = np.sin(th[j0 + j])
            ck[j] = 1.0
            sk[j] = 0.0
        for i in range(n):
            for j in range(m):
                acc[i, j] = U[0, i]
                acc[n + i, j] = 0.0
        for k in range(1, H + 1):
            wk = Omega * k
            for j in range(m):
                c = ck[j] * c1[j] - sk[j] * s1[j]
                sk[j] = sk[j] * c1[j] + ck[j] * s1[j]
                ck[j] = c
            for i in range(n):
                a = U[2 * k - 1, i]
                b = U[2 * k, i]
                for j in range(m):
                    acc[i, j] += a * ck[j] + b * sk[j]
                    acc[n + i, j] += wk * (b * ck[j] - a * sk[j])
        for j in range(m):
            for i in range(2 * n):
                z[j0 + j, i] = acc[i, j]
    return z


def _pointwise(hb, p):
    """Callables evaluating the model at one state (the reference path)."""
    n = hb.n
    M, C, K = hb.model.linear(p)
    Minv = np.linalg.inv(M)
    w = float(p[hb.kw])
    f = np.zeros((1, n))
    dfdx = np.zeros((1, n, n))
    dfdxd = np.zeros((1, n, n))
    fe = np.zeros((1, n))
    tau = np.zeros(1)

    def forces(x, xd, t):
        f[:] = 0.0
        dfdx[:] = 0.0
        dfdxd[:] = 0.0
        tau[0] = w * t
        for el in hb.model.forces:
            el.evaluate(x[None, :], xd[None, :], tau, p, f, dfdx, dfdxd)
        return f[0], dfdx[0], dfdxd[0]

    def excitation(t):
        fe[:] = 0.0
        tau[0] = w * t
        for el in hb.model.excitations:
            el.evaluate(tau, p, fe)
        return fe[0]

    return M, C, K, Minv, forces, excitation


def _state_matrix(Minv, C, K, dfdx, dfdxd, n):
    A = np.zeros((2 * n, 2 * n))
    A[:n, n:] = np.eye(n)
    A[n:, :n] = -Minv @ (K + dfdx)
    A[n:, n:] = -Minv @ (C + dfdxd)
    return A


def _check_switch_mode(switches):
    if switches not in _SWITCH_MODES:
        raise ValueError(f"switches must be one of {list(_SWITCH_MODES)}, got {switches!r}")


def _clamped(a, b, inner_a, inner_b):
    """``t -> t`` clamped into ``[a, b]`` shrunk by ``1e-9 (b - a)`` at the ends that are switches."""
    lo = a + (1e-9 * (b - a) if inner_a else 0.0)
    hi = b - (1e-9 * (b - a) if inner_b else 0.0)
    return lambda t: min(max(t, lo), hi)


def monodromy_orbit_ivp(hb, u: np.ndarray, lam: float, rtol: float = 1e-11, atol: float = 1e-12,
                        switches: str = "saltation", samples: int = 4096) -> Monodromy:
    """Monodromy of the variational equations along the HB orbit, adaptive DOP853.

    Same equations as :func:`monodromy_rk4` (the orbit is the HB solution,
    evaluated exactly at every requested time) with an error-controlled
    integrator: the reference for the fixed-step error. With switches
    (``switches`` as in :func:`monodromy_rk4`; located on ``samples``
    points) each segment between two switches is integrated separately, its
    ends evaluated ``1e-9`` of its length inside, and the saltation matrices
    are applied in between.
    """
    _check_switch_mode(switches)
    n = hb.n
    p = hb.params_at(lam)
    Omega = _frequency(hb, lam)
    T = 2.0 * np.pi / Omega
    _, C, K, Minv, forces, _ = _pointwise(hb, p)
    d = 2 * n
    events = [] if switches == "ignore" else switching_events(hb, u, lam, samples, saltation=switches == "saltation")
    segs = _segments(events, T)
    Phi = np.eye(d)
    nfev = 0
    for s, (a, b) in enumerate(segs):
        if b > a:
            clamp = _clamped(a, b, s > 0, s < len(segs) - 1)

            def rhs(t, y, clamp=clamp):
                tt = clamp(t)
                z = orbit_state(hb, u, lam, tt)
                _, dfdx, dfdxd = forces(z[:n], z[n:], tt)
                A = _state_matrix(Minv, C, K, dfdx, dfdxd, n)
                return (A @ y.reshape(d, d)).reshape(-1)

            sol = solve_ivp(rhs, (a, b), Phi.reshape(-1), method="DOP853", rtol=rtol, atol=atol)
            if not sol.success:
                raise ArithmeticError(f"solve_ivp failed on the variational equations: {sol.message}")
            Phi = sol.y[:, -1].reshape(d, d)
            nfev += int(sol.nfev)
        if s < len(events):
            Phi = events[s].saltation @ Phi
    return Monodromy(Phi, T, "orbit-dop853", evaluations=nfev, switches=tuple(events),
                     saltation=bool(events) and switches == "saltation")


def monodromy_reference(hb, u: np.ndarray, lam: float, rtol: float = 1e-11, atol: float = 1e-12,
                        switches: str = "saltation", max_switches: int = 1000) -> Monodromy:
    """Reference monodromy: the nonlinear flow from the HB state and its variational equations, DOP853.

    Integrates ``M x'' + C x' + K x + f(x, x', w t) = f_ext(w t)`` together with
    ``Phi' = A(t) Phi`` from the HB state at ``t = 0`` over one period. The
    right-hand side calls the elements with ``(1, n)`` arrays (slow, but this
    is the reference).

    For a model with switching functions (and ``switches != 'ignore'``) the
    state is integrated first, one contact mode at a time: each law is frozen
    (the elements' force is corrected by ``(mode - [h > 0]) * difference``, so that a
    trial stage beyond a surface sees the smooth extension of the current
    law), the switches are terminal events located by ``solve_ivp`` on its
    dense output, and the mode flips there. The variational equations are
    then integrated segment by segment along that dense trajectory, with the
    saltation matrix at each switch (``switches='piecewise'``: without). This
    path shares nothing with the HB orbit but its start, so it checks
    :func:`monodromy_rk4` up to the HB truncation error (``orbit_error``).

    Returns
    -------
    Monodromy
        With ``orbit_error = max |z(T) - z(0)|`` and the switches of the
        nonlinear trajectory.

    Raises
    ------
    ArithmeticError
        ``solve_ivp`` fails, more than ``max_switches`` switches (chatter), or
        a switch without a defined saltation matrix.
    """
    _check_switch_mode(switches)
    n = hb.n
    p = hb.params_at(lam)
    Omega = _frequency(hb, lam)
    T = 2.0 * np.pi / Omega
    _, C, K, Minv, forces, excitation = _pointwise(hb, p)
    d = 2 * n
    z0 = orbit_state(hb, u, lam, 0.0)
    sw = [] if switches == "ignore" else _switching_elements(hb.model)
    if sw:
        return _reference_with_switches(hb, p, T, z0, sw, rtol, atol, switches == "saltation", max_switches)

    def rhs(t, y):
        x, xd = y[:n], y[n:d]
        f, dfdx, dfdxd = forces(x, xd, t)
        acc = Minv @ (excitation(t) - C @ xd - K @ x - f)
        A = _state_matrix(Minv, C, K, dfdx, dfdxd, n)
        out = np.empty_like(y)
        out[:n] = xd
        out[n:d] = acc
        out[d:] = (A @ y[d:].reshape(d, d)).reshape(-1)
        return out

    y0 = np.concatenate([z0, np.eye(d).reshape(-1)])
    sol = solve_ivp(rhs, (0.0, T), y0, method="DOP853", rtol=rtol, atol=atol)
    if not sol.success:
        raise ArithmeticError(f"solve_ivp failed on the reference integration: {sol.message}")
    yT = sol.y[:, -1]
    return Monodromy(
        yT[d:].reshape(d, d), T, "dop853", evaluations=int(sol.nfev), orbit_error=float(np.max(np.abs(yT[:d] - z0)))
    )


def _reference_with_switches(hb, p, T, z0, sw, rtol, atol, saltation, max_switches):
    """:func:`monodromy_reference` for a model with switching functions (see there)."""
    n = hb.n
    d = 2 * n
    w = float(p[hb.kw])
    _, C, K, Minv, forces, excitation = _pointwise(hb, p)
    funcs = [(e, el, i) for e, el, m in sw for i in range(m)]

    def switching(t, z):
        tau = np.array([w * t])
        out = [el.switching_functions(z[None, :n], z[None, n:], tau, p) for _, el, _ in sw]
        return np.concatenate([o.value[0] for o in out]), np.concatenate([o.difference[0] for o in out])

    def force_in_mode(t, z, mode):
        f = forces(z[:n], z[n:], t)[0].copy()
        h, jump = switching(t, z)
        return f + ((mode.astype(float) - (h > 0.0)) @ jump)

    mode = switching(0.0, z0)[0] > 0.0
    skip = [None]  # (function, restart time, value there): the sign just after a switch

    def rhs_state(t, z):
        acc = Minv @ (excitation(t) - C @ z[n:] - K @ z[:n] - force_in_mode(t, z, mode))
        return np.concatenate([z[n:], acc])

    def event(k):
        def h(t, z):
            if skip[0] is not None and skip[0][0] == k and t == skip[0][1]:
                return skip[0][2]
            return float(switching(t, z)[0][k])

        h.terminal = True
        return h

    evs = [event(k) for k in range(len(funcs))]
    t0, z = 0.0, z0.copy()
    pieces, events, nfev = [], [], 0
    while True:
        sol = solve_ivp(rhs_state, (t0, T), z, method="DOP853", rtol=rtol, atol=atol, events=evs, dense_output=True)
        nfev += int(sol.nfev)
        if not sol.success:
            raise ArithmeticError(f"solve_ivp failed on the reference integration: {sol.message}")
        t1 = float(sol.t[-1])
        pieces.append((t0, t1, sol.sol))
        if sol.status == 0:
            zT = sol.y[:, -1]
            break
        k = next(j for j in range(len(funcs)) if len(sol.t_events[j]))
        tc, zc = float(sol.t_events[k][0]), np.array(sol.y_events[k][0])
        e, el, i = funcs[k]
        direction = -1 if mode[k] else 1
        events.append(_saltation(hb, p, el, e, i, direction, tc, zc, force_in_mode(tc, zc, mode), saltation))
        if len(events) > max_switches:
            raise ArithmeticError(f"more than {max_switches} switches in one period (chatter) at t = {tc:.9g}")
        mode[k] = not mode[k]
        skip[0] = (k, tc, 1e-300 if mode[k] else -1e-300)
        t0, z = tc, zc
    Phi = np.eye(d)
    for s, (a, b, dense) in enumerate(pieces):
        if b > a:
            clamp = _clamped(a, b, s > 0, s < len(pieces) - 1)

            def rhs(t, y, clamp=clamp, dense=dense):
                tt = clamp(t)
                zz = dense(tt)
                _, dfdx, dfdxd = forces(zz[:n], zz[n:], tt)
                A = _state_matrix(Minv, C, K, dfdx, dfdxd, n)
                return (A @ y.reshape(d, d)).reshape(-1)

            sol = solve_ivp(rhs, (a, b), Phi.reshape(-1), method="DOP853", rtol=rtol, atol=atol)
            if not sol.success:
                raise ArithmeticError(f"solve_ivp failed on the variational equations: {sol.message}")
            Phi = sol.y[:, -1].reshape(d, d)
            nfev += int(sol.nfev)
        if s < len(events):
            Phi = events[s].saltation @ Phi
    return Monodromy(Phi, T, "dop853", evaluations=nfev, orbit_error=float(np.max(np.abs(zT - z0))),
                     switches=tuple(events), saltation=bool(events) and saltation)
