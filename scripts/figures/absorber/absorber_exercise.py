"""Seed 000, exercise 7.5 (1): the optimal absorber for m1 = 100 kg, k1 = 5e5 N/m with m2 = 10 kg.

Den Hartog's design (contin.modal.absorber): k2 = k1 beta/(1+beta)^2 and c = 2 m2 p zeta with
zeta = c/(2 m2 p) = sqrt(3 beta/(8 (1+beta)^3)) (referred to the main system; the absorber's
own ratio zeta_a = zeta/mu is printed too). The response |X1|(w) of the main mass is
computed three ways, and the script prints how far they are apart:

- the closed form of seed 000, sec. 7.3;
- the impedance matrix Z(w) = K - w^2 M + i w C (contin.modal.modes.frf);
- harmonic balance with H = 1 on the built-in linear_chain model (Newton at each w), and the
  continuation of scenes/absorber_exercise.yaml (frequency_response, H = 1).

It plots |X1|/delta_st against w with the fixed points, the true peak, and the curves without
the damper and with a rigid one.

    python scripts/figures/absorber/absorber_exercise.py [--quick] [--out absorber_exercise.png]
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np

from contin.modal.absorber_design import design_absorber, plot_design
from contin.util.blas import limit_blas_threads
from contin.model.catalog import build_model
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.engine.newton import solve_at_parameter

ROOT = Path(__file__).resolve().parents[3]
M1, K1, M2, F = 100.0, 5e5, 10.0, 1.0


def closed_form(d, w):
    """|X1| of seed 000, sec. 7.3 (the zeta form), for a force F on the main mass."""
    O2 = (w / d.p) ** 2
    z, mu, b = d.zeta, d.mu, d.beta
    num = (mu**2 - O2) ** 2 + 4 * z**2 * O2
    den = ((1 - O2) * (mu**2 - O2) - b * mu**2 * O2) ** 2 + 4 * z**2 * O2 * (1 - (1 + b) * O2) ** 2
    return F / d.k1 * np.sqrt(num / den)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="a coarse grid (CI)")
    ap.add_argument("--out", type=Path, default=Path("absorber_exercise.png"))
    args = ap.parse_args()
    limit_blas_threads()
    d = design_absorber(M1, K1, M2)
    print(d.report())
    w = np.linspace(40.0, 110.0, 71 if args.quick else 701)
    ref = closed_form(d, w)
    X = d.frf(w, F)
    print(f"impedance solve vs closed form: max relative error {np.max(np.abs(np.abs(X[:, 0]) / ref - 1)):.1e}")
    model = build_model("linear_chain", {"m1": M1, "m2": M2, "k1": K1, "k2": d.k2, "k3": 0.0, "c1": 0.0,
                                         "c2": d.c, "c3": 0.0, "F1": F, "F2": 0.0})
    hb = HarmonicBalance(model, "w", HBOptions(harmonics=1))
    err_z, err_c = 0.0, 0.0
    for wi, Xi, ri in zip(w, X, ref):
        res = solve_at_parameter(hb, np.zeros(hb.size), wi)
        Xh = res.x[2:4] - 1j * res.x[4:6]  # x = a cos + b sin = Re((a - i b) e^{i w t})
        err_z = max(err_z, float(np.max(np.abs(Xh - Xi)) / np.max(np.abs(Xi))))
        err_c = max(err_c, abs(abs(Xh[0]) / ri - 1))
    print(f"harmonic balance H = 1 vs impedance solve: max relative error {err_z:.1e}; "
          f"vs closed form {err_c:.1e}")
    from contin.output.results import read_csv
    from contin.app.runner import run_scene
    from contin.scene.parse import load_scene

    sets = ["analysis.continuation={ds_max: 0.5}"] if args.quick else []
    with tempfile.TemporaryDirectory() as tmp:
        run_scene(load_scene(ROOT / "scenes" / "absorber_exercise.yaml", sets), tmp, progress=False)
        rows = read_csv(Path(tmp) / "branches.csv")
    rel = np.abs(rows["amp_x1"] / closed_form(d, rows["w"]) - 1)
    print(f"scenes/absorber_exercise.yaml (continuation, H = 1): {len(rel)} points, max relative error "
          f"{rel.max():.1e}; largest |X1|/delta_st on the branch {rows['amp_x1'].max() / (F / K1):.6f}")
    plot_design(d, args.out, points=300 if args.quick else 2000)
    print(f"figure: {args.out}")


if __name__ == "__main__":
    main()
