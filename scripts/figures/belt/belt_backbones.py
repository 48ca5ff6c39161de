"""Figures 6, 7 and 8 of the timing-belt paper: backbone curves of modes 1 and 2.

Free undamped periodic vibrations about the static equilibrium, frequency
unknown, traced in amplitude from the linear natural frequency
(:mod:`contin.bifurcation.backbone`; the paper's Section 4.3 takes m up to 3 cosine
harmonics, here H = 5 sine and cosine harmonics). The amplitude axis is w_rms
at xi = 0.6 (eq. 21) on a log scale, as in the paper:

- Fig. 6: alpha = 0.005, no magnet, the rotor mass ratio beta varied;
- Fig. 7: beta = 0.2, no magnet, the shape factor alpha varied;
- Fig. 8: alpha = 0.005, beta = 0.2, with the magnet (gamma0..3 = 50, 5, 0.313,
  0.0156) and without.

Without the magnet every curve hardens; with it the first mode softens, down
to a frequency minimum, then hardens (softening-hardening); the second mode
stays nearly hardening. Prints, per curve, the linear frequency, the
frequencies at w_rms = 1, 3 and 10 and any frequency minimum; writes
``belt_fig6_backbones.png``, ``belt_fig7_backbones.png`` and
``belt_fig8_backbones.png``.

    python scripts/figures/belt/belt_backbones.py [--quick] [--out DIR] [--harmonics H]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from contin.bifurcation.backbone import trace_backbone
from contin.util.blas import limit_blas_threads
from contin.model.catalog import build_model

NO_MAGNET = ["rotor_mass", "stretching"]
MAGNET = ["rotor_mass", "stretching", "magnet"]


def curve(params, effects, mode, A_max, H):
    model = build_model("timing_belt", params, effects)
    br, prob = trace_backbone(model, mode, (0.01, A_max), observe="w", harmonics=H, amplitude="rms")
    A = np.exp(br.parameter)
    W = br.unknowns[:, prob.m]
    turns = [s.data["frequency"] for s in br.special_points if s.kind.value == "user"]
    return A, W, prob.omega0, turns, br


def report(label, mode, A, W, w0, turns, br):
    at = [np.interp(a, A, W) if A[0] <= a <= A[-1] else np.nan for a in (1.0, 3.0, 10.0)]
    extra = f"; frequency minimum {min(turns):.4f}" if turns else ""
    status = "" if br.status.value == "range_end" else f" [{br.status.value}: {br.message}]"
    print(f"  {label:22s} mode {mode}: linear {w0:.4f}; at w_rms = 1, 3, 10: "
          + ", ".join(f"{v:.4f}" for v in at) + extra + status)


def figure(path, title, curves):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.6, 4.6), constrained_layout=True)
    for label, mode, A, W, style, color in curves:
        ax.plot(W, A, style, color=color, lw=1.4, label=f"{label}, mode {mode}")
    ax.set_yscale("log")
    ax.set_xlabel(r"frequency $\omega$")
    ax.set_ylabel(r"RMS of $w$ at $\xi = 0.6$")
    ax.set_title(title)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    fig.savefig(path, dpi=130)
    plt.close(fig)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer curves, amplitudes up to 3")
    ap.add_argument("--out", default="results/belt")
    ap.add_argument("--harmonics", type=int, default=5)
    args = ap.parse_args(argv)
    limit_blas_threads(1)  # small matrices: one BLAS thread is faster (see README)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    A_max = 3.0 if args.quick else 10.0
    H = args.harmonics
    colors = ["tab:blue", "tab:orange", "tab:green", "tab:red"]
    studies = [
        (6, "Fig. 6: alpha = 0.005, q = 0, beta varied", "beta",
         (0.0, 0.2) if args.quick else (0.0, 0.2, 1.0, 10.0), {"alpha": 0.005}, NO_MAGNET),
        (7, "Fig. 7: beta = 0.2, q = 0, alpha varied", "alpha",
         (0.005, 0.05) if args.quick else (0.001, 0.005, 0.02, 0.1), {"beta": 0.2}, NO_MAGNET),
    ]
    for no, title, key, values, base, effects in studies:
        print(title)
        curves = []
        for v, color in zip(values, colors):
            for mode, style in ((1, "-"), (2, "--")):
                A, W, w0, turns, br = curve({**base, key: v}, effects, mode, A_max, H)
                report(f"{key} = {v:g}", mode, A, W, w0, turns, br)
                curves.append((f"{key} = {v:g}", mode, A, W, style, color))
        figure(out / f"belt_fig{no}_backbones.png", title, curves)
    print("Fig. 8: alpha = 0.005, beta = 0.2, with the magnet (gamma0..3 = 50, 5, 0.313, 0.0156) and without")
    curves = []
    for label, effects, color in (("no magnet", NO_MAGNET, "0.5"), ("magnet", MAGNET, "tab:red")):
        for mode, style in ((1, "-"), (2, "--")):
            A, W, w0, turns, br = curve({"alpha": 0.005, "beta": 0.2}, effects, mode, A_max, H)
            report(label, mode, A, W, w0, turns, br)
            curves.append((label, mode, A, W, style, color))
    figure(out / "belt_fig8_backbones.png", "Fig. 8: backbones with and without the magnet", curves)
    print(f"wrote belt_fig6/7/8_backbones.png in {out}")


if __name__ == "__main__":
    main()
