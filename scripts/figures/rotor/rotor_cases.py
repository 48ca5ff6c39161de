"""The bearing rotor's four cases side by side: the paper's Fig. 4, 6 and 8 and the f0 = 0 case.

Runs the scenes ``scenes/rotor_f0_05.yaml`` (f0 = 0.5), ``rotor_f0_02.yaml``
(f0 = 0.2), ``rotor_f0_0.yaml`` (no static force) and ``rotor_c2_5.yaml``
(bearing damping c2 = 5.0) and draws, for each, the +w/2 forward-whirl radius
of the disc against the rotor speed w: the harmonic solution at zero (it has
no w/2 component; the paper's "zero-amplitude solution"), the 1/2-subharmonic
branches, stable solid, unstable dashed, period-doubling points marked. It
prints, per case, the speeds of the harmonic branch's period-doubling points
and the interval where a stable nu = 2 branch exists (Inagaki, Ishida &
Hayashi 2005: that interval shrinks from f0 = 0.5 to 0.2 and vanishes for
f0 = 0 and for c2 = 5).

    python scripts/figures/rotor/rotor_cases.py [--quick] [--out DIR] [--from DIR]

``--from DIR`` reuses the result directories ``DIR/<case>`` of earlier
``contin run`` calls instead of running the scenes. ``--quick`` (the CI
smoke run) narrows the speed range and the harmonics, drops the nu = 2 starts
(a stiff-contact subharmonic needs H = 80) and runs only f0 = 0.5 and c2 = 5:
the numbers it prints are not converged.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]
CASES = [("rotor_f0_05", "f0 = 0.5 (Fig. 4)"), ("rotor_f0_02", "f0 = 0.2 (Fig. 6)"),
         ("rotor_f0_0", "f0 = 0"), ("rotor_c2_5", "c2 = 5.0 (Fig. 8)")]
# H = 20: the fewest harmonics that keep the bearing on its casing along this range (with 12 the truncated orbit
# leaves it and a dozen spurious period doublings are located, at twice the cost)
QUICK = ["analysis.range=[2.12, 2.2]", "analysis.start=2.12", "analysis.harmonics=20", "analysis.samples=512",
         "analysis.stability_options.steps_per_period=2048", "analysis.continuation.ds_max=0.02", "analysis.starts=[]"]


def run_case(name: str, outdir: Path, quick: bool) -> Path:
    from contin.app.runner import run_scene
    from contin.scene.parse import load_scene

    overrides = list(QUICK) if quick else []
    scene = load_scene(ROOT / "scenes" / f"{name}.yaml", overrides)
    out = outdir / name
    run_scene(scene, out, progress=False)
    return out


def main(argv=None) -> int:
    from contin.util.blas import limit_blas_threads

    limit_blas_threads(1)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from contin.output.plotting import _segments
    from contin.models.bearing_rotor import stable_subharmonic_interval
    from contin.output.results import read_csv

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="narrow range, few harmonics (a smoke run)")
    ap.add_argument("--out", default="results/rotor_cases", help="output directory")
    ap.add_argument("--from", dest="source", default=None, help="reuse result directories DIR/<case>")
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    fig, axes = plt.subplots(2, 2, figsize=(10, 7), sharex=True, constrained_layout=True)
    print(f"{'case':22s} {'pd of the harmonic branch':34s} stable nu=2 interval")
    # the quick smoke run skips f0 = 0.2 and f0 = 0, whose starts need a long simulation from w = 1.6
    cases = [c for c in CASES if not args.quick or c[0] in ("rotor_f0_05", "rotor_c2_5")]
    for ax, (name, label) in zip(axes.flat, cases):
        d = Path(args.source) / name if args.source else run_case(name, out, args.quick)
        rows, sp = read_csv(d / "branches.csv"), read_csv(d / "special_points.csv")
        for b in np.unique(rows["branch"]):
            m = rows["branch"] == b
            nu = int(rows["nu"][m][0])
            color = "tab:blue" if nu == 1 else "tab:red"
            st = np.array([bool(v) for v in rows["stable"][m]])
            for xs, ys, s in _segments(rows["w"][m], rows["whirl_fwd_half_disc"][m], st):
                ax.plot(xs, ys, "-" if s else "--", color=color, lw=1.6 if s else 1.0)
        pd_w = sp["w"][(sp["kind"] == "pd") & (sp["branch"] == 0)] if len(sp["kind"]) else np.array([])
        ax.plot(pd_w, np.zeros_like(pd_w), "s", mfc="none", color="tab:purple", label="pd")
        iv = stable_subharmonic_interval(rows, sp)
        pds = ", ".join(f"{v:.4f}" for v in np.unique(np.round(pd_w, 4))) or "none"
        print(f"{label:22s} {pds:34s} {'none' if iv is None else f'{iv[0]:.4f} .. {iv[1]:.4f}'}")
        ax.set_title(label)
        ax.set_ylabel(r"forward whirl radius at $\Omega/2$")
    for ax in axes[-1]:
        ax.set_xlabel(r"rotor speed $\Omega$")
    axes.flat[0].plot([], [], "-", color="tab:blue", label="harmonic (nu=1)")
    axes.flat[0].plot([], [], "-", color="tab:red", label="1/2 subharmonic (nu=2)")
    axes.flat[0].plot([], [], "k-", label="stable")
    axes.flat[0].plot([], [], "k--", label="unstable")
    axes.flat[0].legend(fontsize=8)
    path = out / "rotor_cases.png"
    fig.savefig(path, dpi=110)
    print(f"figure: {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
