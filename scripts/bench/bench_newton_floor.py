"""Benchmark: one Newton iteration against its cost floor, and how both grow with H.

One iteration of the continuation corrector is what the engine does per
update: the residual and the analytic Jacobians of the harmonic-balance
problem (:meth:`contin.hb.problem.HarmonicBalance.linearize`), the
scaled bordered matrix ``[Ju su, Jlam sl; t]`` of pseudo-arclength
continuation, its LU factorisation with condition estimate
(:func:`contin.engine.newton.factorize`) and the solve for the update. Its floor is
what no implementation of the method can avoid: one dense LU of a matrix of
the same order (:func:`scipy.linalg.lu_factor`) plus the real FFTs of the
sampled state (``numpy.fft.irfft`` to the ``N`` samples of the ``n`` dofs and
``numpy.fft.rfft`` back). The ratio iteration / floor is printed for the
bearing rotor (at a converged harmonic solution at ``w = 2.16``, paper
values, ``N = 2^ceil(log2(25 H))`` samples as in ``scenes/rotor_f0_05.yaml``)
at ``H = 10, 20, 40, 80`` and for the forced Duffing oscillator, with the
breakdown of the iteration (linearize / bordered matrix / factorize / solve)
so that a ratio above the target of 3 shows where the time goes.

The condensed table compares, for the rotor at ``H = 40`` and ``80``, one
iteration of the problem condensed onto the bearing's dofs ``x2, y2``
(:mod:`contin.hb.condensation`: the disc's ``x1, y1`` carry no nonlinear force
and are eliminated exactly, harmonic by harmonic) with the full iteration and
with its own floor (one dense LU of the condensed order plus the FFTs of the
kept dofs), all interleaved in the same rounds. There each linearisation (full
and condensed) is at a new value of ``lambda`` (by 1e-12 relative), as in the
corrector, so the condensed blocks are rebuilt every time.

The second table is the cost per Newton iteration and per continuation point
of the rotor as ``H`` grows, with the exponent of the growth between
successive ``H`` against the ``O((nH)^3)`` of the LU: where the measured
exponent is below 3 the ``O(n^2 N log N + (nH)^2)`` evaluation still
dominates, where it reaches 3 the iteration sits on the LU floor.

Every figure is measured in this run, side by side, with one BLAS thread.

    python scripts/bench/bench_newton_floor.py [--quick] [--harmonics 10,20,40,80] [--points]
"""

from __future__ import annotations

import argparse
import functools
import math
import os
import sys
import time

# One BLAS thread: at these sizes a second thread costs more in synchronisation
# than it gains, and the floor and the iteration must be measured alike.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np
import scipy.linalg

from contin.model.catalog import build_model
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.engine.newton import factorize


class Iteration:
    """One corrector update as the continuation engine performs it, split in its stages.

    ``fresh_lambda``: linearise at a new ``lambda`` (by 1e-12 relative) each call, as the corrector does, so
    that what depends on ``lambda`` alone is recomputed rather than taken from a cache.
    """

    def __init__(self, hb: HarmonicBalance, u: np.ndarray, lam: float, fresh_lambda: bool = False):
        self.hb, self.u, self.lam, self.fresh = hb, u, lam, fresh_lambda
        m = hb.size
        self.m = m
        self.su = np.full(m, max(float(np.max(np.abs(u))), 1e-12))
        self.sl = 1.0
        t = np.random.default_rng(0).normal(size=m + 1)
        self.t = t / np.linalg.norm(t)
        self.A = np.empty((m + 1, m + 1))
        self.F = np.empty(m + 1)
        self.A[m] = self.t
        self.calls = 0

    def linearize(self):
        if not self.fresh:
            return self.hb.linearize(self.u, self.lam)
        # lambda moves in every corrector update: a new value each call, so that what depends on it alone
        # (the excitation, the condensed problem's blocks) is recomputed as in the engine
        self.calls += 1
        return self.hb.linearize(self.u, self.lam * (1.0 + 1e-12 * self.calls))

    def border(self, R, Ju, Jlam):
        m = self.m
        np.multiply(Ju, self.su, out=self.A[:m, :m])
        np.multiply(Jlam, self.sl, out=self.A[:m, m])
        self.F[:m] = R
        self.F[m] = 0.0
        return self.F, self.A

    def __call__(self):
        F, A = self.border(*self.linearize())
        lu = factorize(A)
        return lu.solve(-F)


