"""Figures 2 and 3 of the timing-belt paper: natural frequencies against beta, and mode shapes.

Linear modes about the static equilibrium (alpha = 0.005, xi1 = 0.4, no magnet,
p_s = p_d = 0, n = 5 terms): the tangent stiffness is the Jacobian ``Ju`` of the
H = 0 harmonic balance (the static residual) at the equilibrium, the mass
matrix the model's ``M``, and ``scipy.linalg.eigh(Ju, M)`` gives ``omega^2`` and
the shapes ``sum_p phi_p sin(p pi xi)``, scaled to a largest displacement of 1
(paper Fig. 3).

Checks printed beside the figures: at beta = 0 the frequencies are ``j pi``; the
fifth mode has a node at the rotor (sin(5 pi 0.4) = 0) and keeps ``5 pi`` for
every beta; the Galerkin values come down towards the exact frequencies of the
string with a point mass, ``sin w = beta w sin(w xi1) sin(w (1 - xi1))``, as
terms are added. Writes ``belt_fig2_frequencies.png`` and ``belt_fig3_modes.png``.

    python scripts/figures/belt/belt_modes.py [--quick] [--out DIR]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import scipy.linalg

from contin.modal.equilibrium import static_equilibrium
from contin.util.blas import limit_blas_threads
from contin.model.catalog import build_model
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.models.timing_belt import shape_values, string_mass_frequencies


def modes(beta, n=5, **params):
    """``(omega, shapes)``: frequencies (n,) and mode shapes on ``xi`` (201, n), largest displacement 1."""
    model = build_model("timing_belt", {"beta": beta, "terms": n, "alpha": 0.005, "xi1": 0.4, **params},
                        ["rotor_mass", "stretching"])
    x0 = static_equilibrium(model)
    hb = HarmonicBalance(model, "w", HBOptions(harmonics=0))
    _, Ju, _ = hb.linearize(x0, float(hb.p0[hb.k]))
    M = model.linear(model.parameter_vector())[0]
    lam, phi = scipy.linalg.eigh(Ju, M)
    xi = np.linspace(0.0, 1.0, 201)
    Z = shape_values(n, xi) @ phi
    idx = np.argmax(np.abs(Z), axis=0)
    Z = Z / Z[idx, np.arange(n)]
    return np.sqrt(lam), xi, Z


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer beta values")
    ap.add_argument("--out", default="results/belt", help="output directory for the figures")
    args = ap.parse_args(argv)
    limit_blas_threads(1)  # small matrices: one BLAS thread is faster (see README)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    betas = np.linspace(0.0, 10.0, 21 if args.quick else 201)
    F = np.array([modes(b)[0] for b in betas])
    print("Fig. 2: natural frequencies (n = 5, alpha = 0.005, xi1 = 0.4, no magnet)")
    print(f"{'beta':>6} " + " ".join(f"{'mode ' + str(j):>9}" for j in range(1, 6)))
    for b in (0.0, 0.2, 0.4, 0.8, 1.0, 5.0, 10.0):
        print(f"{b:6.2f} " + " ".join(f"{w:9.5f}" for w in modes(b)[0]))
    print(f"beta = 0: omega / pi = {np.round(F[0] / np.pi, 12)}; mode 5 over all beta: "
          f"{F[:, 4].min():.12f} .. {F[:, 4].max():.12f} (5 pi = {5 * np.pi:.12f})")
    print("\nGalerkin convergence at beta = 0.2 towards the string with a point mass (exact):")
    exact = string_mass_frequencies(0.2, 0.4, 4)
    for n in (5, 10, 20, 40) if not args.quick else (5, 10):
        print(f"  n = {n:3d}: " + "  ".join(f"{w:.5f}" for w in modes(0.2, n)[0][:4]))
    print("  exact  : " + "  ".join(f"{w:.5f}" for w in exact))

    fig, ax = plt.subplots(figsize=(6.0, 4.6), constrained_layout=True)
    for j in range(5):
        ax.plot(F[:, j], betas, "-", label=f"({j + 1})")
    ax.set_xlabel(r"natural frequency $\omega$")
    ax.set_ylabel(r"mass ratio $\beta$")
    ax.set_title(r"Fig. 2: natural frequencies, $\alpha = 0.005$, $q = 0$, $\xi_1 = 0.4$")
    ax.legend(title="mode", fontsize=8)
    ax.grid(True, alpha=0.3)
    fig.savefig(out / "belt_fig2_frequencies.png", dpi=130)
    plt.close(fig)

    shown = (0.0, 0.2, 1.0, 10.0)
    fig, axs = plt.subplots(1, 3, figsize=(12, 3.6), constrained_layout=True)
    for b in shown:
        om, xi, Z = modes(b)
        for j in range(3):
            axs[j].plot(xi, Z[:, j], label=f"beta = {b:g} (w = {om[j]:.3f})")
    for j in range(3):
        axs[j].axvline(0.4, color="k", lw=0.6, ls=":")
        axs[j].set_title(f"mode {j + 1}")
        axs[j].set_xlabel(r"$\xi$")
        axs[j].legend(fontsize=7)
        axs[j].grid(True, alpha=0.3)
    axs[0].set_ylabel("mode shape (largest displacement 1)")
    fig.suptitle("Fig. 3: mode shapes, alpha = 0.005, q = 0, xi1 = 0.4 (rotor dotted)")
    fig.savefig(out / "belt_fig3_modes.png", dpi=130)
    plt.close(fig)
    print(f"\nwrote {out / 'belt_fig2_frequencies.png'} and {out / 'belt_fig3_modes.png'}")


if __name__ == "__main__":
    main()
