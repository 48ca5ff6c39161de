"""Seed 002, sec. 4.3: m1 = m, m2 = 2m, k1 = k2 = k, k3 = 2k, force F0 sin(w t) on m1.

Natural frequencies w1 = sqrt(k/m), w2 = sqrt(5/2) sqrt(k/m) = 1.5811 sqrt(k/m), mode-shape
ratios r_i = u2/u1 (1 and -1/2), principal coordinates, and the forced response

    X1 = 2 F0/(5k) (3/2 - (w/w1)^2) / ([1 - (w/w1)^2][1 - (w/w2)^2]),
    X2 = F0/(5k) / ([1 - (w/w1)^2][1 - (w/w2)^2]).

The script computes them with contin.modal.modes (and the built-in linear_chain model with harmonic
balance, H = 1), prints the errors against these closed forms, and plots X1 and X2 (signed, in
units of F0/k) against w/w1 as the seed does, with the mode shapes beside them.

    python scripts/figures/two_dof/two_dof_example.py [--quick] [--out two_dof_example.png]
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np

from contin.util.blas import limit_blas_threads
from contin.model.catalog import build_model
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.modal.modes import frf, natural_modes, principal_coordinates
from contin.engine.newton import solve_at_parameter

M, K, F0 = 1.0, 1.0, 1.0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="a coarse grid (CI)")
    ap.add_argument("--out", type=Path, default=Path("two_dof_example.png"))
    args = ap.parse_args()
    limit_blas_threads()
    model = build_model("linear_chain", {"m1": M, "m2": 2 * M, "k1": K, "k2": K, "k3": 2 * K, "F1": F0},
                        effects=["forcing"])
    Mm, Cm, Km = model.linear(model.parameter_vector())
    nm = natural_modes(Mm, Km)
    w1, w2 = math.sqrt(K / M), math.sqrt(5 / 2) * math.sqrt(K / M)
    print(f"natural frequencies: {nm.omega[0]:.12f}, {nm.omega[1]:.12f} sqrt(k/m) "
          f"(seed: 1, sqrt(5/2) = {math.sqrt(2.5):.12f}); errors {abs(nm.omega[0] - w1):.1e}, "
          f"{abs(nm.omega[1] - w2):.1e}")
    print(f"mode-shape ratios r_i = u2/u1: {nm.ratios()[1, 0]:.12f}, {nm.ratios()[1, 1]:.12f} (seed: 1, -1/2)")
    pc = principal_coordinates(Mm, Cm, Km, nm)
    print("principal coordinates x = Phi q: Phi^T M Phi =", np.round(pc.modal_mass, 12).tolist(),
          ", Phi^T K Phi =", np.round(pc.modal_stiffness, 12).tolist())
    n = 150 if args.quick else 3000
    w = np.linspace(0.0, 2.5, n) + 1.234e-4  # off the resonances, where the undamped response is infinite
    X = frf(Mm, Cm, Km, w, [F0, 0.0])
    d = (1 - (w / w1) ** 2) * (1 - (w / w2) ** 2)
    X1 = 2 * F0 / (5 * K) * (1.5 - (w / w1) ** 2) / d
    X2 = F0 / (5 * K) / d
    e1 = np.max(np.abs(X[:, 0].real - X1) / np.maximum(np.abs(X1), 1e-300 + np.abs(X2)))
    e2 = np.max(np.abs(X[:, 1].real - X2) / np.abs(X2))
    print(f"impedance FRF vs closed form: max relative error X1 {e1:.1e}, X2 {e2:.1e}")
    hb = HarmonicBalance(model, "w", HBOptions(harmonics=1))
    err = 0.0
    for wi, Xi in zip(w[:: max(1, n // 60)], X[:: max(1, n // 60)]):
        u = solve_at_parameter(hb, np.zeros(hb.size), wi).x
        err = max(err, float(np.max(np.abs(u[2:4] - 1j * u[4:6] - Xi)) / np.max(np.abs(Xi))))
    print(f"harmonic balance H = 1 vs impedance FRF: max relative error {err:.1e}")

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axs = plt.subplots(1, 3, figsize=(13, 4.2), constrained_layout=True)
    for ax, Y, Yc, name in ((axs[0], X[:, 0].real, X1, "X1"), (axs[1], X[:, 1].real, X2, "X2")):
        Yp = np.where(np.abs(Y) < 4, Y, np.nan)
        ax.plot(w / w1, Yp * K / F0, lw=1.5, label="impedance solve")
        ax.plot(w[::25] / w1, np.where(np.abs(Yc[::25]) < 4, Yc[::25], np.nan) * K / F0, "k.", ms=3,
                label="seed 002 closed form")
        for om in (1.0, w2 / w1):
            ax.axvline(om, color="0.6", lw=0.8, ls=":")
        ax.axhline(0, color="0.5", lw=0.6)
        ax.set_xlabel(r"$\omega / \omega_1$,  $\omega_1 = \sqrt{k/m}$")
        ax.set_ylabel(f"${name[0]}_{name[1]}$ / $(F_0/k)$")
        ax.set_title(f"({'ab'[name == 'X2']}) {name}(w)")
        ax.set_ylim(-4, 4)
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8)
    for j in range(2):
        shape = nm.modes[:, j] / nm.modes[0, j]
        axs[2].plot([1, 2], shape, "o-", label=f"mode {j + 1}: w = {nm.omega[j]:.4f} sqrt(k/m), r = {shape[1]:.3g}")
    axs[2].axhline(0, color="0.5", lw=0.6)
    axs[2].set_xticks([1, 2])
    axs[2].set_xticklabels(["x1", "x2"])
    axs[2].set_title(r"mode shapes $[1, r_i]$")
    axs[2].legend(fontsize=8)
    axs[2].grid(True, alpha=0.3)
    fig.suptitle("seed 002, sec. 4.3: m1 = m, m2 = 2m, k1 = k2 = k, k3 = 2k")
    fig.savefig(args.out, dpi=110)
    print(f"figure: {args.out}")


if __name__ == "__main__":
    main()