def _stages(hb, u: np.ndarray, lam: float, fresh_lambda: bool = False) -> dict:
    """The timed stages of one iteration of ``hb`` and of its floor.

    ``hb``: any problem with ``linearize``, ``size``, ``n`` and ``N`` (a condensed one too);
    ``fresh_lambda``: linearise at a new ``lambda`` each call (see :class:`Iteration`).
    """
    it = Iteration(hb, u, lam, fresh_lambda)
    R, Ju, Jlam = it.linearize()
    F, A = it.border(R, Ju, Jlam)
    lu = factorize(A)
    m1 = hb.size + 1
    rng = np.random.default_rng(1)
    B = rng.normal(size=(m1, m1)) + m1 * np.eye(m1)
    X = np.fft.rfft(rng.normal(size=(hb.N, hb.n)), axis=0)
    return {
        "it": it,
        "lin": it.linearize,
        "border": lambda: it.border(R, Ju, Jlam),
        "fac": lambda: factorize(A),
        "solve": lambda: lu.solve(-F),
        "lu": lambda: scipy.linalg.lu_factor(B),
        "fft": lambda: np.fft.rfft(np.fft.irfft(X, hb.N, axis=0), axis=0),
    }


def _best(stages: dict, repeat: int, rounds: int) -> dict:
    """The best time of each stage over ``rounds`` rounds, the stages interleaved in each round."""
    best = {k: math.inf for k in stages}
    for fn in stages.values():
        fn()
    for _ in range(rounds):
        for k, fn in stages.items():
            t = time.perf_counter()
            for _ in range(repeat):
                fn()
            best[k] = min(best[k], (time.perf_counter() - t) / repeat)
    return best


def _summary(best: dict, hb) -> dict:
    best = dict(best)
    best["floor"] = best["lu"] + best["fft"]
    return dict(size=hb.size + 1, N=hb.N, ratio=best["it"] / best["floor"], **best)


def measure(hb: HarmonicBalance, u: np.ndarray, lam: float, repeat: int, rounds: int = 7) -> dict:
    """Iteration, its stages and its floor, measured in interleaved rounds (the best of each kept).

    Interleaving puts the iteration and its floor under the same load of a
    shared machine; the minimum over rounds drops the interruptions.
    """
    return _summary(_best(_stages(hb, u, lam), repeat, rounds), hb)


def measure_condensed(hb: HarmonicBalance, u: np.ndarray, lam: float, repeat: int, rounds: int = 7):
    """The full and the condensed iteration with their floors, all stages interleaved in the same rounds.

    Returns
    -------
    full, condensed : dict
        As :func:`measure`; the condensed floor is the LU of the condensed
        order plus the FFTs of the kept dofs.
    """
    from contin.hb.condensation import condense

    ch = condense(hb)
    both = {("f", k): fn for k, fn in _stages(hb, u, lam, True).items()}
    both.update({("c", k): fn for k, fn in _stages(ch, ch.restrict(u), lam, True).items()})
    best = _best(both, repeat, rounds)
    full = _summary({k: v for (s, k), v in best.items() if s == "f"}, hb)
    cond = _summary({k: v for (s, k), v in best.items() if s == "c"}, ch)
    return full, cond


def rotor_samples(H: int) -> int:
    return 2 ** math.ceil(math.log2(25 * H))


