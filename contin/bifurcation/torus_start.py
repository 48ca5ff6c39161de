"""Switching at a Neimark-Sacker point: the first point of a quasi-periodic (torus) branch.

At a Neimark-Sacker point of a periodic branch (base frequency
``Omega = w/nu``) a pair of Floquet multipliers ``exp(+-i theta)`` crosses
the unit circle; the exponent ``s = i omega_c`` and Hill's eigenvector
``y(theta1)`` give the critical perturbation

    dx(t) = Re( e^{i omega_c t} y(Omega t) ) = Re( sum_k c_k e^{i (omega_c + k Omega) t} ),

a ring of lines around the self-excited frequency. The second base frequency
of the torus is the line of the largest ``|c_k|``, ``w2 = |omega_c + k* Omega|``
(the exponent is fixed only modulo ``Omega``; the eigenvector decides), and
the lines sit on the pairs ``(k - k*, 1)`` of :mod:`contin.hb.qp_basis`
(Kuznetsov, Elements of Applied Bifurcation Theory, 3rd ed., sec. 4.7 for
the bifurcation; the torus grows like ``sqrt(lambda - lambda_ns)``).

The first point solves the quasi-periodic balance with the amplitude of the
pinned line fixed, ``a_{j*, i*} = eps`` (its sine is the phase condition),
and ``lambda`` free: the amplitude, not the parameter, is what is known on
which side the torus lies. The tangent there points away from the
periodic branch (growing ``a_{j*, i*}``).
"""

from __future__ import annotations

import math

import numpy as np

from contin.bifurcation.switching import BranchStart, extended_nullvector
from contin.engine.branch import Branch, SpecialKind, SpecialPoint
from contin.engine.newton import newton
from contin.hb.torus import QuasiPeriodicBalance, TorusOptions
from contin.stability.hill import hill_spectrum

__all__ = ["critical_mode", "torus_start"]


def critical_mode(hb, u: np.ndarray, lam: float, multiplier: complex | None = None):
    """The Neimark-Sacker mode of a periodic solution on the torus pairs.

    Parameters
    ----------
    hb : HarmonicBalance (or a condensed one)
    u : ndarray, shape (hb.size,)
    lam : float
    multiplier : complex, optional
        The critical multiplier as the stability monitor found it (the Hill
        exponent nearest to it is taken); default the complex exponent of
        largest real part.

    Returns
    -------
    w2 : float
        The second base frequency, > 0.
    lines : dict of int to ndarray, shape (n,) complex
        ``k -> d_k``: the perturbation is ``Re(sum_k d_k e^{i (w2 + k Omega) t})``,
        the line ``k`` on the pair ``(k, 1)``; ``d_0`` the strongest.
    """
    spec = hill_spectrum(hb, u, lam, vectors=True)
    ex = spec.exponents
    cand = np.flatnonzero(np.abs(ex.imag) > 1e-9 * spec.Omega)
    if not cand.size:
        raise ValueError("no complex Floquet exponent at this point: not a Neimark-Sacker point")
    if multiplier is not None and np.isfinite(multiplier):
        j = cand[np.argmin(np.abs(spec.multipliers[cand] - multiplier))]
    else:
        j = cand[np.argmax(ex[cand].real)]
    n = hb.full.n
    Q = spec.vectors[:, j].reshape(-1, n)
    H = (Q.shape[0] - 1) // 2
    c = {0: Q[0].astype(complex)}
    for k in range(1, H + 1):
        c[k] = 0.5 * (Q[2 * k - 1] - 1j * Q[2 * k])
        c[-k] = 0.5 * (Q[2 * k - 1] + 1j * Q[2 * k])
    kstar = max(c, key=lambda k: np.linalg.norm(c[k]))
    w2 = float(ex[j].imag) + kstar * spec.Omega
    lines = {k - kstar: v for k, v in c.items()}
    if w2 < 0:  # Re(z) = Re(conj z): the same motion seen with the opposite frequency
        w2 = -w2
        lines = {-k: np.conj(v) for k, v in lines.items()}
    return w2, lines


def _perturbation(qp: QuasiPeriodicBalance, lines: dict, dof: int) -> np.ndarray:
    """The lines as torus coefficients, shape (rows, n), scaled so that the pinned line's cosine is 1 and its
    sine 0."""
    rot = np.exp(-1j * np.angle(lines[0][dof])) / abs(lines[0][dof])
    out = np.zeros((qp.basis.rows, qp.n))
    for k, d in lines.items():
        try:
            j, sign = qp.basis.pair(k, 1)
        except KeyError:
            continue  # beyond H1: dropped
        d = d * rot
        # Re(d e^{i phi}) = Re(d) cos(phi) - Im(d) sin(phi); stored as (-k, -1) the sine flips
        out[2 * j - 1] += d.real
        out[2 * j] += -sign * d.imag
    return out


