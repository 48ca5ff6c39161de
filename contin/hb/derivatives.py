"""Derivatives of the harmonic-balance Jacobian, for systems that augment ``R = 0``.

Two-parameter continuation of folds and period doublings (see
:mod:`contin.bifurcation.two_parameter`) needs more than ``R`` and ``dR/du``:

- ``R``, ``J = dR/du`` and ``dR/dp_k`` for *several* parameters at an
  arbitrary parameter vector ``p`` (:meth:`HBDerivatives.linearize_at`);
- the *flip matrix* ``B(u, p)``: the odd-harmonic block of the order-``2 nu``
  Jacobian at an order-``nu`` solution (:meth:`HBDerivatives.flip_matrix`),
  singular exactly where the truncated problem has a Floquet multiplier -1;
- for a matrix ``Mx`` in {``J``, ``B``} and two fixed vectors ``v``, ``w``,
  the scalar ``S(u, p) = w^T Mx(u, p) v``, its gradient in ``u`` and its
  derivatives in parameters (:meth:`HBDerivatives.bilinear`). With ``v``,
  ``w`` the bordered null vectors this is the derivative of Govaerts'
  test function, ``g_z = -S_z``.

How the gradient in ``u`` is obtained
-------------------------------------
``S = w^T A v + sum_j W_j . (f_x(x_j, xd_j) V_j + f_xd(x_j, xd_j) Vd_j)``,
where ``V_j``, ``Vd_j`` are the time samples of ``v`` and of its velocity and
``W_j`` the samples of the adjoint of the AFT projection applied to ``w``.
Only the force Jacobians ``f_x``, ``f_xd`` depend on ``u``, through the
samples ``(x_j, xd_j)``. Because second derivatives are symmetric,

    d/dx_j [W_j . (f_x V_j + f_xd Vd_j)] = (D f_x)^T W_j,   D = directional derivative along (V_j, Vd_j),

and likewise for ``xd_j``. The element kernels provide ``f_x`` and ``f_xd``
analytically but not their derivatives, so ``D f_x`` and ``D f_xd`` are taken
as a *central difference of the analytic sample Jacobians along the sampled
direction*, per sample: two extra force evaluations in all, not one per
unknown. The chain rule through the synthesis ``u -> (x_j, xd_j)`` (an FFT)
then gives the gradient. For polynomial forces of degree <= 3 (Duffing,
Mathieu) ``f_x`` is at most quadratic, so the central difference is exact
to rounding; for smooth forces its error is ``O(h^2)``. This gradient only
enters the *Jacobian* of the augmented systems (and the cusp test): the
residual of those systems, ``R`` and the test function ``g``, is computed
from the analytic ``J`` and ``B`` and is exact, so a small error here slows
Newton's convergence without moving the converged curve
(``tests/test_bifurcation_curves.py`` checks the resulting Jacobians against
finite differences of the residuals).

Parameter derivatives of ``S`` are central differences of ``S`` itself in the
parameter (exact to rounding for parameters that enter at most quadratically,
as the frequency, stiffnesses, damping and force amplitudes do).

Contact laws with their switches resolved
-----------------------------------------
A problem built with ``crossings='interval'`` or ``'exact'``
(:class:`~contin.hb.problem.HBOptions`) integrates its contact laws
over arcs whose ends move with ``u`` (:mod:`contin.hb.crossings`,
:mod:`contin.hb.contact_quadrature`). The sample formulas above do not hold
there, so everything is taken from the problems' own analytic linearisation
(:meth:`HarmonicBalance.linearize`): ``R``, ``J`` and ``dR/dp_k`` of the
order-``nu`` problem continued in ``p_k``; ``B`` as the flip block of the
Jacobian of the order-``2 nu`` problem (``2H`` harmonics, ``2N`` samples) at
the embedded solution; and for ``S = w^T Mx v`` the same symmetry argument on
the whole residual,

    dS/du = (D_v Mx)^T w,       dS/dp_k = w . D_v (dR/dp_k),

with ``D_v`` a central difference along ``v`` of the analytic Jacobian and of
``dR/dp_k`` (two linearisations per parameter; for ``B`` the difference is
taken in the order-``2 nu`` space and restricted to the embedded
coefficients). Where the law's arcs appear or vanish (a grazing touch) the
residual is only once differentiable and the difference straddles the
change; as above, this affects Newton's rate, not the converged curve. With
the plain law, the bearing rotor's period-doubling curves stop where the
orbit starts to leave its casing (the sampled residual jumps when a sample
crosses the clearance); with the switches resolved they pass through.
"""

