"""Benchmark: a 24-point sweep run serially against the same sweep on a local Dask cluster.

The sweep is the damped Mathieu-Duffing scene (``scenes/mathieu_duffing_pd.yaml``:
the trivial branch, its two period doublings and the switched nu = 2
branches) over a 6 x 4 grid of the parametric amplitude ``eps`` and the
damping ``c``, with finer steps than the scene's. Both runs go through
:func:`contin.app.sweep.run_sweep`:

- serial: the points one after another in this process (``--serial``),
  after one untimed point, so that this process has loaded its kernels and
  the plotting stack, as every worker does in its warm-up;
- cluster: the embedded ``LocalCluster`` with one single-threaded worker
  process per core (the default of ``contin sweep``), timed from the start
  of the command to its end: cluster start, worker warm-up, the runs and
  the shutdown all count.

The script prints both wall times, the parts of the cluster's, the ratio,
and whether the two sweeps wrote the same branches (they must).

    python scripts/bench/bench_sweep.py [--workers N] [--quick]
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
from pathlib import Path

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")
os.environ.setdefault("MPLBACKEND", "Agg")

ROOT = Path(__file__).resolve().parents[2]


def same_branches(a: Path, b: Path) -> bool:
    import numpy as np

    from contin.output.results import read_csv

    for d in sorted((a / "points").iterdir()):
        ra, rb = read_csv(d / "branches.csv"), read_csv(b / "points" / d.name / "branches.csv")
        if list(ra) != list(rb):
            return False
        for col in ra:
            x, y = ra[col], rb[col]
            if x.dtype.kind in "fb":
                if not np.allclose(x.astype(float), y.astype(float), rtol=1e-12, atol=1e-13, equal_nan=True):
                    return False
            elif list(x) != list(y):
                return False
    return True


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 1, help="cluster workers (default: cores)")
    ap.add_argument("--quick", action="store_true", help="4 points at coarse settings, one worker (a smoke run)")
    args = ap.parse_args()

    from contin.util.blas import limit_blas_threads
    from contin.app.sweep import SweepOptions, run_sweep
    from contin.app.sweep_grid import parse_grid
    from contin.app.sweep_point import PointTask, run_point

    limit_blas_threads()
    scene = ROOT / "scenes" / "mathieu_duffing_pd.yaml"
    if args.quick:
        grid = (parse_grid("model.parameters.eps=0.3,0.5"), parse_grid("model.parameters.c=0.1,0.2"))
        overrides = ("analysis.harmonics=4", "output.plots=false")
        workers = 1  # the cluster's path all the same; a second worker's warm-up would double the smoke run's cost
    else:
        grid = (parse_grid("model.parameters.eps=0.2:0.6:6"), parse_grid("model.parameters.c=0.05,0.1,0.15,0.2"))
        overrides = ("analysis.continuation={ds: 0.005, ds_max: 0.01}",)
        workers = args.workers
    npoints = len(grid[0].values) * len(grid[1].values)
    load_before = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    with tempfile.TemporaryDirectory(prefix="contin-bench-sweep-") as tmp:
        tmp = Path(tmp)
        # one untimed point: this process loads what each worker loads in its warm-up
        text = scene.read_text()
        (tmp / "warm").mkdir()
        run_point(PointTask(text, str(scene), overrides, str(tmp / "warm"), "warm", 0, ()))

        t0 = time.perf_counter()
        serial = run_sweep(SweepOptions(str(scene), grid, str(tmp / "serial"), overrides=overrides, serial=True,
                                        progress=False, map_plot=False))
        t_serial = time.perf_counter() - t0

        t0 = time.perf_counter()
        cluster = run_sweep(SweepOptions(str(scene), grid, str(tmp / "cluster"), overrides=overrides,
                                         workers=workers, progress=False, map_plot=False))
        t_cluster = time.perf_counter() - t0
        parts = json.loads((tmp / "cluster" / "sweep.json").read_text())["timings"]
        ok = (len(serial.failed) == 0 and len(cluster.failed) == 0
              and same_branches(tmp / "serial", tmp / "cluster"))
        runs = sum(r.get("run_seconds") or 0.0 for r in serial.records)

    print(f"sweep of {npoints} points ({scene.name}, grid "
          + " x ".join(f"{a.key.rsplit('.', 1)[-1]}[{len(a.values)}]" for a in grid) + f"), {os.cpu_count()} cores")
    print(f"{'':28s} {'wall [s]':>9s}")
    print(f"{'serial, one process':28s} {t_serial:9.2f}   (runs {runs:.2f} s, {runs / npoints:.2f} s a point)")
    print(f"{f'local cluster, {workers} workers':28s} {t_cluster:9.2f}   (start {parts.get('cluster_start', 0):.2f}, "
          f"warm-up {parts.get('warm_up', 0):.2f}, runs {parts.get('tasks', 0):.2f}, "
          f"shutdown {parts.get('shutdown', 0):.2f})")
    print(f"ratio serial / cluster: {t_serial / t_cluster:.2f}   "
          f"(runs only: {t_serial / max(parts.get('tasks', t_cluster), 1e-9):.2f})")
    print(f"same branches in both sweeps: {'yes' if ok else 'NO'}")
    load_after = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"load average (1 min) before / after: {load_before:.1f} / {load_after:.1f} on {os.cpu_count()} cores "
          "(other processes take cores from the workers: the ratio is only meaningful on an idle machine)")
    if not ok:
        raise SystemExit(1)


if __name__ == "__main__":
    main()