def rotor_solution(H: int, lam: float = 2.16):
    """The rotor's harmonic solution at ``w = lam`` (homotopy in the contact stiffness, the model's own start).

    Computed once per ``(H, lam)``: the tables reuse it (the homotopy costs more than all their timings).
    """
    return _rotor_solution(int(H), float(lam))


@functools.lru_cache(maxsize=None)
def _rotor_solution(H: int, lam: float):
    model = build_model("bearing_rotor", {"f0": 0.5})
    hb = HarmonicBalance(model, "w", HBOptions(harmonics=H, samples=rotor_samples(H)))
    u = model.start(hb, lam)
    return hb, np.asarray(u, dtype=float)


def duffing_solution(H: int, lam: float = 1.5):
    from contin.engine.newton import solve_at_parameter

    hb = HarmonicBalance(build_model("duffing", {"F": 0.5}), "w", HBOptions(harmonics=H))
    res = solve_at_parameter(hb, hb.linear_solution(lam), lam)
    return hb, res.x


def print_table(rows):
    print(f"{'case':>16s} {'order':>6s} {'N':>5s} {'iteration':>10s} {'linearize':>10s} {'border':>8s} "
          f"{'factorize':>10s} {'solve':>7s} | {'lu_factor':>10s} {'FFTs':>7s} {'floor':>8s} | {'ratio':>6s}")
    for name, r in rows:
        us = {k: r[k] * 1e6 for k in ("it", "lin", "border", "fac", "solve", "lu", "fft", "floor")}
        print(f"{name:>16s} {r['size']:6d} {r['N']:5d} {us['it']:10.0f} {us['lin']:10.0f} {us['border']:8.0f} "
              f"{us['fac']:10.0f} {us['solve']:7.0f} | {us['lu']:10.0f} {us['fft']:7.0f} {us['floor']:8.0f} | "
              f"{r['ratio']:6.2f}")


def points_per_h(hs, quick: bool):
    """Time per continuation point and per Newton iteration of the rotor's harmonic branch for each H."""
    from contin.engine.continuation import ContinuationOptions, continuation

    lo, hi = (2.16, 2.165) if quick else (2.14, 2.18)
    out = []
    for H in hs:
        hb, u0 = rotor_solution(H, lo)
        u0 = u0.copy()
        ds = 0.05 if quick else 0.005  # relative to the range (scaled arclength): about 20 points quick, 200 in full
        opts = ContinuationOptions(ds=ds, ds_max=ds)
        t = time.perf_counter()
        br = continuation(hb, u0, lo, (lo, hi), opts, parameter_name="w")
        dt = time.perf_counter() - t
        out.append((H, hb.size, len(br), dt, int(br.info.get("n_linearizations", 0)),
                    int(br.info.get("n_newton_iterations", 0))))
    return out


