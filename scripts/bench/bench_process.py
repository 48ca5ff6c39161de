"""Benchmark: a small run as a whole process, against the plain numpy script that computes the same branch.

Times, side by side and interleaved (the median of ``--repeat`` rounds), fresh Python processes of

- ``bench_plain_duffing.py`` (this folder): the forced Duffing branch at ``H = 5`` with Hill stability in plain
  numpy, what a user would write without contin;
- ``contin run duffing`` at ``H = 5`` with Hill stability and no figure (``output.plots: false``), and the same
  run drawing its figure;
- the floor any numba program pays here: the interpreter importing numpy, scipy.linalg and numba and calling
  one kernel from numba's disk cache.

Every process starts warm (compiled kernels and bytecode cached by a first round that is not counted) and with
bytecode writing allowed (``PYTHONDONTWRITEBYTECODE`` removed: with it set, each process compiles contin's
modules from source, about 0.35 s here). The script prints the times, the ratios to the plain script, and both
branches' folds, so that the two are seen to compute the same thing.

    python scripts/bench/bench_process.py [--repeat 5] [--quick]
"""

from __future__ import annotations

import argparse
import csv
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
SCENE = HERE.parents[1] / "scenes" / "duffing.yaml"
SMALL = ["--set", "analysis.harmonics=5", "--set", "analysis.stability=hill"]

FLOOR = """
import numpy, scipy.linalg, numba

@numba.njit(cache=True)
def one(x):
    return x + 1.0

one(1.0)
"""


def _timed(cmd, env) -> float:
    t = time.perf_counter()
    subprocess.run(cmd, env=env, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - t


def _folds_plain(path: Path) -> list[float]:
    rows = list(csv.DictReader(path.open()))
    s = [int(r["stable"]) for r in rows]
    return [float(rows[i]["w"]) for i in range(1, len(rows)) if s[i] != s[i - 1]]


def _folds_contin(out: Path) -> list[float]:
    return [float(r["w"]) for r in csv.DictReader((out / "special_points.csv").open()) if r["kind"] == "fold"]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5, help="rounds counted (each runs every process once)")
    ap.add_argument("--quick", action="store_true", help="one counted round")
    args = ap.parse_args(argv)
    rounds = 1 if args.quick else max(1, args.repeat)
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        floor = tmp / "floor.py"
        floor.write_text(FLOOR)
        plain_csv = tmp / "plain.csv"

        def contin(name, plots):
            out = tmp / name
            extra = [] if plots else ["--set", "output.plots=false"]
            return [sys.executable, "-m", "contin", "run", str(SCENE), "-o", str(out), "--force", "--quiet",
                    *SMALL, *extra]

        cases = {
            "plain numpy script": [sys.executable, str(HERE / "bench_plain_duffing.py"), "--out", str(plain_csv)],
            "contin run, no figure": contin("nofig", False),
            "contin run, with its figure": contin("fig", True),
            "floor: numpy + scipy.linalg + numba, one cached kernel": [sys.executable, str(floor)],
        }
        times = {k: [] for k in cases}
        for r in range(rounds + 1):  # round 0 warms the caches
            for name, cmd in cases.items():
                t = _timed(cmd, env)
                if r:
                    times[name].append(t)
        med = {k: statistics.median(v) for k, v in times.items()}
        base = med["plain numpy script"]
        print(f"median of {rounds} round(s), fresh processes, warm caches:")
        for name, t in med.items():
            print(f"  {name:56s} {t:6.2f} s  {t / base:5.1f}x the plain script")
        print(f"  contin (no figure) over the floor: {med['contin run, no figure'] / med[next(reversed(med))]:.2f}x")
        print(f"folds, plain script (first unstable/stable point): {', '.join(f'{w:.5f}' for w in _folds_plain(plain_csv))}")
        print(f"folds, contin (located): {', '.join(f'{w:.7f}' for w in _folds_contin(tmp / 'nofig'))}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
