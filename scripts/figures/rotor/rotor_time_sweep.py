"""Brute-force time-simulation sweep of the bearing rotor over the rotor speed w.

What the rotor paper did before its harmonic balance (Inagaki, Ishida &
Hayashi, Trans. JSME C 71 (2005), section 3, Fig. 3 and 5): integrate eq. 11
by Runge-Kutta with 4096 steps per revolution to steady state at each speed.
For each w the script runs ``--transient`` revolutions, records ``--record``
more, and classifies the response from the Poincare section and the spectrum
of the disc (:func:`contin.timedomain.poincare.classify`):

- ``harmonic``     period-1 (the +w whirl only),
- ``subharmonic``  period-2 (entrained into the 1/2-order subharmonic, +w/2),
- ``neither``      not periodic (self-excited forward whirl, beating) or another period.

It prints a table (w, class, whirl radii of the disc at +w/2 and +w, wall
time per speed) and writes a PNG of the +w/2 forward-whirl radius against w
with the classes marked. With ``--diagram OUTDIR`` the points are drawn over
the harmonic-balance diagram in ``OUTDIR/branches.csv`` (columns ``branch``,
``nu``, ``w``, ``stable`` and a +w/2 forward-whirl column; without one, the
``h1_x1`` amplitude of the ``nu = 2`` rows, which is the half-order amplitude
of x1, not a whirl radius).

    python scripts/figures/rotor/rotor_time_sweep.py [--quick] [--f0 0.5] [--c2 0.05] [--diagram OUTDIR]
"""

from __future__ import annotations

import argparse
import re
import sys
import time
from pathlib import Path

import numpy as np

from contin.util.blas import limit_blas_threads
from contin.model.catalog import build_model
from contin.timedomain.poincare import steady_state

CLASS_NAMES = {1: "harmonic", 2: "subharmonic"}
STYLE = {"harmonic": ("o", "tab:green"), "subharmonic": ("s", "tab:red"), "neither": ("x", "k")}


def class_name(cls) -> str:
    return CLASS_NAMES.get(cls.period, "neither")


def whirl_column(columns, explicit=None):
    """The +w/2 forward-whirl column of a branches.csv header, or None."""
    if explicit:
        if explicit not in columns:
            raise SystemExit(f"--column {explicit!r} is not a column of branches.csv: {list(columns)}")
        return explicit
    forward = [c for c in columns
               if re.search(r"fwd|forward|fw_|_fw", c.lower()) and not re.search(r"bwd|back", c.lower())]
    for c in forward:  # prefer a column named for the half-order (w/nu) component
        if re.search(r"half|1/2|0\.5|nu|sub", c.lower()):
            return c
    return forward[0] if forward else None


