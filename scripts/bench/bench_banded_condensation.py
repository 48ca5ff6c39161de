"""Benchmark: one elimination of the condensation, dense against banded factors, as the linear dofs grow.

The problem is a damped chain of ``n`` unit masses, each joined by springs and
dampers to its ``b`` nearest neighbours on either side (``--band``, 1: a
plain chain; finite-element rotors ordered node by node are near ``b = 7``),
with a cubic spring on the last mass and a harmonic force on the first. It is
condensed onto the last mass (:mod:`contin.hb.condensation`), so the ``n - 1``
others are eliminated, harmonic by harmonic, with blocks of bandwidths
``kl = ku = b``. One elimination is :meth:`CondensedHarmonicBalance._at` at a
new value of ``lambda = w``, as in every corrector iteration; it is timed for
the problem condensed with dense factors (``banded=False``) and with band
factors, interleaved in the same rounds, and their ratio printed.

    python scripts/bench/bench_banded_condensation.py [--sizes 50,200,800] [--harmonics 10] [--band 1]
"""

from __future__ import annotations

import argparse
import os
import time

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np

from contin.hb.condensation import CondensedHarmonicBalance
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.model.base import Model, Monomial, ParametricMatrix
from contin.model.elements.harmonic import HarmonicExcitation
from contin.model.elements.polynomial import PolynomialForce


def coupled_chain(n: int, band: int) -> Model:
    """``n`` unit masses, springs (1/d) and dampers (0.01/d) between masses ``d = 1..band`` apart and to the walls."""
    K, C = np.zeros((n, n)), np.zeros((n, n))
    for d in range(1, band + 1):
        for i in range(-d, n):  # the element from i to i + d; indices outside 0..n-1 are walls
            for A, s in ((K, 1.0 / d), (C, 0.01 / d)):
                for a, b, v in ((i, i, s), (i + d, i + d, s), (i, i + d, -s), (i + d, i, -s)):
                    if 0 <= a < n and 0 <= b < n:
                        A[a, b] += v
    one = Monomial(1.0)
    ex = np.zeros(n, dtype=int)
    ex[-1] = 3
    return Model(
        name="coupled_chain", dof_names=tuple(f"x{i + 1}" for i in range(n)), parameters={"w": 0.8},
        mass=ParametricMatrix(n, ((one, np.eye(n)),)), damping=ParametricMatrix(n, ((one, C),)),
        stiffness=ParametricMatrix(n, ((one, K),)),
        forces=[PolynomialForce(n, [(n - 1, Monomial(0.5), ex, np.zeros(n, dtype=int))], label="cubic")],
        excitations=[HarmonicExcitation(0, one)], frequency="w")


def elimination_times(n: int, H: int, band: int, min_time: float) -> tuple:
    """Median seconds of one elimination at a new ``lambda``, (dense, banded), and the banded bandwidths."""
    hb = HarmonicBalance(coupled_chain(n, band), "w", HBOptions(harmonics=H))
    problems = [CondensedHarmonicBalance(hb, [n - 1], banded=flag) for flag in (False, True)]
    lam = [0.8]

    def once(ch):
        lam[0] *= 1.0 + 1e-12  # a new lambda: the blocks are rebuilt, not taken from the cache
        t = time.perf_counter()
        ch._at(lam[0])
        return time.perf_counter() - t

    for ch in problems:  # compilation and first touch
        once(ch)
    times = ([], [])
    while not times[0] or (sum(times[0]) + sum(times[1]) < min_time and len(times[0]) < 50):
        for i, ch in enumerate(problems):
            times[i].append(once(ch))
    return float(np.median(times[0])), float(np.median(times[1])), problems[1].band, len(times[0])


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="50,200,800", help="numbers of masses n, comma-separated")
    ap.add_argument("--harmonics", type=int, default=10, help="H")
    ap.add_argument("--band", type=int, default=1, help="neighbours each mass is coupled to on either side")
    ap.add_argument("--min-time", type=float, default=1.0, help="seconds of timed rounds per size, at least one")
    ap.add_argument("--quick", action="store_true", help="50 and 200 masses, one short round each (CI)")
    args = ap.parse_args(argv)
    if args.quick:
        args.sizes, args.min_time = "50,200", 0.05
    print(f"one elimination (CondensedHarmonicBalance._at at a new w), H = {args.harmonics}, "
          f"coupling to {args.band} neighbours, condensed onto the last mass; median of the rounds")
    # "(kl, ku)" dense: the block is too wide for band storage, the "banded" problem factors it densely too
    print(f"{'n':>6} {'n_l':>6} {'(kl, ku)':>9} {'dense [ms]':>11} {'banded [ms]':>12} {'dense/banded':>13} "
          f"{'rounds':>7}")
    for n in (int(s) for s in args.sizes.split(",")):
        dense, banded, bw, rounds = elimination_times(n, args.harmonics, args.band, args.min_time)
        bw = str(bw or "dense")
        print(f"{n:>6} {n - 1:>6} {bw:>9} {1e3 * dense:>11.3f} {1e3 * banded:>12.3f} {dense / banded:>13.1f} "
              f"{rounds:>7}")


if __name__ == "__main__":
    main()