def torus_start(problem, branch: Branch, point: SpecialPoint, options: TorusOptions, *,
                eps: float | None = None, tol: float = 1e-10, retries: int = 4) -> BranchStart | None:
    """First point of the torus branch at a Neimark-Sacker point.

    Parameters
    ----------
    problem : HarmonicBalance (or a condensed one)
        The periodic branch's problem.
    branch : Branch
    point : SpecialPoint
        Of kind ``ns`` (or a ``stability`` point classified ``ns``).
    options : TorusOptions
        Harmonics and grid of the torus (its ``subharmonic`` is taken from
        ``problem``).
    eps : float, optional
        Amplitude of the self-excited line at the first point; default 2 %
        of the largest harmonic amplitude of the periodic solution. Halved up
        to ``retries`` times when Newton fails.
    tol : float
        Newton tolerance on the residual.

    Returns
    -------
    BranchStart or None
        Kind ``ns``; ``problem`` is the :class:`QuasiPeriodicBalance`, ``u``
        its unknowns ``(coefficients, w2)``. None if Newton failed for every
        ``eps``.
    """
    hb = problem.full
    u_star = np.asarray(point.unknowns, dtype=float)
    if problem.condensed:
        u_star = problem.expand(u_star, float(point.parameter))
    lam_star = float(point.parameter)
    w2, lines = critical_mode(hb, u_star, lam_star, point.data.get("multiplier"))
    dof = int(np.argmax(np.abs(lines[0])))
    opts = TorusOptions(options.harmonics, options.harmonics2, options.samples, options.samples2, hb.nu)
    qp = QuasiPeriodicBalance(hb.model, hb.parameter, opts, hb.parameters(), hb.frequency, pin=(1, dof))
    # the periodic solution in the torus' own truncation and grid first: a start that is no solution of the
    # pairs (k, 0) would leave Newton fighting the truncation instead of finding the torus
    hp = qp.periodic
    up = np.asarray(u_star, dtype=float).reshape(-1, qp.n)[: 2 * qp.H1 + 1]
    up = np.vstack([up, np.zeros((2 * qp.H1 + 1 - up.shape[0], qp.n))]).reshape(-1)
    per = newton(lambda x: hp.linearize(x, lam_star)[:2], up, tol, 30, backtrack=4)
    if per.converged:
        up = per.x
    base = np.append(qp.basis.embed_periodic(up, qp.n), w2)
    phi = np.append(_perturbation(qp, lines, dof).reshape(-1), 0.0)
    ia = qp.n + dof  # the cosine of the pinned line, pair 1 = (0, 1)
    if eps is None:
        eps = 0.02 * float(np.max(np.abs(u_star)))
    m = qp.m
    for _ in range(retries + 1):
        def fun(x, e=eps):
            R, Ju, Jlam = qp.linearize(x[:m], x[m])
            F = np.append(R, x[ia] - e)
            A = np.zeros((m + 1, m + 1))
            A[:m, :m] = Ju
            A[:m, m] = Jlam
            A[m, ia] = 1.0
            return F, A

        res = newton(fun, np.append(base + eps * phi, lam_star), tol, 30, backtrack=4)
        if res.converged and math.isfinite(res.x[m]) and res.x[m - 1] > 0:
            u, lam = res.x[:m].copy(), float(res.x[m])
            t = extended_nullvector(qp, u, lam)
            if t[ia] < 0:
                t = -t
            return BranchStart(problem=qp, u=u, lam=lam, tangent=t, kind=SpecialKind.NS, direction=phi, eps=eps,
                               side=1, bifurcation=(base, lam_star), newton_iterations=res.iterations,
                               residual_norm=res.residual_norm)
        eps *= 0.5
    return None


def torus_from_record(problem: QuasiPeriodicBalance, t: np.ndarray, x: np.ndarray, w2: float) -> np.ndarray:
    """A torus' unknowns fitted to a simulated quasi-periodic record (a start away from any NS point).

    The record is projected by least squares on the torus' own lines
    ``cos, sin((k1 w/nu + k2 w2) t)`` (the frequencies measured, e.g. by
    :func:`contin.timedomain.spectral_lines.spectral_lines`), then shifted in
    ``theta2`` so that the phase condition holds.

    Parameters
    ----------
    problem : QuasiPeriodicBalance
        Its parameters are those of the simulation (``w`` included).
    t : ndarray, shape (K,)
        Times, with the forcing phase ``tau = w t``; ``K`` well above ``2P``.
    x : ndarray, shape (K, n)
        Displacements.
    w2 : float
        The second frequency.

    Returns
    -------
    ndarray, shape (problem.m,)
    """
    qp = problem
    Omega1 = qp.base_frequency(qp.p0)
    f = qp.basis.frequencies(Omega1, w2)[1:]
    ph = np.outer(t, f)
    E = np.concatenate([np.ones((t.size, 1)), np.cos(ph), np.sin(ph)], axis=1)
    # lines closer than the record's resolution cannot be told apart: a truncated pseudo-inverse keeps
    # their sum and not an arbitrary split of it (Newton sorts them out)
    coef, *_ = np.linalg.lstsq(E, x, rcond=1e-6)
    P = qp.basis.P
    U = np.zeros((qp.basis.rows, qp.n))
    U[0], U[1::2], U[2::2] = coef[0], coef[1:P], coef[P:]
    # theta2 -> theta2 + phi turns pair j by k2_j phi: choose phi so the pinned line's sine vanishes
    j, i = qp.pin
    phi = np.arctan2(U[2 * j, i], U[2 * j - 1, i]) / qp.basis.pairs[j, 1]
    k2 = qp.basis.pairs[1:, 1]
    c, s = np.cos(k2 * phi)[:, None], np.sin(k2 * phi)[:, None]
    A, B = U[1::2].copy(), U[2::2].copy()
    U[1::2], U[2::2] = A * c + B * s, -A * s + B * c
    return np.append(U.ravel(), w2)
