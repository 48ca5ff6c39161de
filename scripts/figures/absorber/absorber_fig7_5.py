"""Seed 000, Fig. 7-5: |X1|/delta_st against Omega = w/p for beta = 0.05, mu = 1 and several dampings.

Each curve is the impedance-matrix response (contin.modal.modes.frf) of the two-mass system
m1 = 1, k1 = 1, m2 = beta, k2 = m2 (mu p)^2, c = 2 m2 p zeta, with zeta = c/(2 m2 p)
referred to the MAIN system (seed 000, sec. 7.3). All curves cross at the fixed points P
and Q (seed 000, sec. 7.4), whatever the damping; the script measures how closely they
do. It adds the optimal design (mu_opt = 1/(1+beta), zeta_opt = sqrt(3 beta/(8(1+beta)^3)))
with its own fixed points at sqrt((2+beta)/beta) and its true peak, slightly above them.

    python scripts/figures/absorber/absorber_fig7_5.py [--quick] [--out absorber_fig7_5.png]
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np

from contin.modal.absorber import fixed_points, optimal_damping, optimal_tuning, true_peak
from contin.util.blas import limit_blas_threads
from contin.modal.modes import chain_matrices, frf

BETA, MU, ZETAS = 0.05, 1.0, (0.001, 0.1, 0.3)


def X1(beta, mu, zeta, Omega):
    """|X1|/delta_st from Z(w) with m1 = k1 = 1 (p = 1, delta_st = F = 1)."""
    m2 = beta
    M, C, K = chain_matrices([1.0, m2], [1.0, m2 * mu**2, 0.0], [0.0, 2 * m2 * zeta, 0.0])
    return np.abs(frf(M, C, K, Omega, [1.0, 0.0])[:, 0])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="a coarse grid (CI)")
    ap.add_argument("--out", type=Path, default=Path("absorber_fig7_5.png"))
    args = ap.parse_args()
    limit_blas_threads()
    Omega = np.linspace(0.6, 1.4, 400 if args.quick else 8000)
    (OP, OQ), (hP, hQ) = fixed_points(BETA, MU)
    print(f"beta = {BETA}, mu = {MU}: fixed points P at Omega = {OP:.6f} (|X1|/delta_st = {hP:.6f}), "
          f"Q at Omega = {OQ:.6f} ({hQ:.6f})")
    zs = ZETAS + (0.0, 0.03, 1.0, 10.0)
    at = np.array([X1(BETA, MU, z, np.array([OP, OQ])) for z in zs])
    dev = np.max(np.abs(at - [hP, hQ]) / [hP, hQ])
    print(f"|X1| at P and Q for zeta in {list(zs)}: largest relative spread {dev:.1e} (independent of c)")
    mo, zo = optimal_tuning(BETA), optimal_damping(BETA)
    (oP, oQ), (h1, h2) = fixed_points(BETA, mo)
    Op, hp = true_peak(BETA, mo, zo)
    print(f"optimal design: mu = 1/(1+beta) = {mo:.6f}, zeta = {zo:.6f} (zeta_a = zeta/mu = {zo / mo:.6f}); "
          f"fixed points at {h1:.6f} = sqrt((2+beta)/beta) = {math.sqrt((2 + BETA) / BETA):.6f}; "
          f"true peak {hp:.6f} at Omega = {Op:.6f} ({100 * (hp / h1 - 1):.3f} % above)")

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7.2, 4.8), constrained_layout=True)
    for z in ZETAS:
        ax.plot(Omega, X1(BETA, MU, z, Omega), lw=1.2, label=f"zeta = {z:g}")
    ax.plot([OP, OQ], [hP, hQ], "ko", mfc="none", ms=8)
    for O, h, name in ((OP, hP, "P"), (OQ, hQ, "Q")):
        ax.annotate(name, (O, h), textcoords="offset points", xytext=(6, 6), fontsize=11)
    ax.plot(Omega, X1(BETA, mo, zo, Omega), "k-", lw=2.0,
            label=f"optimal: mu = {mo:.4f}, zeta = {zo:.4f}")
    ax.plot([oP, oQ], [h1, h2], "ks", ms=5, label=f"its fixed points ({h1:.4f})")
    ax.plot([Op], [hp], "r^", ms=7, label=f"its true peak ({hp:.4f})")
    ax.set_ylim(0, 20)
    ax.set_xlabel(r"$\Omega = \omega / p$")
    ax.set_ylabel(r"$|X_1| / \delta_{\mathrm{st}}$")
    ax.set_title(f"seed 000, Fig. 7-5: beta = m2/m1 = {BETA}, mu = p_a/p = {MU}; zeta = c/(2 m2 p)")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    fig.savefig(args.out, dpi=120)
    print(f"figure: {args.out}")


if __name__ == "__main__":
    main()