def read_diagram(outdir: Path, column=None):
    """Curves of the harmonic-balance diagram: list of dicts (w, y, stable, nu, branch), and the y label."""
    from contin.output.results import read_csv

    path = Path(outdir) / "branches.csv"
    if not path.exists():
        raise SystemExit(f"--diagram: no branches.csv in {outdir}")
    rows = read_csv(path)
    for need in ("branch", "nu", "w"):
        if need not in rows:
            raise SystemExit(f"--diagram: {path} has no column '{need}' (columns: {list(rows)})")
    col = whirl_column(list(rows), column)
    label = col
    if col is None:
        if "h1_x1" not in rows:
            raise SystemExit(f"--diagram: {path} has neither a +w/2 forward-whirl column nor h1_x1")
        col, label = "h1_x1", "h1_x1 of the nu = 2 rows (half-order amplitude of x1)"
    curves = []
    stable_col = rows.get("stable")
    for b in np.unique(rows["branch"]):
        sel = rows["branch"] == b
        nu = int(rows["nu"][sel][0])
        if col == "h1_x1" and nu != 2:
            continue
        st = None
        if stable_col is not None and stable_col.dtype == bool:
            st = stable_col[sel]
        curves.append({"w": rows["w"][sel], "y": rows[col][sel], "stable": st, "nu": nu, "branch": int(b)})
    return curves, label


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="a few speeds, short runs (CI)")
    ap.add_argument("--f0", type=float, default=0.5, help="static lateral force (paper: 0.5, 0.2, 0)")
    ap.add_argument("--c2", type=float, default=None, help="bearing damping (paper: 0.05; 5.0 in its Fig. 8)")
    ap.add_argument("--w", type=float, nargs=3, metavar=("START", "STOP", "STEP"), default=None,
                    help="speed grid (default 1.6 2.6 0.05)")
    ap.add_argument("--transient", type=float, default=None, help="revolutions discarded (default 1500)")
    ap.add_argument("--record", type=int, default=None, help="revolutions recorded (default 100)")
    ap.add_argument("--steps", type=int, default=4096, help="RK4 steps per revolution (paper: 4096)")
    ap.add_argument("--initial", choices=("previous", "rest"), default="previous",
                    help="start each speed from the last state of the previous one (a slow sweep) or from rest")
    ap.add_argument("--diagram", type=Path, default=None, metavar="OUTDIR",
                    help="result directory of a rotor frequency_response run (branches.csv) to draw under the points")
    ap.add_argument("--column", default=None, help="the +w/2 forward-whirl column of branches.csv (default: detected)")
    ap.add_argument("--out", type=Path, default=Path("rotor_time_sweep.png"), help="output PNG")
    args = ap.parse_args(argv)
    limit_blas_threads(1)

    if args.quick:
        ws = np.array([1.8, 2.0, 2.16, 2.2])
        transient, record = args.transient or 300, args.record or 32
    else:
        lo, hi, step = args.w or (1.6, 2.6, 0.05)
        ws = np.round(np.arange(lo, hi + 0.5 * step, step), 10)
        transient, record = args.transient or 1500, args.record or 100
    params = {"f0": args.f0}
    if args.c2 is not None:
        params["c2"] = args.c2
    model = build_model("bearing_rotor", params)
    print(f"bearing rotor (paper eq. 11), {', '.join(f'{k} = {v:g}' for k, v in params.items())}; "
          f"RK4 with {args.steps} steps per revolution, contact switching located; "
          f"{transient:g} transient + {record} recorded revolutions per speed; start: {args.initial}")
    print(f"{'w':>6} {'class':>12} {'section':>14} {'|+w/2|':>9} {'|-w/2|':>9} {'|+w|':>8} "
          f"{'strongest other line':>22} {'events':>7} {'wall s':>7} {'us/rev':>7}")
    rows = []
    y = None
    t_all = time.perf_counter()
    for w in ws:
        x0 = v0 = None
        if args.initial == "previous" and y is not None:
            x0, v0 = y[:4], y[4:]
        t0 = time.perf_counter()
        res, cls = steady_state(model, {"w": float(w)}, x0, v0, transient=transient, record=record,
                                steps_per_period=args.steps, samples_per_period=64)
        wall = time.perf_counter() - t0
        y = res.final_state
        name = class_name(cls)
        other = next(((f, a) for f, a in cls.lines if abs(2 * f - round(2 * f)) > 1e-6), None)  # not a multiple of w/2
        other_txt = f"{other[0]:+.3f} w: {other[1]:.3f}" if other else "-"
        print(f"{w:6.3f} {name:>12} {cls.label:>14} {abs(cls.whirl['+w/2']):9.4f} {abs(cls.whirl['-w/2']):9.4f} "
              f"{abs(cls.whirl['+w']):8.4f} {other_txt:>22} {res.events:7d} {wall:7.2f} {res.cost_per_period_us:7.0f}")
        rows.append((float(w), name, abs(cls.whirl["+w/2"]), abs(cls.whirl["+w"]), wall, res.compile_time))
    total = time.perf_counter() - t_all
    compile_time = sum(r[5] for r in rows)
    counts = {k: sum(1 for r in rows if r[1] == k) for k in STYLE}
    print(f"total {total:.1f} s for {len(rows)} speeds ({compile_time:.1f} s loading/compiling the integrator); "
          + ", ".join(f"{k}: {v}" for k, v in counts.items()))

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7.5, 4.6), constrained_layout=True)
    ylabel = r"forward whirl radius of the disc at $\Omega/2$"
    if args.diagram is not None:
        curves, label = read_diagram(args.diagram, args.column)
        ylabel += f"\n(diagram: {label})"
        for c in curves:
            st = c["stable"]
            color = "tab:blue" if c["nu"] == 2 else "tab:gray"
            if st is None:
                ax.plot(c["w"], c["y"], "-", color=color, lw=1.0)
                continue
            # runs of equal stability, each sharing its end point with the next
            cuts = [0] + [i for i in range(1, len(st)) if st[i] != st[i - 1]] + [len(st)]
            for a, b in zip(cuts[:-1], cuts[1:]):
                flag = bool(st[a])
                ax.plot(c["w"][a:b + 1], c["y"][a:b + 1], "-" if flag else "--", color=color,
                        lw=1.4 if flag else 0.9)
        ax.plot([], [], "-", color="tab:blue", label="HB, stable")
        ax.plot([], [], "--", color="tab:blue", label="HB, unstable")
    for k, (m, col) in STYLE.items():
        pts = [(r[0], r[2]) for r in rows if r[1] == k]
        if pts:
            p = np.array(pts)
            ax.plot(p[:, 0], p[:, 1], m, color=col, mfc="none", ms=7, label=f"simulation: {k}")
    ax.set_xlabel(r"rotor speed $\Omega$")
    ax.set_ylabel(ylabel)
    ax.set_title(f"bearing rotor, time simulation ({args.steps} steps/rev), "
                 + ", ".join(f"{k} = {v:g}" for k, v in params.items()))
    ax.legend(fontsize=8)
    fig.savefig(args.out, dpi=110)
    plt.close(fig)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
