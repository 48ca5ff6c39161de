"""The rotor's Fig. 4 three ways: converged harmonic balance, the paper's truncation, the equations of motion.

Inagaki, Ishida & Hayashi (2005) draw the 1/2-subharmonic branch at f0 = 0.5 with
m = 10 harmonics of w/2: stable C-E between unstable branches C-B-D and E-F that end
on the zero-amplitude (harmonic) solution. This script draws, in one diagram of the
+w/2 forward whirl radius of the disc against w (stable solid, unstable dashed):

- the converged harmonic balance of the README's main job (scenes/rotor_f0_05.yaml,
  H = 80 harmonics of w/2 on the nu = 2 branch), read from ``--main DIR`` if that
  holds a finished run, otherwise run here;
- the same branch with the paper's truncation (H = 10 of w/2, 512 samples), which goes
  on through the folds C and past E but whose multipliers flicker across the unit
  circle where the bearing skims its casing;
- the branch of the equations of motion themselves, by shooting on the flow map of the
  time integrator, from the period doubling D through C and E to the period doubling F
  (scripts/figures/rotor/rotor_subharmonic_shooting.py, which this script runs).

It prints where each branch ends and writes ``fig4_truncations.png`` in ``-o DIR``.

    python scripts/figures/rotor/rotor_fig4_truncations.py --main results/rotor   # ~25 min on two cores
    python scripts/figures/rotor/rotor_fig4_truncations.py --quick                 # short stretches, ~1 min
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from contin.util.blas import limit_blas_threads
from contin.model.catalog import build_model
from contin.output.results import read_csv
from contin.app.runner import run_scene
from contin.scene.parse import load_scene
from rotor_subharmonic_shooting import W0, draw_stability, fig4_branches  # the equations of motion's branch

ROOT = Path(__file__).resolve().parents[3]
PAPER_TRUNCATION = """\
model: {builtin: bearing_rotor, parameters: {f0: 0.5}}
analysis:
  type: frequency_response
  parameter: w
  range: [%(lo)s, %(hi)s]
  start: 2.16
  start_from: simulation
  start_simulation: {transient: %(transient)d, steps_per_period: 4096}
  both_ways: true
  subharmonic: 2
  harmonics: 10
  samples: 512
  crossings: interval
  stability: floquet
  stability_options: {steps_per_period: 4096}
  continuation: {ds: %(ds)s, ds_max: %(ds_max)s, newton_tol: 1.0e-9, stall_points: 20}
output: {measure: whirl_fwd_half_disc, plots: %(plots)s}
"""


def hb_branches(outdir: Path, nu: int = 2):
    """(w, radius, stable) per nu-``nu`` branch of a finished run."""
    rows = read_csv(outdir / "branches.csv")
    out = []
    for b in np.unique(rows["branch"][rows["nu"] == nu]):
        m = rows["branch"] == b
        out.append((rows["w"][m], rows["whirl_fwd_half_disc"][m], rows["stable"][m].astype(bool)))
    return out


def ends(outdir: Path) -> list:
    """One line per branch of a finished run: order, points, status and message."""
    branches = json.loads((outdir / "summary.json").read_text())["analysis"]["branches"]
    return [f"branch {b['branch']} (nu = {b['nu']}): {b['points']} points, {b['status']}: {b['message'][:110]}"
            for b in branches]


def shooting_branches(quick: bool):
    """[(w, radius, stable)] of the equations of motion's branch from F.

    Computed by scripts/figures/rotor/rotor_subharmonic_shooting.py.
    """
    rows = fig4_branches(build_model("bearing_rotor", {"f0": 0.5}), quick)[0]
    return [tuple(np.array([r[k] for r in rows]) for k in ("w", "radius", "stable"))]


def draw(ax, branches, color, label, lw):
    for k, (w, r, st) in enumerate(branches):
        draw_stability(ax, w, r, st, label=label if k == 0 else None, color=color, lw=lw)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="short stretches of each branch (a smoke run)")
    ap.add_argument("--main", default="results/rotor", help="a finished run of scenes/rotor_f0_05.yaml, if any")
    ap.add_argument("-o", "--outdir", default="results/rotor_fig4_truncations")
    args = ap.parse_args(argv)
    limit_blas_threads(1)
    out = Path(args.outdir)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    main_dir = Path(args.main)
    if not (main_dir / "summary.json").exists():
        main_dir = out / "converged"
        # a smoke run: the harmonic branch over a short range, without the nu = 2 start
        narrow = ["analysis.range=[2.15, 2.17]", "analysis.start=2.15", "analysis.starts=[]", "output.plots=false"] \
            if args.quick else []
        run_scene(load_scene(ROOT / "scenes" / "rotor_f0_05.yaml", narrow), main_dir, progress=False)
    print(f"converged harmonic balance ({main_dir}):")
    for line in ends(main_dir):
        print(f"  {line}")
    # --quick: a short stretch either side of the start in a few steps (relative to the range), without the
    # scenes' own figures (this one is drawn)
    lo, hi = (W0 - 0.004, W0 + 0.004) if args.quick else (1.6, 2.6)
    scene_path = out / "paper_truncation.yaml"
    scene_path.write_text(PAPER_TRUNCATION % {"lo": lo, "hi": hi, "transient": 300 if args.quick else 1500,
                                              "ds": 0.05 if args.quick else 0.005, "ds_max": 0.2 if args.quick else 0.03,
                                              "plots": "false" if args.quick else "true"})
    run_scene(load_scene(scene_path), out / "paper_truncation", progress=False)
    print("the paper's truncation (10 harmonics of w/2):")
    for line in ends(out / "paper_truncation"):
        print(f"  {line}")
    print("the equations of motion (shooting):")
    shoot = shooting_branches(args.quick)

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7.5, 5.0), constrained_layout=True)
    rows = read_csv(main_dir / "branches.csv")
    h = rows["nu"] == 1
    ax.plot(rows["w"][h], np.zeros(h.sum()), "-", color="0.5", lw=1.0, label="harmonic solution (zero +w/2)")
    draw(ax, hb_branches(out / "paper_truncation"), "C2", "harmonic balance, 10 harmonics of w/2 (the paper's)", 1.0)
    draw(ax, hb_branches(main_dir), "C0", "harmonic balance, 80 harmonics of w/2", 2.0)
    draw(ax, shoot, "k", "equations of motion (shooting)", 1.2)
    ax.set_xlim(2.13, 2.21)
    ax.set_xlabel(r"rotor speed $\Omega$")
    ax.set_ylabel(r"forward whirl radius of the disc at $\Omega/2$")
    ax.set_title(r"bearing rotor, $f_0$ = 0.5: stable solid, unstable dashed")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="upper left")
    fig.savefig(out / "fig4_truncations.png", dpi=110)
    plt.close(fig)
    print(f"\ntotal {time.perf_counter() - t0:.1f} s; {out / 'fig4_truncations.png'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
