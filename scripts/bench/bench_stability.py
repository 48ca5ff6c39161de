"""Benchmark: Floquet multipliers by Hill's method against the RK4 monodromy.

Two periodic solutions:

- Duffing: x'' + 0.1 x' + x + x^3 = 0.5 cos(w t) at w = 1.4 on the upper
  (resonant, large-amplitude) branch;
- Mathieu: x'' + 0.1 x' + (delta + 0.4 cos t) x + x^3 = 0 at delta = 0.2 on the
  2T-periodic (1/2 subharmonic) branch born at the period doubling of x = 0;
- (full run only) a clearance oscillator x'' + 0.05 x' + x + 4 (|x| - 0.5)_+ sign x
  = 0.3 cos(w t) at w = 1.33: the Jacobian jumps at contact, Hill converges
  algebraically in H; RK4 with the contact switches located is fourth order
  in the step (first order straight across them, ``switches='ignore'``).

For each number of harmonics H the solution is recomputed (Newton at fixed
parameter) and the script prints the time per point of Hill's method (Hill
matrices + companion eigenproblem + selection), the time of the RK4 monodromy
for each step count S, and the disagreement ``max |mu_Hill - mu_RK4|`` after
optimal pairing, plus each method's error against an adaptive DOP853
integration of the same variational equations (rtol 1e-12). Timings are the
minimum over repeats, measured in this run.

    python scripts/bench/bench_stability.py [--quick] [--repeat 5]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from contin.model.catalog import build_model
from contin.engine.continuation import ContinuationOptions, continuation
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.engine.newton import solve_at_parameter
from contin.stability import hill_spectrum, monodromy_orbit_ivp, monodromy_rk4, multiplier_distance
from contin.bifurcation.diagram import follow


def best_time(fun, repeat):
    out, best = None, np.inf
    for _ in range(repeat):
        t = time.perf_counter()
        out = fun()
        best = min(best, time.perf_counter() - t)
    return best, out


def resize(u, n, H):
    """Truncate or zero-pad a coefficient vector to H harmonics."""
    U = u.reshape(-1, n)
    V = np.zeros((2 * H + 1, n))
    k = min(U.shape[0], V.shape[0])
    V[:k] = U[:k]
    return V.reshape(-1)


def duffing_point(H_max):
    hb = HarmonicBalance(build_model("duffing", {"F": 0.5}), "w", HBOptions(harmonics=H_max))
    br = continuation(hb, hb.linear_solution(0.5), 0.5, (0.5, 1.4), ContinuationOptions())
    return "Duffing, w = 1.4, upper branch (nu = 1)", hb, br.unknowns[-1].copy(), float(br.parameter[-1])


def mathieu_point(H_max):
    model = build_model("mathieu", {"c": 0.1, "g": 1.0, "eps": 0.4})
    hb = HarmonicBalance(model, "delta", HBOptions(harmonics=4))
    dg = follow(hb, np.zeros(hb.size), 0.3, (0.2, 0.6), ContinuationOptions(ds=0.02, ds_max=0.05),
                stability={"method": "hill"}, switch=("pd",))
    child = next(i for i in range(1, len(dg)) if dg[i].info["origin"]["kind"] == "pd")
    u, d = dg[child].point(len(dg[child]) - 1)
    hb2 = dg.problems[child].with_options(harmonics=H_max)
    u = solve_at_parameter(hb2, resize(u, 1, H_max), d).x
    return f"Mathieu-Duffing, delta = {d:.3g}, 1/2-subharmonic branch (nu = 2)", hb2, u, d


def gap_point(H_max):
    from contin.model.elements import GapForce
    from contin.model.base import Monomial
    from contin.models.polynomial import polynomial_model

    model = polynomial_model(["x"], {"c": 0.05, "F": 0.3, "w": 1.0}, mass=[[1.0]], damping=[["c"]],
                             stiffness=[[1.0]], forcing=[{"dof": "x", "amplitude": "F"}])
    model.forces.append(GapForce(0, Monomial(0.5), Monomial(4.0)))
    hb = HarmonicBalance(model, "w", HBOptions(harmonics=H_max))
    br = continuation(hb, hb.linear_solution(0.9), 0.9, (0.9, 1.33), ContinuationOptions(max_points=400))
    return "Clearance oscillator, w = 1.33 (piecewise-linear gap, nu = 1)", hb, br.unknowns[-1].copy(), float(br.parameter[-1])


def table(label, hb_max, u_max, lam, Hs, Ss, repeat):
    print(f"\n{label}")
    n = hb_max.n
    head = f"{'H':>3} {'Hill ms':>8} {'|Hill-ref|':>10} | " + " ".join(f"{'S=' + str(S):>9}" for S in Ss)
    print("  disagreement max|mu_Hill - mu_RK4(S)| (same orbit), Hill cost and Hill error against DOP853")
    print("  " + head)
    rk_rows = []
    for H in Hs:
        hb = hb_max.with_options(harmonics=H)
        res = solve_at_parameter(hb, resize(u_max, n, H), lam)
        if not res.converged:
            print(f"  {H:>3}  HB did not converge ({res.message})")
            continue
        u = res.x
        t_hill, spec = best_time(lambda: hill_spectrum(hb, u, lam), repeat)
        ref = monodromy_orbit_ivp(hb, u, lam, rtol=1e-12, atol=1e-13).multipliers
        cells, rk_times, rk_errs = [], [], []
        for S in Ss:
            S_eff = max(S, H + 1)
            t_rk, mono = best_time(lambda: monodromy_rk4(hb, u, lam, S_eff), repeat)
            m = mono.multipliers
            cells.append(f"{multiplier_distance(spec.multipliers, m):9.1e}")
            rk_times.append(t_rk * 1e3)
            rk_errs.append(multiplier_distance(m, ref))
        rk_rows.append((H, rk_times, rk_errs))
        print(f"  {H:>3} {t_hill * 1e3:8.3f} {multiplier_distance(spec.multipliers, ref):10.1e} | " + " ".join(cells))
    if rk_rows:
        H, times, errs = rk_rows[-1]
        print(f"  RK4 at H = {H}: ms per point   " + " ".join(f"{t:9.3f}" for t in times))
        print(f"  RK4 at H = {H}: |RK4 - ref|     " + " ".join(f"{e:9.1e}" for e in errs))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="a few seconds (CI)")
    ap.add_argument("--repeat", type=int, default=None, help="timing repeats (default 5, quick 1)")
    args = ap.parse_args(argv)
    repeat = args.repeat or (1 if args.quick else 5)
    if args.quick:
        Hs, Ss = (3, 6, 9), (64, 256, 1024)
    else:
        Hs, Ss = (3, 5, 7, 9, 12, 15, 20), (64, 128, 256, 512, 1024, 2048)
    H_max = max(Hs)
    t0 = time.perf_counter()
    # compile the kernels before timing anything
    label, hb, u, lam = duffing_point(H_max)
    monodromy_rk4(hb, u, lam, 16 + H_max)
    table(label, hb, u, lam, Hs, Ss, repeat)
    label, hb, u, lam = mathieu_point(2 * H_max)
    table(label, hb, u, lam, tuple(2 * H for H in Hs), Ss, repeat)
    if not args.quick:
        label, hb, u, lam = gap_point(80)
        table(label, hb, u, lam, (10, 20, 40, 80), Ss + (8192,), repeat)
    print(f"\ntotal {time.perf_counter() - t0:.1f} s")


if __name__ == "__main__":
    main()
