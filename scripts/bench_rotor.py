"""Benchmark: the rotor's f0 = 0.5 diagram against a brute-force time-simulation sweep.

Two measurements, side by side in one run:

1. **Diagram vs brute force at the same speed resolution.** ``scenes/rotor_f0_05.yaml``
   (the harmonic branch over w = 1.6..2.6 and the 1/2-subharmonic branch, both
   with Floquet stability by monodromy) is run once and timed. Its speed
   resolution is the median spacing in w of the harmonic branch's stored
   points. The brute-force alternative, what the rotor paper did, integrates
   eq. 11 to steady state (RK4, 4096 steps per revolution, ``--transient``
   revolutions, then ``--record`` more classified by
   :func:`contin.poincare.classify`) at every speed of a grid over the same
   range with that spacing. Each speed is classified both ways, with the same
   three classes: ``harmonic`` (period 1), ``subharmonic`` (period 2) or
   ``neither``; the diagram's class at w is that of the stable branches
   through it (see :func:`diagram_class`). Both classes are printed side by
   side with the agreement count, and the time ratio brute force / diagram.
   ``--every k`` simulates only every k-th grid speed and extrapolates the
   brute-force time to the whole grid (the ratio is then marked so).
2. **Convergence in H of the stable nu = 2 interval.** The nu = 2 branch is
   traced with ``H`` harmonics of w/2 for each ``--harmonics`` value
   (samples ``max(1024, 25 H)``) and the end points of its stable interval
   (a Neimark-Sacker point and a fold) are printed with their change against
   the finest H.

``--quick`` is a smoke run for CI: the harmonic branch alone over w = 2.12..2.2
at H = 12, a few speeds with short transients (its classes are not converged).

    python scripts/bench_rotor.py [--quick] [--every 1] [--harmonics 40,60,80,120] [--no-convergence]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def run(name, overrides, outdir):
    from contin.runner import run_scene
    from contin.scene import load_scene

    scene = load_scene(ROOT / "scenes" / f"{name}.yaml", overrides)
    return scene, run_scene(scene, outdir, progress=False)


def diagram_class(rows, w: float) -> str:
    """What the diagram says at speed w: a stable branch of nu = 1 or 2 through it, or neither."""
    out = []
    for b in np.unique(rows["branch"]):
        m = rows["branch"] == b
        ws, st, nu = rows["w"][m], np.array([bool(s) for s in rows["stable"][m]]), int(rows["nu"][m][0])
        for i in range(len(ws) - 1):
            if min(ws[i], ws[i + 1]) <= w <= max(ws[i], ws[i + 1]):
                j = i if abs(ws[i] - w) <= abs(ws[i + 1] - w) else i + 1  # the nearer stored point
                if not st[j] or (nu == 2 and rows["whirl_fwd_half_disc"][m][j] < 1e-3):
                    continue
                out.append({1: "harmonic", 2: "subharmonic"}[nu])
    return "+".join(sorted(set(out))) or "neither"


def stable_row_near(rows, w: float, cls: str):
    """Row (in branches.csv) of the stored stable point of class ``cls`` nearest to speed w, or None."""
    nu_of = {"harmonic": 1, "subharmonic": 2}[cls]
    best = None
    for i in range(len(rows["w"])):
        if int(rows["nu"][i]) != nu_of or not bool(rows["stable"][i]):
            continue
        if nu_of == 2 and rows["whirl_fwd_half_disc"][i] < 1e-3:
            continue
        d = abs(float(rows["w"][i]) - w)
        if best is None or d < best[0]:
            best = (d, i)
    return None if best is None else best[1]


def simulate_from_orbit(model, outdir: Path, rows, w: float, cls: str, transient: float, record: int):
    """Class of the steady state reached from the diagram's own stable orbit at w (its phase theta = 0)."""
    from contin import aft
    from contin.checkpoint import read_records
    from contin.poincare import steady_state

    row = stable_row_near(rows, w, cls)
    if row is None:
        return None
    rec = next(r for r in read_records(outdir / "state.jsonl") if r["type"] == "point" and r["row"] == row)
    nu = int(rec["nu"])
    U = np.array(rec["u"], dtype=float).reshape(-1, 4)
    x, xp = aft.synthesize(U, 2 * U.shape[0])  # at least 2H+1 samples: only theta = 0 is used
    _, res = steady_state(model, {"w": w}, x0=x[0], v0=(w / nu) * xp[0], transient=transient, record=record)
    return brute_force_class(res.period if res is not None else None)


