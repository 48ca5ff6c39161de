"""Benchmark: independent flows integrated side by side in threads against one after another.

The bearing rotor at f0 = 0.5, w = 2.16, 4096 RK4 steps a revolution, the contact switches
located, one BLAS thread. Timed with ``CONTIN_THREADS`` = 1 and with the threads asked
(default: the cores available), alternately, the fastest of ``--repeat`` each:

1. an invariant circle of ``--points`` points (the states a simulation passes at forcing
   phase 0): its linearisation (one variational flow per point), its residual (one plain
   flow per point) and the points' and midpoints' Jacobians (its stability's input);
2. the 1/2-subharmonic orbit by multiple shooting with 4 segments: a linearisation and a
   residual.

Printed: the times, the ratio serial / threaded, and whether the numbers are the same bit
for bit (they must be: each flow writes only its own arrays).

    python scripts/bench/bench_threads.py [--quick] [--threads 2] [--points 31] [--repeat 5]
"""

from __future__ import annotations

import argparse
import os
import time

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np

W0 = 2.16
S = 4096


def fastest(fn, repeat: int) -> tuple[float, object]:
    out = fn()  # warm-up (and the result compared)
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def same(a, b) -> bool:
    if isinstance(a, (tuple, list)):
        return len(a) == len(b) and all(same(x, y) for x, y in zip(a, b))
    return bool(np.array_equal(a, b))


def main(argv=None) -> int:
    from contin.model.catalog import build_model
    from contin.timedomain.invariant_circle import CircleOptions, InvariantCircleProblem, point_jacobians
    from contin.timedomain.multiple_shooting import ShootingProblem
    from contin.timedomain.shooting_options import ShootingOptions
    from contin.timedomain.simulation import simulate
    from contin.util import workers
    from contin.util.blas import limit_blas_threads

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="small settings (a smoke run; the figures mean nothing)")
    ap.add_argument("--threads", type=int, default=None, help="threads to compare with one (default: the cores)")
    ap.add_argument("--points", type=int, default=31, help="points of the invariant circle (odd)")
    ap.add_argument("--repeat", type=int, default=5, help="timed calls per setting (fastest kept)")
    args = ap.parse_args(argv)
    steps, settle = S, 400
    if args.quick:
        steps, settle, args.points, args.repeat = 1024, 20, 5, 1
    n_threads = args.threads or workers.threads()
    if n_threads < 2:
        print(f"only {n_threads} thread available: nothing to compare (set --threads 2)")
    limit_blas_threads(1)
    model = build_model("bearing_rotor", {"f0": 0.5})
    run = simulate(model, {"w": W0}, periods=settle + args.points, steps_per_period=steps, record_every=steps)
    U = np.hstack([run.x, run.v])[-args.points:]
    circle = InvariantCircleProblem(model, "w", options=CircleOptions(points=args.points, steps_per_period=steps),
                                    anchor=U)
    u = circle.unknowns(U, 0.55)
    shooting = ShootingProblem(model, "w", options=ShootingOptions(steps_per_period=steps, subharmonic=2, segments=4))
    us = shooting.start_unknowns(U[-1], W0)

    def fresh(fn):
        def call():
            shooting._cache.clear()  # else a repeated linearisation is a cache hit
            return fn()
        return call

    cases = [
        (f"circle of {args.points} points: linearisation", lambda: circle.linearize(u, W0)),
        (f"circle of {args.points} points: residual", lambda: circle.residual(u, W0)),
        (f"circle of {args.points} points: Jacobians at points and midpoints",
         lambda: point_jacobians(circle, u, W0, midpoints=True)),
        ("nu = 2 orbit, 4 segments: linearisation", fresh(lambda: shooting.linearize(us, W0))),
        ("nu = 2 orbit, 4 segments: residual", lambda: shooting.residual(us, W0)),
    ]
    print(f"bearing rotor f0 = 0.5, w = {W0}, {steps} RK4 steps a revolution; 1 thread against {n_threads}")
    print(f"{'':58s} {'1 thread ms':>12s} {f'{n_threads} threads ms':>14s} {'ratio':>7s} {'same':>5s}")
    before = workers.threads()
    try:
        for name, fn in cases:
            workers.set_threads(1)
            t1, r1 = fastest(fn, args.repeat)
            workers.set_threads(n_threads)
            tn, rn = fastest(fn, args.repeat)
            print(f"{name:58s} {1e3 * t1:12.1f} {1e3 * tn:14.1f} {t1 / tn:6.2f}x {'yes' if same(r1, rn) else 'NO':>5s}")
    finally:
        workers.set_threads(before)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
