"""Benchmark: the rotor paper's Fig. 3 by continuation against the simulation sweep that draws it.

Bearing rotor at f0 = 0.5, w in [1.6, 2.6], both timed in this run, side by side:

- the sweep (``scripts/figures/rotor/rotor_fig3.py``, the paper's way): the speed stepped up by 0.01 after
  a run-up from rest, then down, each speed 600 revolutions of transient and 400 recorded with 4096 RK4
  steps a revolution, the disc's whirl split into its spectral lines;
- the continuation (``scripts/figures/rotor/rotor_fig3_continuation.py``): the main job's diagram
  (harmonic and 1/2-subharmonic branches with their stability and special points) and the tori of the
  self-excited whirl as invariant circles (31 points) fitted to simulations at 1.9, 2.1 and 2.3 and
  stepped in the speed, with their stability.

Printed: both times and their ratio, and where the sweeps whirl on a torus, the largest difference of
``p_f / w`` and of the self-excited radius between the sweeps' speeds and the tori's circles
(interpolated; a sweep whose self-excited line is below half the torus' whirls on another motion and is
counted apart).

    python scripts/bench/bench_rotor_fig3.py            # about 8 minutes
    python scripts/bench/bench_rotor_fig3.py --quick    # three speeds, one torus of three circles, no diagram
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np

from contin.api import run

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "figures" / "rotor"))
from rotor_fig3 import FULL, run_sweeps  # noqa: E402
from rotor_fig3_continuation import SCENES, torus_rows  # noqa: E402


def compare(sweeps: dict, rows: list[dict]) -> tuple[float, float, int, int]:
    """The largest difference of ``p_f / w`` and of the self-excited radius between the tori (interpolated in
    ``w`` within each torus' circles) and the sweeps' speeds on them, how many speeds were compared, and how
    many were left out: a sweep whose self-excited line is below half the torus' there whirls on another
    motion (the harmonic orbit's transient, below the hysteresis' upper end)."""
    d_ratio = d_radius = 0.0
    count = other = 0
    for fit in dict.fromkeys(r["fit"] for r in rows):
        mine = sorted((r for r in rows if r["fit"] == fit), key=lambda r: r["w"])
        w = np.array([r["w"] for r in mine])
        for sw in sweeps.values():
            inside = sw.has_pf & (sw.w >= w[0]) & (sw.w <= w[-1])
            if not np.any(inside) or len(w) < 2:
                continue
            ratio = np.interp(sw.w[inside], w, [r["ratio"] for r in mine])
            radius = np.interp(sw.w[inside], w, [r["self_excited"] for r in mine])
            on = sw.self_excited[inside] >= 0.5 * radius
            other += int(np.count_nonzero(~on))
            if np.any(on):
                d_ratio = max(d_ratio, float(np.max(np.abs(sw.pf[inside] / sw.w[inside] - ratio)[on])))
                d_radius = max(d_radius, float(np.max(np.abs(sw.self_excited[inside] - radius)[on])))
            count += int(np.count_nonzero(on))
    return d_ratio, d_radius, count, other


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="three speeds, one torus of three circles, no diagram")
    args = ap.parse_args(argv)
    if args.quick:
        speeds, transient, record, run_up = np.array([1.88, 1.9, 1.92]), 300.0, 200, ()
        fits, span, step, min_step, stability = (1.9,), (1.89, 1.91), 0.01, 2e-3, False
    else:
        lo, hi, dw = FULL["w"]
        speeds = np.round(np.arange(lo, hi + 0.5 * dw, dw), 10)
        transient, record, run_up = FULL["transient"], FULL["record"], FULL["run_up"]
        fits, span, step, min_step, stability = (1.9, 2.1, 2.3), (1.6, 2.6), 0.02, 1e-3, True
    print(f"bearing rotor, f0 = 0.5: sweep of {speeds.size} speeds up and down, {transient:g} + {record} "
          f"revolutions each; continuation: {'no diagram, ' if args.quick else 'the main job, '}"
          f"tori fitted at {', '.join(map(str, fits))}", flush=True)
    t0 = time.perf_counter()
    sweeps = {name: sw for name, sw in run_sweeps(0.5, speeds, transient, record, FULL["steps"], run_up)
              if name != "run-up"}
    t_sweep = time.perf_counter() - t0
    print(f"sweep: {t_sweep:.1f} s", flush=True)
    t0 = time.perf_counter()
    if not args.quick:
        with tempfile.TemporaryDirectory() as tmp:
            result = run(str(SCENES[0.5]), Path(tmp) / "diagram")
        print(f"diagram: {result.status}, {len(result.branches)} branches, {time.perf_counter() - t0:.1f} s",
              flush=True)
    rows = []
    for fit in fits:
        rows += torus_rows(0.5, fit, 31, span, step, min_step, stability)[0]
    t_cont = time.perf_counter() - t0
    d_ratio, d_radius, count, other = compare(sweeps, rows)
    print(f"continuation: {t_cont:.1f} s ({len(rows)} circles)")
    print(f"sweep / continuation: {t_sweep / t_cont:.2f}x")
    print(f"at {count} speeds of the sweeps on a torus: p_f/w within {d_ratio:.2e}, self-excited radius within "
          f"{d_radius:.2e} ({other} speeds inside a torus' range whirl on another motion)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
