"""Subharmonic responses of the timing belt: orders 1/2 and 1/3 (the paper's mu = 1/2 and 1/3).

- 1/2 (``scenes/belt_subharmonic2.yaml``): with the magnet, undamped, p_d = 2;
  the harmonic response loses stability by period doubling near twice the
  first natural frequency and the two nu = 2 branches are started there by
  switching (one stable, one unstable, bending to lower frequency: the
  softening of the magnet-on first mode).
- 1/3 (``scenes/belt_subharmonic3.yaml``): without the magnet, undamped; the
  isolated nu = 3 branch near three times the first natural frequency,
  started from the free vibration of mode 1 at w/3 (its backbone) and traced
  both ways: stable large and unstable small branches meet at a fold.

Each subharmonic branch is checked against time integration (RK4, 2048 steps
per forcing period) started on one of its points: the orbit must close after
one solution period ``2 pi nu / w``. Writes ``belt_subharmonics.png``.

    python scripts/figures/belt/belt_subharmonic.py [--quick] [--out DIR]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from contin.util.blas import limit_blas_threads
from contin.model.catalog import build_model
from contin.output.results import read_csv
from contin.app.pointplot import load_state_row, stored_expansion
from contin.app.runner import run_scene
from contin.scene.parse import load_scene
from contin.timedomain.simulation import simulate

ROOT = Path(__file__).resolve().parents[3]


def run(scene_name, outdir, sets=()):
    scene = load_scene(ROOT / "scenes" / scene_name, list(sets) + ["output.plots=false"])
    summary = run_scene(scene, outdir, progress=False)
    return summary, read_csv(outdir / "branches.csv"), read_csv(outdir / "special_points.csv")


def check_by_time_integration(outdir, scene_name, row):
    """Largest deviation between the HB orbit of ``row`` and an RK4 run from its start over one period."""
    scene = load_scene(ROOT / "scenes" / scene_name)
    m = scene.model
    model = build_model("timing_belt", m["parameters"], m["effects"])
    rec = load_state_row(outdir, row)
    u, w, nu = stored_expansion(outdir)(rec["branch_record"], rec["u"], rec["lam"]), rec["lam"], rec["nu"]
    U = u.reshape(-1, model.n_dof)
    H = (U.shape[0] - 1) // 2
    k = np.arange(1, H + 1)
    Om = w / nu
    x0, v0 = U[0] + U[1::2].sum(axis=0), Om * (k[:, None] * U[2::2]).sum(axis=0)
    run_ = simulate(model, {"w": w}, x0, v0, periods=nu, steps_per_period=2048, record_every=64)
    th = Om * run_.t
    ref = U[0] + np.cos(np.outer(th, k)) @ U[1::2] + np.sin(np.outer(th, k)) @ U[2::2]
    return w, nu, float(np.abs(run_.x - ref).max()), float(np.abs(U[1:]).max())


def describe(label, rows, sp):
    print(label)
    for b in np.unique(rows["branch"]):
        sel = rows["branch"] == b
        nu = int(rows["nu"][sel][0])
        w, st = rows["w"][sel], rows["stable"][sel].astype(bool)
        parts = []
        for stable in (True, False):
            if (st == stable).any():
                parts.append(f"{'stable' if stable else 'unstable'} {w[st == stable].min():.4f}-"
                             f"{w[st == stable].max():.4f}")
        print(f"  branch {int(b)} (nu = {nu}): w_rms up to {rows['w_rms'][sel].max():.4f}; " + "; ".join(parts))
    for k, w, a, b in zip(sp["kind"], sp["w"], sp["w_rms"], sp["branch"]):
        if k in ("fold", "pd", "ns", "bp"):
            print(f"  {k} on branch {int(b)} at w = {w:.6f} (w_rms {a:.4f})")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="narrower ranges, longer steps, fewer harmonics of the 1/3 subharmonic")
    ap.add_argument("--out", default="results/belt")
    args = ap.parse_args(argv)
    limit_blas_threads(1)  # small matrices: one BLAS thread is faster (see README)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    q = args.quick
    # quick: the ranges just hold the period doublings and the fold, in longer steps; Hill's spectrum (an
    # eigenvalue problem of order 2 n (2 H + 1) at every point) is what costs, hence H = 6 of w/3 for the 1/3
    steps = "analysis.continuation={ds: 0.04, ds_max: 0.2, max_points: 1500}"
    runs = [("belt_subharmonic2.yaml", "1/2 subharmonic (magnet on, undamped): switching at period doubling",
             ["analysis.range=[9.8, 9.95]", "analysis.stability=hill", steps] if q else []),
            ("belt_subharmonic3.yaml", "1/3 subharmonic (no magnet, undamped): started from the mode-1 backbone",
             ["analysis.range=[7.95, 8.7]", "analysis.harmonics=6", steps] if q else [])]
    results = []
    for name, label, sets in runs:
        d = out / Path(name).stem
        _, rows, sp = run(name, d, sets)
        describe(label, rows, sp)
        for b in np.unique(rows["branch"]):
            sel = np.flatnonzero((rows["branch"] == b) & (rows["nu"] > 1))
            if sel.size:
                i = int(sel[len(sel) // 2])
                w, nu, err, size = check_by_time_integration(d, name, i)
                print(f"  time integration from branch {int(b)} at w = {w:.4f}: the orbit closes after "
                      f"{nu} forcing periods to {err:.2e} (harmonics up to {size:.3f})")
        results.append((label, rows, sp))
    _plot(out / "belt_subharmonics.png", results)
    print(f"wrote {out / 'belt_subharmonics.png'}")


def _plot(path, results):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axs = plt.subplots(1, 2, figsize=(12, 4.4), constrained_layout=True)
    for ax, (label, rows, sp) in zip(axs, results):
        for b in np.unique(rows["branch"]):
            sel = rows["branch"] == b
            w, a, st = rows["w"][sel], rows["w_rms"][sel], rows["stable"][sel].astype(bool)
            nu = int(rows["nu"][sel][0])
            color = "0.4" if nu == 1 else None
            for stable in (True, False):
                keep = (st == stable) | np.r_[st[1:] == stable, False] | np.r_[False, st[:-1] == stable]
                if keep.any():
                    line, = ax.plot(np.where(keep, w, np.nan), np.where(keep, a, np.nan), "-" if stable else "--",
                                    color=color, label=f"branch {int(b)}, nu = {nu}" if stable else None)
                    color = line.get_color()
        for k, marker in (("pd", "s"), ("fold", "o")):
            f = sp["kind"] == k
            ax.plot(sp["w"][f], sp["w_rms"][f], marker, mfc="none", color="tab:red", label=k if f.any() else None)
        ax.set_xlabel(r"excitation frequency $\Omega$")
        ax.set_ylabel(r"RMS of $w$ at $\xi = 0.6$")
        ax.set_title(label, fontsize=9)
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7)
    fig.savefig(path, dpi=130)
    plt.close(fig)


if __name__ == "__main__":
    main()
