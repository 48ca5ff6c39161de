"""Where a run's special points cost: per event, the points located, the solves on the arc and the time.

Runs a scene in this process (as ``contin run SCENE -o OUT``) with the engine's locator counted: each
location of an event and each solve on the arc between two stored points, with the wall time spent
locating each kind. The main job's shooting legs spend most of their location time on grazing points.

    python scripts/bench/bench_locations.py [scenes/rotor_f0_05.yaml] [-o OUT]
    python scripts/bench/bench_locations.py --quick      # scenes/gap_oscillator.yaml, a few seconds
"""

from __future__ import annotations

import argparse
import collections
import tempfile
import time
from pathlib import Path

from contin.engine import location
from contin.timedomain import multiple_shooting, variational


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    scenes = Path(__file__).resolve().parents[2] / "scenes"
    ap.add_argument("scene", nargs="?", default=str(scenes / "rotor_f0_05.yaml"))
    ap.add_argument("-o", "--out", default=None, help="output directory (default: a temporary one)")
    ap.add_argument("--quick", action="store_true", help="the stop oscillator's grazing scene instead")
    args = ap.parse_args(argv)
    if args.quick:
        args.scene = str(scenes / "gap_oscillator.yaml")
    # per event: located, solves on the arc, seconds, variational flows (linearisations of shooting orbits),
    # plain flows (residuals) and flows without the variational equations (graze and switches alone)
    stats = collections.defaultdict(lambda: [0, 0, 0.0, 0, 0, 0])
    cls = location.EventLocation
    locate, solve = cls._locate, cls._solve_on_arc
    current = ["(steps)"]

    def counted_locate(self, ev, comp, *a, **k):
        current[0] = ev.name
        t = time.perf_counter()
        stats[ev.name][0] += 1
        try:
            return locate(self, ev, comp, *a, **k)
        finally:
            stats[ev.name][2] += time.perf_counter() - t
            current[0] = "(steps)"

    def counted_solve(self, *a, **k):
        stats[current[0]][1] += 1
        return solve(self, *a, **k)

    cls._locate, cls._solve_on_arc = counted_locate, counted_solve
    shoot = multiple_shooting.ShootingProblem
    for attr, col in (("_segment", 3), ("_run", 4)):
        def counted(self, *a, _f=getattr(shoot, attr), _c=col, **k):
            stats[current[0]][_c] += 1
            return _f(self, *a, **k)
        setattr(shoot, attr, counted)
    runs = variational.VariationalFlow.run

    def counted_run(self, *a, jacobian=True, **k):
        if not jacobian:
            stats[current[0]][5] += 1
        return runs(self, *a, jacobian=jacobian, **k)

    variational.VariationalFlow.run = counted_run
    from contin.app.cli import main as contin_main

    with tempfile.TemporaryDirectory() as tmp:
        out = args.out or str(Path(tmp) / "out")
        t = time.perf_counter()
        code = contin_main(["run", args.scene, "-o", out, "--quiet"])
        total = time.perf_counter() - t
    print(f"run: {total:.1f} s, exit status {code}")
    print("  (shooting flows: variational = linearisations; plain = residuals; contacts = graze and switches alone)")
    for name, (n, solves, sec, var, plain, passes) in sorted(stats.items(), key=lambda kv: -kv[1][2]):
        where = "" if name == "(steps)" else f"{n:4d} located, {solves:5d} solves on the arc, {sec:6.1f} s, "
        print(f"  {name:24s} {where}flows: {var} variational, {plain} plain, {passes} contacts")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