def main(argv=None) -> int:
    from contin.util.blas import limit_blas_threads

    limit_blas_threads(1)
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="H = 20, 40 only, fewer repetitions, a short branch (CI)")
    ap.add_argument("--harmonics", default="10,20,40,80", help="rotor harmonic counts")
    ap.add_argument("--duffing-harmonics", type=int, default=5)
    ap.add_argument("--no-points", action="store_true", help="skip the per-point table")
    a = ap.parse_args(argv)
    hs = [20, 40] if a.quick else [int(h) for h in a.harmonics.split(",")]
    # repetitions per timing: about 4000 / H^2 (a few ms each) and 7 rounds; a tenth of that and 2 rounds quick
    rounds = 2 if a.quick else 7

    def repeat(H):
        return max(2, (400 if a.quick else 4000) // (H * H))

    rows = []
    for H in hs:
        hb, u = rotor_solution(H)
        rows.append((f"rotor H={H}", measure(hb, u, 2.16, repeat(H), rounds)))
    hb, u = duffing_solution(a.duffing_harmonics)
    rows.append((f"Duffing H={a.duffing_harmonics}", measure(hb, u, 1.5, 30 if a.quick else 300, rounds)))
    print("one Newton iteration (linearize + bordered matrix + factorize + solve) against its floor")
    print("(lu_factor of a matrix of the same order + irfft/rfft of the sampled state); times in us")
    print_table(rows)
    worst = max(r["ratio"] for _, r in rows)
    print(f"largest ratio iteration / floor: {worst:.2f} (target <= 3)")

    print()
    print("rotor condensed onto the bearing dofs (x2, y2), against the full problem; times in us")
    print(f"{'H':>4s} {'full order':>11s} {'full it':>8s} {'full floor':>11s} | {'cond order':>11s} {'cond it':>8s} "
          f"{'linearize':>10s} {'factorize':>10s} {'cond floor':>11s} | {'full/cond it':>13s} {'cond it/floor':>14s}")
    for H in [h for h in hs if h >= 40] or hs:
        hb, u = rotor_solution(H)
        f, c = measure_condensed(hb, u, 2.16, repeat(H), rounds)
        print(f"{H:4d} {f['size']:11d} {f['it'] * 1e6:8.0f} {f['floor'] * 1e6:11.0f} | {c['size']:11d} "
              f"{c['it'] * 1e6:8.0f} {c['lin'] * 1e6:10.0f} {c['fac'] * 1e6:10.0f} {c['floor'] * 1e6:11.0f} | "
              f"{f['it'] / c['it']:13.2f} {c['ratio']:14.2f}")
    print("(the condensed floor: lu_factor of the condensed order + irfft/rfft of the kept dofs)")

    print()
    print("rotor: cost growth with H (exponent between successive H; the LU alone grows as H^3)")
    print(f"{'H':>4s} {'order':>6s} {'iteration us':>13s} {'exp':>5s} {'floor us':>9s} {'exp':>5s} "
          f"{'linearize us':>13s} {'exp':>5s} {'factorize us':>13s} {'exp':>5s}")
    prev = None
    for (name, r), H in zip(rows, hs):
        if prev is None:
            e = ["", "", "", ""]
        else:
            q = math.log(H / prev[0])
            e = [f"{math.log(r[k] / prev[1][k]) / q:5.2f}" for k in ("it", "floor", "lin", "fac")]
        print(f"{H:4d} {r['size']:6d} {r['it'] * 1e6:13.0f} {e[0]:>5s} {r['floor'] * 1e6:9.0f} {e[1]:>5s} "
              f"{r['lin'] * 1e6:13.0f} {e[2]:>5s} {r['fac'] * 1e6:13.0f} {e[3]:>5s}")
        prev = (H, r)

    if not a.no_points:
        print()
        print(f"rotor harmonic branch from w = {2.16 if a.quick else 2.14}, ds = {0.05 if a.quick else 0.005} (per point: "
              f"corrector, tangent, events; no stability)")
        print(f"{'H':>4s} {'order':>6s} {'points':>7s} {'time s':>8s} {'per point ms':>13s} {'exp':>5s} "
              f"{'Newton its':>11s} {'per it ms':>10s} {'exp':>5s} {'linearizations':>15s}")
        prev = None
        for H, size, pts, dt, n_lin, n_it in points_per_h(hs, a.quick):
            tp, ti = dt / max(pts, 1), dt / max(n_it, 1)
            if prev is None:
                e = ["", ""]
            else:
                q = math.log(H / prev[0])
                e = [f"{math.log(tp / prev[1]) / q:5.2f}", f"{math.log(ti / prev[2]) / q:5.2f}"]
            print(f"{H:4d} {size + 1:6d} {pts:7d} {dt:8.2f} {tp * 1e3:13.2f} {e[0]:>5s} {n_it:11d} {ti * 1e3:10.2f} "
                  f"{e[1]:>5s} {n_lin:15d}")
            prev = (H, tp, ti)
        print("(per point and per iteration include the tangent's solve, the final factorisation and the "
              "events; exponents near 3 mean the LU dominates)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
