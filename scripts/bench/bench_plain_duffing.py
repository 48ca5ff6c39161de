"""The forced Duffing branch and its stability in plain numpy: the script a user would write without contin.

    x'' + c x' + k x + g x^3 = F cos(w t),   c = 0.1, k = g = 1, F = 0.5,   w from 0.5 to 3

Harmonic balance with ``H`` harmonics (``x = a0 + sum a_j cos(j w t) + b_j sin(j w t)``), the cubic force
by alternating frequency and time on ``N = 4H + 1`` samples (dense trigonometric matrices), pseudo-arclength
continuation with a secant predictor and a step adapted to Newton's iterations, and stability at every point
by Hill's method (the quadratic eigenvalue problem of the perturbation's ``2H + 1`` complex harmonics in
companion form; the two exponents of smallest imaginary part are the Floquet exponents). It writes one line
per point, ``w, amplitude, stable``, to ``--out`` (or stdout), and is the reference process that
``bench_process.py`` times contin's command line against (the scene ``duffing`` at ``H = 5``, Hill
stability, no figure).

    python scripts/bench/bench_plain_duffing.py [--harmonics 5] [--out FILE]
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

C, K, G, F = 0.1, 1.0, 1.0, 0.5
W0, W1 = 0.5, 3.0


def trig(H: int, N: int):
    """Synthesis ``E`` (N, 2H+1) and analysis ``A`` (2H+1, N): ``x = E U``, ``U = A x``."""
    t = 2 * np.pi * np.arange(N) / N
    E = np.ones((N, 2 * H + 1))
    for j in range(1, H + 1):
        E[:, 2 * j - 1] = np.cos(j * t)
        E[:, 2 * j] = np.sin(j * t)
    A = E.T * (2.0 / N)
    A[0] /= 2.0
    return E, A


def linear(H: int, w: float):
    """The linear part's matrix and its derivative in ``w``."""
    L = np.zeros((2 * H + 1, 2 * H + 1))
    dL = np.zeros_like(L)
    L[0, 0] = K
    for j in range(1, H + 1):
        a, b = 2 * j - 1, 2 * j
        L[a, a] = L[b, b] = K - (j * w) ** 2
        L[a, b], L[b, a] = C * j * w, -C * j * w
        dL[a, a] = dL[b, b] = -2 * j * j * w
        dL[a, b], dL[b, a] = C * j, -C * j
    return L, dL


def residual(U, w, E, A, H):
    """``R`` (2H+1,), ``dR/dU`` and ``dR/dw``."""
    L, dL = linear(H, w)
    x = E @ U
    R = L @ U + A @ (G * x ** 3)
    R[1] -= F
    J = L + A @ (3 * G * x[:, None] ** 2 * E)
    return R, J, dL @ U


def newton(U, w, t, x0, ds, E, A, H, tol=1e-10, max_iter=10):
    """Newton on ``R = 0`` and the arclength condition; the point and the number of iterations, or None."""
    z = np.append(U, w)
    for it in range(max_iter):
        R, J, Jw = residual(z[:-1], z[-1], E, A, H)
        F_ = np.append(R, t @ (z - x0) - ds)
        if np.max(np.abs(F_)) < tol:
            return z, it
        M = np.vstack([np.column_stack([J, Jw]), t])
        z = z - np.linalg.solve(M, F_)
    return None, max_iter


def hill_stable(U, w, E, A, H) -> bool:
    """Stability by Hill's method: the Floquet exponents of the two eigenvalues with smallest imaginary part."""
    x = E @ U
    n = 2 * H + 1
    # complex Fourier coefficients of 3 g x^2 up to 2H
    c = np.fft.fft(3 * G * x ** 2) / x.size
    k = np.arange(-H, H + 1)
    S = c[(k[:, None] - k[None, :]) % x.size]
    D1 = C * np.eye(n) + 2j * w * np.diag(k)
    D0 = K * np.eye(n) - np.diag((k * w) ** 2) + 1j * C * w * np.diag(k) + S
    comp = np.block([[np.zeros((n, n)), np.eye(n)], [-D0, -D1]])
    lam = np.linalg.eigvals(comp)
    floquet = lam[np.argsort(np.abs(lam.imag))[:2]]
    return bool(np.all(floquet.real < 0))


def branch(H: int):
    """The points ``(w, amplitude, stable)`` from ``w = 0.5`` to 3."""
    N = 4 * H + 1
    E, A = trig(H, N)
    U = np.zeros(2 * H + 1)
    z0 = np.append(U, W0)
    for _ in range(50):  # the first point at fixed w
        R, J, _ = residual(z0[:-1], W0, E, A, H)
        if np.max(np.abs(R)) < 1e-12:
            break
        z0[:-1] -= np.linalg.solve(J, R)
    t = np.zeros(2 * H + 2)
    t[-1] = 1.0
    ds, out = 0.02, []
    z = z0
    while W0 <= z[-1] <= W1:
        x = E @ z[:-1]
        out.append((z[-1], 0.5 * (x.max() - x.min()), hill_stable(z[:-1], z[-1], E, A, H)))
        while True:
            new, it = newton(z[:-1] + ds * t[:-1], z[-1] + ds * t[-1], t, z, ds, E, A, H)
            if new is not None:
                break
            ds *= 0.5
            if ds < 1e-8:
                raise SystemExit(f"step too small at w = {z[-1]}")
        t = (new - z) / np.linalg.norm(new - z)
        z = new
        ds = min(0.1, ds * (1.5 if it <= 3 else 0.7))
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--harmonics", type=int, default=5)
    ap.add_argument("--out", default=None)
    ap.add_argument("--quick", action="store_true", help="the same (the branch takes a fraction of a second)")
    args = ap.parse_args(argv)
    rows = branch(args.harmonics)
    text = "w,amplitude,stable\n" + "".join(f"{w:.10g},{a:.10g},{int(s)}\n" for w, a, s in rows)
    if args.out:
        with open(args.out, "w") as f:
            f.write(text)
    else:
        sys.stdout.write(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