from __future__ import annotations

import dataclasses
import enum

import numpy as np

from contin.hb import aft
from contin.hb.linear import linear_apply, linear_operator
from contin.hb.factory import harmonic_balance
from contin.hb.problem import HarmonicBalance
from contin.hb.harmonics import coefficient_blocks, embed

__all__ = ["MatrixKind", "HBDerivatives", "flip_indices"]


class MatrixKind(str, enum.Enum):
    """Which matrix a singularity condition is imposed on.

    JACOBIAN
        ``J = dR/du`` of the order-``nu`` problem (folds: multiplier +1).
    FLIP
        The odd-harmonic block ``B`` of the order-``2 nu`` Jacobian at the
        order-``nu`` solution (period doubling: multiplier -1).
    """

    JACOBIAN = "jacobian"
    FLIP = "flip"

    def __str__(self) -> str:
        return self.value


def flip_indices(n: int, harmonics: int) -> np.ndarray:
    """Positions of the flip-block unknowns in the order-``2 nu`` coefficient vector.

    The flip block of an order-``nu`` problem with ``H = harmonics`` holds
    the odd harmonics ``1, 3, ..., 2H-1`` of ``w/(2 nu)``; in the order-``2 nu``
    vector with ``2H`` harmonics (:mod:`contin.hb.harmonics`) they sit at these
    indices, shape (2nH,).
    """
    idx = []
    for k in range(1, 2 * harmonics, 2):
        idx.extend(range((2 * k - 1) * n, (2 * k + 1) * n))
    return np.array(idx, dtype=int)


def _contract(W, G, V) -> float:
    """``sum_j W_j . (G_j V_j)`` for shapes (N', n), (N', n, n), (N', n)."""
    return float(np.sum(W * np.matmul(G, V[:, :, None])[:, :, 0]))


def _limited_difference(W, Gp, G0, Gm, h):
    """``(D G)^T W`` per sample from ``G`` at ``x + hV``, ``x``, ``x - hV``, shape (N', n).

    Central difference where the two one-sided differences agree (smooth
    samples, second order); at a sample whose difference interval straddles a
    switching surface of a piecewise force (contact onset), the one-sided
    difference of smaller size, i.e. the derivative of the smooth piece the
    sample lies on, instead of a spike of the size of the jump over ``h``.
    """
    fwd = np.einsum("ja,jac->jc", W, Gp - G0) / h
    bwd = np.einsum("ja,jac->jc", W, G0 - Gm) / h
    out = 0.5 * (fwd + bwd)
    nf = np.sqrt(np.sum(fwd * fwd, axis=1))
    nb = np.sqrt(np.sum(bwd * bwd, axis=1))
    jump = np.abs(nf - nb) > 0.5 * np.maximum(nf, nb) + 1e-300
    if np.any(jump):
        pick_f = (nf <= nb)[:, None]
        out[jump] = np.where(pick_f, fwd, bwd)[jump]
    return out


