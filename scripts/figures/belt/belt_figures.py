"""Every table and figure of the timing-belt paper (seed 003), in one run.

Runs, in this process, the scripts that reproduce each result and writes all
figures into one directory (default ``results/belt``):

==========================  ===============================================
``belt_table1.py``          Table 1 (static deflection against n), misprint
``belt_modes.py``           Fig. 2 (frequencies against beta), Fig. 3 (modes)
``belt_static.py``          Fig. 4, 5 (restoring-force curves, magnet strengths)
``belt_backbones.py``       Fig. 6, 7, 8 (backbones: beta, alpha, magnet)
``belt_forced.py``          Fig. 9 (forced response, folds, switching path)
``belt_subharmonic.py``     1/2 and 1/3 subharmonic responses
``bench_belt.py``           accuracy against time in n and H (Fig. 9 response)
==========================  ===============================================

The full run takes a few minutes. ``--quick`` is a smoke run of this driver
(Table 1, Fig. 2-3 and Fig. 6-8 at their quick settings); each script also has
its own ``--quick``.

    python scripts/figures/belt/belt_figures.py [--quick] [--out DIR]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

# the sibling figure scripts, and the belt benchmark from scripts/bench/
HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(HERE), str(HERE.parents[1] / "bench")]

from contin.util.blas import limit_blas_threads  # noqa: E402

import belt_backbones  # noqa: E402
import belt_forced  # noqa: E402
import belt_modes  # noqa: E402
import belt_static  # noqa: E402
import belt_subharmonic  # noqa: E402
import belt_table1  # noqa: E402
import bench_belt  # noqa: E402


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="smoke run: Table 1, Fig. 2-3, 6-8 at quick settings")
    ap.add_argument("--out", default="results/belt")
    args = ap.parse_args(argv)
    limit_blas_threads(1)  # small matrices: one BLAS thread is faster (see README)
    out = ["--out", args.out]
    quick = ["--quick"] if args.quick else []
    steps = [("Table 1", belt_table1.main, quick), ("Fig. 2-3", belt_modes.main, quick + out),
             ("Fig. 6-8", belt_backbones.main, quick + out)]
    if not args.quick:
        steps += [("Fig. 4-5", belt_static.main, out), ("Fig. 9", belt_forced.main, out),
                  ("subharmonics", belt_subharmonic.main, out), ("benchmark", bench_belt.main, [])]
    t_all = time.perf_counter()
    for label, fn, a in steps:
        t0 = time.perf_counter()
        print(f"==== {label} ====")
        fn(a)
        print(f"[{label}: {time.perf_counter() - t0:.1f} s]\n")
    print(f"all done in {time.perf_counter() - t_all:.1f} s; figures in {args.out}")


if __name__ == "__main__":
    main()
