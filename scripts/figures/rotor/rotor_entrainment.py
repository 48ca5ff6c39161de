"""The 1/2-subharmonic region of the bearing rotor in (w, f0) and (w, c2), against the paper's cases.

Runs scenes/rotor_entrainment_f0.yaml and scenes/rotor_entrainment_c2.yaml (period-doubling
curves of the harmonic branch, H = 40, continued from the two period doublings at f0 = 0.5,
c2 = 0.05) and prints, for each case of Inagaki, Ishida & Hayashi (2005):

- f0 = 0.5: the speed interval where the harmonic solution has a multiplier beyond -1 and the
  1/2 subharmonic is born (paper, Fig. 4: a stable subharmonic over a speed range);
- f0 = 0.2: the same interval, narrower (Fig. 6);
- f0 = 0: below the tip of the region, no period doubling (the harmonic solution is stable,
  no subharmonic);
- c2 = 5.0: no period doubling (Fig. 8: only the stable harmonic solution);

with the smallest f0 of the region (the tip of the tongue), where the curves end and why, how
far the period doublings located by the independent one-parameter runs lie from the curves, and
the period doublings of the integrated flow found by shooting (contin.timedomain.shooting) at the scenes'
`shooting` values: the region where the harmonic balance cannot follow the orbit (the bearing
leaving its casing) and where it ends.

    python scripts/figures/rotor/rotor_entrainment.py            # both scenes in full, ~10 min on two cores
    python scripts/figures/rotor/rotor_entrainment.py --quick    # short stretches of the curves, ~10 s
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from contin.util.blas import limit_blas_threads
from contin.output.results import read_csv
from contin.app.runner import run_scene
from contin.scene.parse import load_scene

ROOT = Path(__file__).resolve().parents[3]

# --quick: H = 20 (still in permanent contact at f0 = 0.5, c2 = 0.05, where the truncation error is ~2e-3,
# tests/models/test_rotor_floquet.py), short stretches of the curves; in (w, c2) only the lower period
# doubling (w = 2.147), with one coarse shooting scan
SMALL = ["analysis.harmonics=20", "analysis.samples=512"]
QUICK = {
    "f0": SMALL + ["analysis.range=[2.1, 2.25]", "analysis.second_range=[0.45, 0.5]", "analysis.overlay=[]",
                   "analysis.shooting=[]"],
    "c2": SMALL + ["analysis.range=[2.1, 2.17]", "analysis.second_range=[0.05, 0.1]", "analysis.overlay=[5.0]",
                   "analysis.shooting=[0.05]", "analysis.shooting_points=3", "analysis.shooting_refine=0",
                   "analysis.shooting_options={steps_per_period: 1024, tol: 1e-8}"],
}


def pd_interval(points, name, value):
    """The period doublings of the one-parameter run at ``name = value``: (w values, largest distance to a curve)."""
    if name not in points:  # no special point in any run
        return np.array([]), None
    sel = (points[name] == value) & (points["kind"] == "pd")
    w = np.sort(points["w"][sel])
    d = points["distance"][sel]
    d = d[np.isfinite(d)] if d.dtype.kind == "f" else np.array([])
    return w, (float(d.max()) if d.size else None)


def report(outdir: Path, name: str) -> dict:
    summary = json.loads((outdir / "summary.json").read_text())
    pts = read_csv(outdir / "one_parameter_points.csv")
    cpts = read_csv(outdir / "curve_points.csv")
    out = {"summary": summary, "points": pts}
    print(f"\n== (w, {name}): {len(summary['analysis']['curves'])} period-doubling curve(s), "
          f"{summary['timings']['total']:.1f} s")
    for c in summary["analysis"]["curves"]:
        rng = c.get(f"{name}_range", [np.nan, np.nan])
        print(f"  curve {c['curve']}: {c['points']} points, {name} in [{rng[0]:.6g}, {rng[1]:.6g}], "
              f"w in [{c['w_range'][0]:.6g}, {c['w_range'][1]:.6g}]")
    for i in range(len(cpts["kind"])):
        kind = cpts["kind"][i]
        if kind == "extremum" and cpts["parameter"][i] == name:
            print(f"  smallest/largest {name} of a curve (extremum): {name} = {cpts[name][i]:.8g} at "
                  f"w = {cpts['w'][i]:.8g}")
        if kind == "end" and not cpts["located"][i]:
            reason = "grazing: the bearing orbit starts to leave its casing" if "discontinuous" in cpts["detail"][i] \
                else cpts["detail"][i][:100]
            print(f"  a curve stops at (w, {name}) = ({cpts['w'][i]:.6g}, {cpts[name][i]:.6g}): {reason}")
    for run in summary["analysis"]["one_parameter_runs"]:
        value = run[name]
        if run["status"] == "start_failed":
            print(f"  one-parameter run at {name} = {value:g}: no start ({run['message'][:80]})")
            continue
        w, dist = pd_interval(pts, name, value)
        span = f"w in [{w[0]:.6g}, {w[-1]:.6g}] (width {w[-1] - w[0]:.4g})" if w.size >= 2 else \
            (f"w = {w[0]:.6g}" if w.size else "no period doubling in the speed range")
        extra = "" if dist is None else f"; distance to the curve {dist:.1e}"
        print(f"  one-parameter run at {name} = {value:g}: {span}{extra}")
    shooting = summary["analysis"].get("shooting") or {}
    if shooting:
        spts = read_csv(outdir / "shooting_points.csv") if (outdir / "shooting_points.csv").stat().st_size else {}
        print(f"  shooting on the integrated flow ({shooting['options']['steps_per_period']} RK4 steps per "
              f"revolution, switches located):")
        for run in shooting["runs"]:
            value, ws = run[name], run.get("period_doublings", [])
            near = ""
            if ws and name in spts:
                d = spts["distance"][spts[name] == value]
                d = d[np.isfinite(d)] if d.dtype.kind == "f" else np.array([])
                near = f"; harmonic-balance curve within {d.max():.1e}" if d.size else "; no harmonic-balance curve here"
            span = f"w in [{ws[0]:.6f}, {ws[-1]:.6f}]" if len(ws) >= 2 else (f"w = {ws[0]:.6f}" if ws else "none")
            print(f"    {name} = {value:g}: period doubling {span}{near}"
                  + ("" if run["status"] == "complete" else f" ({run['message'][:80]})"))
        for b in shooting["region_ends"]:
            print(f"    the region ends between {name} = {b['inside']:.5g} (period doubling) and {b['outside']:.5g} (none)")
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="short stretches of the curves (a smoke run)")
    ap.add_argument("-o", "--outdir", default="results/rotor_entrainment")
    args = ap.parse_args(argv)
    limit_blas_threads(1)
    base = Path(args.outdir)
    results = {}
    t0 = time.perf_counter()
    for name in ("f0", "c2"):
        scene = load_scene(ROOT / "scenes" / f"rotor_entrainment_{name}.yaml", QUICK[name] if args.quick else ())
        run_scene(scene, base / name, progress=False)
        results[name] = report(base / name, name)
    f0 = results["f0"]["points"]
    c2 = results["c2"]["points"]
    print("\n== against the paper's cases (Inagaki, Ishida & Hayashi 2005)")
    w5, _ = pd_interval(f0, "f0", 0.5)
    print(f"  f0 = 0.5 (Fig. 4): the harmonic solution doubles its period over w in [{w5[0]:.5f}, {w5[-1]:.5f}];"
          f" the 1/2 subharmonic is born at both ends")
    if 0.2 in set(f0["f0"]):
        w2, _ = pd_interval(f0, "f0", 0.2)
        print(f"  f0 = 0.2 (Fig. 6): over w in [{w2[0]:.5f}, {w2[-1]:.5f}], narrower "
              f"({w2[-1] - w2[0]:.4f} against {w5[-1] - w5[0]:.4f})")
    tips = [c for c in results["f0"]["summary"]["analysis"]["curves"] if "f0_range" in c]
    if tips and not args.quick:
        f0_min = min(c["f0_range"][0] for c in tips)
        print(f"  f0 = 0 (no subharmonic in the paper): the region ends at its tip f0 = {f0_min:.5f} > 0")
    runs_c2 = {r["c2"]: r for r in results["c2"]["summary"]["analysis"]["one_parameter_runs"]}
    w_c2 = pd_interval(c2, "c2", 5.0)[0] if runs_c2.get(5.0, {}).get("status") == "range_end" else None
    if w_c2 is not None:
        print(f"  c2 = 5.0 (Fig. 8, only the stable harmonic solution): "
              f"{'no period doubling' if not w_c2.size else f'period doublings at {w_c2}'}")
    print(f"\ntotal {time.perf_counter() - t0:.1f} s; results and figures in {base}/f0, {base}/c2")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