def brute_force_class(period) -> str:
    """The brute-force class of a steady-state period (None: not periodic)."""
    return {1: "harmonic", 2: "subharmonic"}.get(period, "neither")


def agrees(bf: str, diagram: str) -> bool:
    """Same class; where the diagram has two stable solutions the simulation may settle on either."""
    return bf in diagram.split("+")


def speed_grid(rows, lo: float, hi: float) -> tuple[np.ndarray, float]:
    """Speeds over [lo, hi] at the diagram's resolution (median w spacing of the harmonic branch)."""
    m = np.array([int(n) == 1 for n in rows["nu"]])
    ws = np.unique(np.round(rows["w"][m] if m.any() else rows["w"], 9))
    dw = float(np.median(np.diff(ws))) if ws.size > 1 else (hi - lo)
    n = max(int(round((hi - lo) / dw)), 1)
    return np.linspace(lo, hi, n + 1), dw


def main(argv=None) -> int:
    from contin.blas import limit_blas_threads
    from contin.catalog import build_model
    from contin.poincare import steady_state
    from contin.models.bearing_rotor import stable_subharmonic_interval
    from contin.results import read_csv

    limit_blas_threads(1)
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="small settings (a smoke run; figures not converged)")
    ap.add_argument("--every", type=int, default=1,
                    help="simulate every k-th speed of the grid and extrapolate the brute-force time")
    ap.add_argument("--transient", type=float, default=1500, help="revolutions to steady state")
    ap.add_argument("--record", type=int, default=40, help="revolutions classified")
    ap.add_argument("--harmonics", default="40,60,80,120", help="H values (of w/2) for the nu = 2 convergence")
    ap.add_argument("--no-convergence", action="store_true", help="skip the nu = 2 convergence study (part 2)")
    args = ap.parse_args(argv)
    overrides = []
    hs = [int(h) for h in args.harmonics.split(",")]
    every = max(args.every, 1)
    if args.quick:
        overrides = ["analysis.range=[2.12, 2.2]", "analysis.start=2.12", "analysis.harmonics=12", "analysis.samples=256",
                     "analysis.stability_options.steps_per_period=2048", "analysis.starts=[]"]
        args.transient, args.record, hs = 30, 8, [12, 16]
    tmp = Path(tempfile.mkdtemp(prefix="bench_rotor_"))

    # 1. the diagram, then brute force at the same speeds
    t0 = time.perf_counter()
    scene, summary = run("rotor_f0_05", overrides, tmp / "diagram")
    t_diagram = time.perf_counter() - t0
    rows = read_csv(tmp / "diagram" / "branches.csv")
    lo, hi = scene.analysis["range"]
    grid, dw = speed_grid(rows, lo, hi)
    if args.quick:
        every = max(len(grid) // 3, 1)  # three speeds
    simulated = np.arange(0, len(grid), every)
    model = build_model("bearing_rotor", {"f0": 0.5})
    rng = np.random.default_rng(1)
    print(f"diagram: {t_diagram:.1f} s for {len(rows['w'])} points "
          f"({len(summary['analysis']['branches'])} branches); speed resolution dw = {dw:.4g}")
    print(f"brute force: {len(simulated)} of the {len(grid)} speeds w = {lo:g}..{hi:g} step {dw:.4g}, "
          f"{args.transient:g} + {args.record} revolutions each")
    print(f"{'w':>8s} {'brute force':>12s} {'diagram':>22s} {'agree':>6s} {'time s':>7s}")
    t_bf, n_agree, disagree = [], 0, []
    for i in simulated:
        w = float(grid[i])
        t1 = time.perf_counter()
        _, res = steady_state(model, {"w": w}, x0=1e-3 * rng.normal(size=4), v0=np.zeros(4),
                              transient=args.transient, record=args.record)
        t_bf.append(time.perf_counter() - t1)
        bf, dg = brute_force_class(res.period if res is not None else None), diagram_class(rows, w)
        ok = agrees(bf, dg)
        n_agree += ok
        if not ok and dg != "neither":
            disagree.append((w, bf, dg))
        print(f"{w:8.4f} {bf:>12s} {dg:>22s} {'yes' if ok else 'NO':>6s} {t_bf[-1]:7.2f}")
    total = float(np.sum(t_bf)) * len(grid) / len(simulated)
    how = "measured" if len(simulated) == len(grid) else f"extrapolated from {len(simulated)} speeds"
    print(f"classification: same class at {n_agree} of {len(simulated)} speeds")
    if disagree:
        # where the simulation from near rest ended elsewhere, start it on the diagram's stable orbit:
        # if it stays there, the two attractors coexist and the sweep from rest found the other one
        n_stay = 0
        print(f"{len(disagree)} speeds where the diagram has a stable solution the simulation from rest did not "
              f"reach; simulated again from the diagram's orbit (200 + {args.record} revolutions):")
        print(f"{'w':>8s} {'from rest':>12s} {'from orbit':>12s} {'diagram':>22s}")
        for w, bf, dg in disagree:
            cls = dg.split("+")[0]
            again = simulate_from_orbit(model, tmp / "diagram", rows, w, cls, 200, args.record)
            n_stay += again is not None and again in dg.split("+")
            print(f"{w:8.4f} {bf:>12s} {str(again):>12s} {dg:>22s}")
        print(f"started on the diagram's orbit, the simulation keeps its class at {n_stay} of {len(disagree)} of them "
              f"(coexisting attractors)")
    print(f"brute force: {np.mean(t_bf):.2f} s per speed, {total:.1f} s for the {len(grid)} speeds ({how}); "
          f"diagram {t_diagram:.1f} s; ratio brute force / diagram = {total / t_diagram:.1f}x")

    # 2. the stable nu = 2 interval against H
    if args.quick or args.no_convergence:
        print("(the nu = 2 convergence study is skipped)")
        return 0
    print(f"\n{'H (of w/2)':>10s} {'samples':>8s} {'stable from':>12s} {'to':>10s} {'time s':>7s}")
    results = []
    for H in hs:
        N = max(1024, 25 * H)
        ov = ["analysis.harmonics=40", "analysis.samples=1024", "analysis.range=[2.1, 2.25]", "analysis.start=2.16",
              "analysis.starts=[]", "analysis.subharmonic=2", f"analysis.harmonics={H}", f"analysis.samples={N}",
              "analysis.start_from=simulation", "analysis.both_ways=true",
              "analysis.start_simulation={transient: 1500, steps_per_period: 4096}",
              "analysis.stability_options.steps_per_period=8192",
              "analysis.continuation={ds: 0.005, ds_max: 0.03, newton_tol: 1.0e-9}"]
        t1 = time.perf_counter()
        run("rotor_f0_05", ov, tmp / f"nu2_H{H}")
        dt = time.perf_counter() - t1
        r, sp = read_csv(tmp / f"nu2_H{H}" / "branches.csv"), read_csv(tmp / f"nu2_H{H}" / "special_points.csv")
        iv = stable_subharmonic_interval(r, sp)
        results.append((H, N, iv, dt))
    ref = results[-1][2]
    for H, N, iv, dt in results:
        if iv is None:
            print(f"{H:10d} {N:8d} {'none':>12s} {'':>10s} {dt:7.1f}")
            continue
        d = "" if ref is None else f"  (change vs H={hs[-1]}: {abs(iv[0] - ref[0]):.1e}, {abs(iv[1] - ref[1]):.1e})"
        print(f"{H:10d} {N:8d} {iv[0]:12.5f} {iv[1]:10.5f} {dt:7.1f}{d}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
