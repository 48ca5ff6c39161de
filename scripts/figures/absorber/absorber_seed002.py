"""Seed 002, sec. 6.3.3: the main system's response with an absorber of mass ratio 1/20 tuned to alpha = 1.

Seed 002 writes mu = m2/m1 for the mass ratio and alpha = w2/w1 for the tuning (here beta and
mu as in seed 000), and zeta = c/(2 m2 w1). The curves zeta = 0, 0.1, 0.32 and infinity all
pass through the points S and T. The undamped absorber resonates at lambda = 0.895 and 1.12
and holds the main mass still at lambda = 1 (w = w_a); with zeta -> infinity the masses move
together, resonant at lambda = 1/sqrt(1 + mu) = 0.976. The script prints these from
contin.modal.absorber and checks them against the impedance-matrix solve (contin.modal.modes).

    python scripts/figures/absorber/absorber_seed002.py [--quick] [--out absorber_seed002.png]
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np

from contin.modal.absorber import amplification, fixed_points, undamped_resonances
from contin.util.blas import limit_blas_threads
from contin.modal.modes import chain_matrices, frf, natural_modes

BETA, MU, ZETAS = 1 / 20, 1.0, (0.0, 0.1, 0.32, math.inf)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="a coarse grid (CI)")
    ap.add_argument("--out", type=Path, default=Path("absorber_seed002.png"))
    args = ap.parse_args()
    limit_blas_threads()
    l1, l2 = undamped_resonances(BETA, MU)
    M, _, K = chain_matrices([1.0, BETA], [1.0, BETA * MU**2, 0.0])
    w12 = natural_modes(M, K).omega
    print(f"undamped absorber: resonances at lambda = {l1:.6f} and {l2:.6f} (seed: 0.895, 1.12); "
          f"eigenvalues of (K, M): {w12[0]:.6f}, {w12[1]:.6f}")
    X = frf(M, np.zeros((2, 2)), K, [MU], [1.0, 0.0])[0]
    print(f"anti-resonance at lambda = alpha = {MU}: |X1| = {abs(X[0]):.1e}, X2 = {X[1].real:.6f} "
          f"(-F1/k2 = {-1 / (BETA * MU**2):.6f})")
    print(f"rigid joint (zeta -> inf): resonance at lambda = 1/sqrt(1 + mu) = {1 / math.sqrt(1 + BETA):.6f} "
          f"(seed: 0.976)")
    (OS, OT), (hS, hT) = fixed_points(BETA, MU)
    print(f"fixed points S at lambda = {OS:.6f} (|X1|/x_st = {hS:.6f}), T at lambda = {OT:.6f} ({hT:.6f})")
    for z in ZETAS[1:3]:
        Mc, Cc, Kc = chain_matrices([1.0, BETA], [1.0, BETA * MU**2, 0.0], [0.0, 2 * BETA * z, 0.0])
        a = np.abs(frf(Mc, Cc, Kc, [OS, OT], [1.0, 0.0])[:, 0])
        print(f"  zeta = {z}: |X1| at S, T from Z(w): {a[0]:.10f}, {a[1]:.10f}")

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    lam = np.linspace(0.6, 1.4, 400 if args.quick else 8000)
    fig, ax = plt.subplots(figsize=(7.2, 4.8), constrained_layout=True)
    for z in ZETAS:
        y = amplification(lam, BETA, MU, z)
        y = np.where(y < 50, y, np.nan)
        ax.plot(lam, y, lw=1.3, label="zeta = inf" if math.isinf(z) else f"zeta = {z:g}")
    ax.plot([OS, OT], [hS, hT], "ko", mfc="none", ms=8)
    for O, h, name in ((OS, hS, "S"), (OT, hT, "T")):
        ax.annotate(name, (O, h), textcoords="offset points", xytext=(6, 6), fontsize=11)
    for l in (l1, l2):
        ax.axvline(l, color="0.6", lw=0.8, ls=":")
    ax.set_ylim(0, 16)
    ax.set_xlabel(r"$\lambda = \omega / \omega_1$")
    ax.set_ylabel(r"$X_1 / x_{\mathrm{st}}$")
    ax.set_title(r"seed 002, 6.3.3: $\mu = m_2/m_1 = 1/20$, $\alpha = \omega_2/\omega_1 = 1$, $\zeta = c/(2 m_2 \omega_1)$", fontsize=10)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    fig.savefig(args.out, dpi=120)
    print(f"figure: {args.out}")


if __name__ == "__main__":
    main()