class HBDerivatives:
    """Jacobians, flip matrices and second-order terms of a harmonic-balance problem.

    Everything is evaluated at an explicit parameter vector ``p`` (shape
    (P,), in ``hb.model.param_names`` order), so any two parameters can vary
    together; ``hb`` supplies the model, ``H``, ``nu``, ``N`` and the sample
    phases, and its own continuation parameter plays no role.

    Parameters
    ----------
    hb : HarmonicBalance
        With ``crossings='none'`` (or no switching force) the derivatives are
        assembled from the samples; otherwise from the problem's own
        linearisation (see "Contact laws with their switches resolved").
    fd_step : float
        Relative step of the central differences (see the module docstring).
    """

    def __init__(self, hb: HarmonicBalance, fd_step: float = 1e-6):
        self.resolved = hb.options.crossings != "none" and bool(hb._switching)
        self.hb = hb
        self.model = hb.model
        self.n, self.H, self.nu, self.N = hb.n, hb.H, hb.nu, hb.N
        self.size = hb.size
        self.flip_size = 2 * self.n * self.H
        self.kw = hb.kw
        self.tau = np.ascontiguousarray(hb.tau)
        self.tau2 = np.ascontiguousarray(np.concatenate([hb.tau, hb.tau]))
        self.flip_idx = flip_indices(self.n, self.H)
        self.fd_step = float(fd_step)
        # switches resolved between samples: everything comes from HarmonicBalance.linearize of the
        # order-nu problem and of the order-2nu problem at the embedded solution (see _resolved_*)
        self._flip_options = dataclasses.replace(hb.options, subharmonic=2 * self.nu, harmonics=2 * self.H,
                                                 samples=2 * self.N)
        self.embed_idx = embed(np.arange(1, self.size + 1, dtype=float), self.n, 2).nonzero()[0]
        self._last = (None, None)

    # ------------------------------------------------------------ evaluation
    def _samples(self, u: np.ndarray, p: np.ndarray):
        U = np.ascontiguousarray(coefficient_blocks(u, self.n))
        x, xp = aft.synthesize(U, self.N)
        return x, self.hb.base_frequency(p) * xp, xp

    def _forces(self, x, xd, tau, p):
        N, n = x.shape
        f = np.zeros((N, n))
        fx = np.zeros((N, n, n))
        fxd = np.zeros((N, n, n))
        for el in self.model.forces:
            el.evaluate(x, xd, tau, p, f, fx, fxd)
        return f, fx, fxd

    # ------------------------------------------------------------ switches resolved between samples
    def _problem(self, p: np.ndarray, k: int, flip: bool) -> HarmonicBalance:
        """The order-``nu`` (or, with ``flip``, order-``2 nu``) problem at ``p``, continued in parameter ``k``."""
        opts = self._flip_options if flip else self.hb.options
        names = self.model.param_names
        return harmonic_balance(self.model, names[k], opts, dict(zip(names, (float(x) for x in p))), self.hb.frequency)

    def _linearized(self, base: np.ndarray, p: np.ndarray, k: int, flip: bool):
        """``HarmonicBalance.linearize`` at ``base``, ``p`` in parameter ``k`` (the last call is kept)."""
        key = (base.tobytes(), p.tobytes(), k, flip)
        if self._last[0] != key:
            self._last = (key, self._problem(p, k, flip).linearize(base, float(p[k])))
        return self._last[1]

    def _embedded(self, u: np.ndarray) -> np.ndarray:
        """``u`` as an order-``2 nu`` vector with ``2H`` harmonics, shape (n(4H+1),)."""
        return embed(np.asarray(u, float), self.n, 2)

    def _resolved_bilinear(self, u, p, v, w, kind: MatrixKind, ks):
        """:meth:`bilinear` from Jacobians with the switches resolved (module docstring)."""
        flip = kind is MatrixKind.FLIP
        if flip:
            base = self._embedded(u)
            vf, wf = np.zeros(base.size), np.zeros(base.size)
            vf[self.flip_idx] = v
            wf[self.flip_idx] = w
        else:
            base, vf, wf = np.asarray(u, float), v, w
        ks = tuple(ks)
        varied = [k for k in ks if self.enters_jacobian(k)] or [self.kw]
        S = float(wf @ (self._linearized(base, p, varied[0], flip)[1] @ vf))
        h = self.fd_step * max(float(np.max(np.abs(base), initial=0.0)), 1e-6) / max(float(np.max(np.abs(vf))), 1e-300)
        S_u = None
        S_p = np.zeros(len(ks))
        for k in varied:
            prob = self._problem(p, k, flip)
            _, Jp, Jlp = prob.linearize(base + h * vf, float(p[k]))
            _, Jm, Jlm = prob.linearize(base - h * vf, float(p[k]))
            if S_u is None:
                S_u = (wf @ Jp - wf @ Jm) / (2.0 * h)
            if k in ks:  # d/dp (w^T Mx v) = D_v (w^T dR/dp) by the symmetry of second derivatives
                S_p[ks.index(k)] = float(wf @ (Jlp - Jlm)) / (2.0 * h)
        return S, (S_u[self.embed_idx] if flip else S_u), S_p

    def linearize_at(self, u: np.ndarray, p: np.ndarray, ks=()):
        """Residual, Jacobian and parameter derivatives at a full parameter vector.

        Parameters
        ----------
        u : ndarray, shape (m,)
        p : ndarray, shape (P,)
        ks : sequence of int
            Parameter indices to differentiate by.

        Returns
        -------
        R : ndarray, shape (m,)
        J : ndarray, shape (m, m)
        dR : ndarray, shape (len(ks), m)
            ``dR/dp_k`` (analytic, as in :meth:`HarmonicBalance.linearize`).
        """
        if self.resolved:
            ks = tuple(ks)
            R, J, Jl = self._linearized(np.asarray(u, float), p, ks[0] if ks else self.kw, False)
            dR = np.zeros((len(ks), self.size))
            for i, k in enumerate(ks):
                dR[i] = Jl if i == 0 else self._linearized(np.asarray(u, float), p, k, False)[2]
            return R.copy(), J.copy(), dR
        model, n, H, nu, kw = self.model, self.n, self.H, self.nu, self.kw
        M, C, K = model.linear(p)
        Om = self.hb.base_frequency(p)
        J = np.zeros((self.size, self.size))
        linear_operator(M, C, K, Om, H, J, False)
        U = np.ascontiguousarray(coefficient_blocks(u, n))
        fe = np.zeros((self.N, n))
        for el in model.excitations:
            el.evaluate(self.tau, p, fe)
        R = J @ u - aft.project(fe, H).reshape(-1)
        dR = np.zeros((len(ks), self.size))
        for i, k in enumerate(ks):
            dM, dC, dK = model.linear_dp(p, k)
            d = linear_apply(dM, dC, dK, Om, U)
            if k == kw:
                d += linear_apply(2.0 * Om * M, C, np.zeros_like(K), 1.0, U) / nu
            dfe = np.zeros((self.N, n))
            for el in model.excitations:
                if el.depends_on(k):
                    el.evaluate_dp(self.tau, p, k, dfe)
            dR[i] = d.reshape(-1) - aft.project(dfe, H).reshape(-1)
        if model.forces:
            x, xd, xp = self._samples(u, p)
            f, fx, fxd = self._forces(x, xd, self.tau, p)
            aft.assemble_jacobian(fx, fxd, Om, H, J)
            R += aft.project(f, H).reshape(-1)
            for i, k in enumerate(ks):
                dfdp = np.zeros((self.N, n))
                for el in model.forces:
                    if el.depends_on(k):
                        el.evaluate_dp(x, xd, self.tau, p, k, dfdp)
                if k == kw:
                    dfdp += aft.matvec_samples(fxd, xp) / nu
                if np.any(dfdp):
                    dR[i] += aft.project(dfdp, H).reshape(-1)
        return R, J, dR

    def flip_matrix(self, u: np.ndarray, p: np.ndarray) -> np.ndarray:
        """The flip matrix: odd-harmonic block of the order-``2 nu`` Jacobian.

        Equal to the rows and columns :func:`flip_indices` of the Jacobian of
        ``hb.with_options(subharmonic=2 nu, harmonics=2H, samples=2N)`` at the
        embedded solution (:func:`contin.hb.harmonics.embed`), computed on the
        order-``nu`` samples (:func:`contin.hb.aft.odd_jacobian`). At an
        order-``nu`` solution the order-``2 nu`` Jacobian is block diagonal
        (even, odd); the odd block is singular exactly when the truncated
        problem has a ``2T``-periodic neutral perturbation, i.e. a Floquet
        multiplier -1 (Hill's determinant at ``s = i w/(2 nu)``).

        Returns
        -------
        ndarray, shape (2nH, 2nH)
        """
        if self.resolved:
            J2 = self._linearized(self._embedded(u), p, self.kw, True)[1]
            return J2[np.ix_(self.flip_idx, self.flip_idx)]
        M, C, K = self.model.linear(p)
        Om2 = self.hb.base_frequency(p) / 2  # the base frequency of the order-2nu problem
        n = self.n
        B = np.zeros((self.flip_size, self.flip_size))
        for i in range(self.H):
            k = 2 * i + 1
            D = K - (k * Om2) ** 2 * M
            G = k * Om2 * C
            rc, rs = 2 * i * n, (2 * i + 1) * n
            B[rc:rc + n, rc:rc + n] = D
            B[rs:rs + n, rs:rs + n] = D
            B[rc:rc + n, rs:rs + n] = G
            B[rs:rs + n, rc:rc + n] = -G
        if self.model.forces:
            x, xd, _ = self._samples(u, p)
            _, fx, fxd = self._forces(x, xd, self.tau, p)
            aft.odd_jacobian(fx, fxd, Om2, self.H, B)
        return B

    def enters_jacobian(self, k: int) -> bool:
        """Whether parameter ``k`` can change ``J`` (and ``B``): the frequency, a
        parameter of the linear matrices or of a force element (not one that
        enters only the excitation)."""
        m = self.model
        if k == self.kw:
            return True
        if any(t[0].depends_on(k) for mat in (m.mass, m.damping, m.stiffness) for t in mat.terms):
            return True
        return any(el.depends_on(k) for el in m.forces)

    # ------------------------------------------------------------ S = w^T Mx v
    def _directions(self, v, w, kind: MatrixKind, p):
        """Sampled ``V``, ``Vd``, ``W`` on the grid of ``kind`` and the linear part ``w^T A v``."""
        n = self.n
        M, C, K = self.model.linear(p)
        if kind is MatrixKind.JACOBIAN:
            Hq, Nq, Omq = self.H, self.N, self.hb.base_frequency(p)
            vf, wf = v, w
        else:
            Hq, Nq, Omq = 2 * self.H, 2 * self.N, self.hb.base_frequency(p) / 2
            vf = np.zeros(n * (2 * Hq + 1))
            wf = np.zeros(n * (2 * Hq + 1))
            vf[self.flip_idx] = v
            wf[self.flip_idx] = w
        Vb = np.ascontiguousarray(coefficient_blocks(vf, n))
        V, Vp = aft.synthesize(Vb, Nq)
        Wt = coefficient_blocks(wf, n).copy()
        Wt[1:] *= 2.0
        W = aft.synthesize(np.ascontiguousarray(Wt), Nq)[0] / Nq
        lin = float(wf @ linear_apply(M, C, K, Omq, Vb).reshape(-1))
        return V, Omq * Vp, W, lin

    def _state(self, u, p, kind):
        x, xd, _ = self._samples(u, p)
        if kind is MatrixKind.JACOBIAN:
            return x, xd, self.tau
        return np.concatenate([x, x]), np.concatenate([xd, xd]), self.tau2

    def form(self, u, p, v, w, kind: MatrixKind | str) -> float:
        """``S = w^T Mx(u, p) v`` from samples (no matrix is formed)."""
        kind = MatrixKind(kind)
        if self.resolved:
            return float(w @ (self.linearize_at(u, p)[1] if kind is MatrixKind.JACOBIAN else self.flip_matrix(u, p)) @ v)
        V, Vd, W, lin = self._directions(v, w, kind, p)
        if not self.model.forces:
            return lin
        x, xd, tau = self._state(u, p, kind)
        _, fx, fxd = self._forces(x, xd, tau, p)
        return lin + _contract(W, fx, V) + _contract(W, fxd, Vd)

    def bilinear(self, u: np.ndarray, p: np.ndarray, v: np.ndarray, w: np.ndarray, kind: MatrixKind | str,
                 ks=()):
        """``S = w^T Mx v``, its gradient in ``u`` and its parameter derivatives.

        Parameters
        ----------
        u : ndarray, shape (m,)
            Order-``nu`` coefficients.
        p : ndarray, shape (P,)
        v, w : ndarray
            Shape (m,) for ``JACOBIAN``, (2nH,) for ``FLIP``.
        kind : MatrixKind
        ks : sequence of int
            Parameters to differentiate by.

        Returns
        -------
        S : float
        S_u : ndarray, shape (m,)
            ``dS/du`` (central difference of the sample Jacobians along the
            sampled ``v``: see the module docstring).
        S_p : ndarray, shape (len(ks),)
            ``dS/dp_k`` (central differences of ``S``).
        """
        kind = MatrixKind(kind)
        if self.resolved:
            return self._resolved_bilinear(u, p, v, w, kind, ks)
        n, N, H = self.n, self.N, self.H
        V, Vd, W, lin = self._directions(v, w, kind, p)
        S_u = np.zeros(self.size)
        S = lin
        if self.model.forces:
            x, xd, tau = self._state(u, p, kind)
            _, fx, fxd = self._forces(x, xd, tau, p)
            S += _contract(W, fx, V) + _contract(W, fxd, Vd)
            sx = max(float(np.max(np.abs(x), initial=0.0)), float(np.max(np.abs(xd), initial=0.0)), 1e-6)
            sv = max(float(np.max(np.abs(V), initial=0.0)), float(np.max(np.abs(Vd), initial=0.0)))
            if sv > 0:
                h = self.fd_step * sx / sv
                _, fxp, fxdp = self._forces(x + h * V, xd + h * Vd, tau, p)
                _, fxm, fxdm = self._forces(x - h * V, xd - h * Vd, tau, p)
                s = _limited_difference(W, fxp, fx, fxm, h)
                t = _limited_difference(W, fxdp, fxd, fxdm, h)
                if kind is MatrixKind.FLIP:
                    s = s[:N] + s[N:]
                    t = t[:N] + t[N:]
                Om = self.hb.base_frequency(p)
                Fs = np.fft.rfft(s, axis=0)
                Ft = np.fft.rfft(t, axis=0)
                G = np.zeros((2 * H + 1, n))
                G[0] = Fs[0].real
                k = np.arange(1, H + 1)[:, None]
                G[1::2] = Fs[1:H + 1].real + Om * k * Ft[1:H + 1].imag
                G[2::2] = -Fs[1:H + 1].imag + Om * k * Ft[1:H + 1].real
                S_u = G.reshape(-1)
        S_p = np.zeros(len(ks))
        for i, k in enumerate(ks):
            if not self.enters_jacobian(k):
                continue  # e.g. a force amplitude: it enters R only through the excitation
            hp = self.fd_step * max(1.0, abs(float(p[k])))
            pp, pm = p.copy(), p.copy()
            pp[k] += hp
            pm[k] -= hp
            S_p[i] = (self.form(u, pp, v, w, kind) - self.form(u, pm, v, w, kind)) / (2 * hp)
        return S, S_u, S_p
