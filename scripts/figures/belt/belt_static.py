"""Figures 4 and 5 of the timing-belt paper: static restoring-force curves under the magnet.

The ``static`` analysis of ``scenes/belt_static.yaml`` (equilibria of the belt
under the magnet and a constant acceleration ``p_s``, continued in ``p_s``)
for beta = 0.2 (Fig. 4) and beta = 10 (Fig. 5), alpha = 0.005, read at
xi = 0.6. The paper varies the pole strength at a fixed gap, which scales all
four coefficients; here ``gamma_k = s * (50, 5, 0.313, 0.0156)`` for the
strengths ``s`` (the printed figure's values are not legible in the source,
so s = 0, 0.5, 1, 2 are drawn). A stronger magnet stiffens the belt at a given
``p_s``; a load against the magnet (``p_s < 0``) snaps the belt through
between two folds; with the heavy rotor (beta = 10) the folds move close to
``p_s = 0`` (the sharp change of stiffness at small ``p_s`` that the paper
reports). Writes ``belt_fig4_static.png``, ``belt_fig5_static.png`` and prints
the folds.

    python scripts/figures/belt/belt_static.py [--quick] [--out DIR]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from contin.util.blas import limit_blas_threads
from contin.models.timing_belt import PAPER_MAGNET
from contin.output.results import read_csv
from contin.app.runner import run_scene
from contin.scene.parse import load_scene

ROOT = Path(__file__).resolve().parents[3]
SCENE = ROOT / "scenes" / "belt_static.yaml"


def restoring_curve(beta, strength, outdir, p_range=(-100.0, 60.0), extra=()):
    """Rows and special points of the static scene with the magnet scaled by ``strength`` (``extra``: more
    ``--set`` overrides)."""
    sets = [f"model.parameters.beta={beta}", f"analysis.range=[{p_range[0]}, {p_range[1]}]", *extra]
    sets += [f"model.parameters.gamma{k}={strength * g}" for k, g in enumerate(PAPER_MAGNET)]
    scene = load_scene(SCENE, sets)
    run_scene(scene, outdir, progress=False)
    return read_csv(outdir / "branches.csv"), read_csv(outdir / "special_points.csv")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="two magnet strengths only, longer steps")
    ap.add_argument("--out", default="results/belt", help="output directory")
    args = ap.parse_args(argv)
    limit_blas_threads(1)  # small matrices: one BLAS thread is faster (see README)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    strengths = (0.0, 1.0) if args.quick else (0.0, 0.5, 1.0, 2.0)
    # quick: longer steps, and no figure of each run (the script draws its own)
    extra = ("analysis.continuation={ds: 0.04, ds_max: 0.2}", "output.plots=false") if args.quick else ()
    for fig_no, beta in ((4, 0.2), (5, 10.0)):
        fig, ax = plt.subplots(figsize=(6.4, 4.6), constrained_layout=True)
        print(f"Fig. {fig_no}: beta = {beta:g}, alpha = 0.005, w at xi = 0.6")
        for s in strengths:
            rows, sp = restoring_curve(beta, s, out / f"static_beta{beta:g}_s{s:g}",
                                       (-250.0, 60.0) if beta < 1 else (-100.0, 60.0), extra)
            at0 = rows["w"][np.argmin(np.abs(rows["p_s"]))]
            folds = sp["kind"] == "fold"
            fold_txt = ", ".join(f"p_s = {p:.4f} (w = {w:.4f})" for p, w in zip(sp["p_s"][folds], sp["w"][folds]))
            print(f"  strength {s:g} (gamma0 = {50 * s:g}): w(p_s = 0) = {at0:.4f}; folds: {fold_txt or 'none'}")
            color = None
            for b in np.unique(rows["branch"]):
                sel = rows["branch"] == b  # in continuation order: the curve folds, it is not a function of p_s
                w, p, st = rows["w"][sel], rows["p_s"][sel], rows["stable"][sel].astype(bool)
                for stable in (True, False):
                    # each point joins the segment of its own stability and of its neighbour's
                    keep = (st == stable) | np.r_[st[1:] == stable, False] | np.r_[False, st[:-1] == stable]
                    if keep.any():
                        line, = ax.plot(np.where(keep, w, np.nan), np.where(keep, p, np.nan),
                                        "-" if stable else "--", color=color,
                                        label=f"gamma0 = {50 * s:g}" if color is None else None)
                        color = line.get_color()
            ax.plot(sp["w"][folds], sp["p_s"][folds], "o", mfc="none", color=color)
        ax.set_xlabel(r"$w$ at $\xi = 0.6$")
        ax.set_ylabel(r"static load $p_s$")
        ax.set_title(rf"Fig. {fig_no}: restoring force, $\beta$ = {beta:g} (dashed: unstable, o: folds)")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8)
        path = out / f"belt_fig{fig_no}_static.png"
        fig.savefig(path, dpi=130)
        plt.close(fig)
        print(f"  wrote {path}")


if __name__ == "__main__":
    main()
