"""Floquet checks on the bearing rotor: saltation, Hill against the monodromy, HB against simulation.

Prints, measured in this run:

1. the monodromy against central finite differences of the simulated flow map
   (``contin.timedomain.simulation.simulate``, located switches) over one period, with and
   without saltation matrices: the reference path (DOP853 on the nonlinear
   state from the HB start) and the production path (RK4 along the HB orbit),
   for a clearance oscillator with contact damping (paper's and clipped laws)
   and (full run) the rotor with c2 = 5 (impacts);
2. Hill's multipliers against the monodromy's on the f0 = 0.5 harmonic branch
   (H = 40) and (full run) the nu = 2 branch (H = 80);
3. the HB orbit against the simulation started on it, max displacement error
   over one period for H = 10, 20, 40, 80, with the fitted rate: exponential in
   H in permanent contact (f0 = 0.5, w = 2.0 stable and 2.1 unstable), algebraic
   for the impacting orbit (c2 = 5).

    python scripts/figures/rotor/rotor_floquet_check.py [--quick]

The same quantities are asserted in tests/stability/test_saltation.py and
tests/models/test_rotor_floquet.py.
"""

from __future__ import annotations

import argparse

import numpy as np
from contin.models.polynomial import polynomial_model

from contin.util.blas import limit_blas_threads
from contin.model.catalog import build_model
from contin.engine.continuation import ContinuationOptions
from contin.model.elements import GapForce
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.model.base import Monomial
from contin.engine.newton import solve_at_parameter
from contin.timedomain.simulation import simulate
from contin.stability import (
    hill_spectrum,
    monodromy_reference,
    monodromy_rk4,
    multiplier_distance,
    orbit_state,
)
from contin.bifurcation.start import simulation_start


def resize(u, n, H):
    U = u.reshape(-1, n)
    V = np.zeros((2 * H + 1, n))
    k = min(U.shape[0], V.shape[0])
    V[:k] = U[:k]
    return V.reshape(-1)


def solve(hb, guess, w):
    res = solve_at_parameter(hb, guess, w, ContinuationOptions(newton_tol=1e-9, newton_max_iter=30))
    if not res.converged:
        raise SystemExit(f"Newton failed at H = {hb.H}, w = {w}: {res.message}")
    return res.x


def flow_jacobian(model, w, z0, steps, eps=1e-6):
    n = model.n_dof
    cols = []
    for j in range(2 * n):
        e = np.zeros(2 * n)
        e[j] = eps
        ends = [simulate(model, {"w": w}, z[:n], z[n:], periods=1, steps_per_period=steps,
                         record_every=steps).final_state for z in (z0 + e, z0 - e)]
        cols.append((ends[0] - ends[1]) / (2 * eps))
    return np.column_stack(cols)


def saltation_rows(label, model, hb, u, w, steps, rk4_steps, rtol=1e-11):
    Phi = flow_jacobian(model, w, orbit_state(hb, u, w, 0.0), steps)
    out = [label]
    for switches in ("saltation", "piecewise"):
        ref = monodromy_reference(hb, u, w, rtol=rtol, atol=rtol / 10, switches=switches)
        out.append(f"{np.abs(ref.matrix - Phi).max():.1e}")
    for switches in ("saltation", "piecewise"):
        out.append(f"{np.abs(monodromy_rk4(hb, u, w, rk4_steps, switches=switches).matrix - Phi).max():.1e}")
    out.append(f"{ref.orbit_error:.1e}")
    print("| " + " | ".join(out) + " |")


def one_period_error(model, hb, u, w, steps=32768):
    n = model.n_dof
    z0 = orbit_state(hb, u, w, 0.0)
    run = simulate(model, {"w": w}, z0[:n], z0[n:], periods=hb.nu, steps_per_period=steps, record_every=steps // 512)
    zh = orbit_state(hb, u, w, run.t)
    return float(np.abs(run.x - zh[:, :n]).max()), float(np.abs(run.v - zh[:, n:]).max())


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="the clearance oscillator and one rotor orbit only")
    args = ap.parse_args()
    limit_blas_threads(1)

    print("1. monodromy against finite differences of the simulated flow map, max |Phi - Phi_FD|")
    print("| orbit | reference | reference, no saltation | RK4 on HB orbit | RK4, no saltation | HB orbit error |")
    print("| --- | --- | --- | --- | --- | --- |")
    for clip in (False, True):
        model = polynomial_model(["x"], {"c": 0.05, "F": 0.3, "w": 1.0}, mass=[[1.0]], damping=[["c"]],
                                 stiffness=[[1.0]], forcing=[{"dof": "x", "amplitude": "F"}])
        model.forces.append(GapForce(0, Monomial(0.5), Monomial(4.0), Monomial(0.5), clip=clip))
        hb = HarmonicBalance(model, "w", HBOptions(harmonics=40, samples=2048))
        u = simulation_start(hb, 1.1, transient=200, steps_per_period=2048)
        saltation_rows(f"clearance oscillator, {'clipped' if clip else 'paper'} law, H = 40", model, hb, u, 1.1,
                       8192, 4096)
    rotor = build_model("bearing_rotor", {"f0": 0.5})
    if not args.quick:
        model = build_model("bearing_rotor", {"f0": 0.5, "c2": 5.0})
        hb = HarmonicBalance(model, "w", HBOptions(harmonics=40, samples=1024))
        saltation_rows("rotor c2 = 5, w = 2, H = 40", model, hb, model.start(hb, 2.0), 2.0, 16384, 8192, rtol=1e-9)

    print("\n2. Hill against the monodromy (f0 = 0.5), max |mu_Hill - mu_RK4| after pairing")
    print("| branch | w | max abs(mu) | distance | Hill quality |")
    print("| --- | --- | --- | --- | --- |")
    hb1 = HarmonicBalance(rotor, "w", HBOptions(harmonics=40, samples=1024))
    harmonic = {w: rotor.start(hb1, w) for w in ((2.0,) if args.quick else (2.0, 2.1, 2.4))}
    for w, u in harmonic.items():
        spec = hill_spectrum(hb1, u, w)
        mono = monodromy_rk4(hb1, u, w, 4096)
        print(f"| nu = 1, H = 40 | {w} | {np.abs(mono.multipliers).max():.6f} | "
              f"{multiplier_distance(spec.multipliers, mono.multipliers):.1e} | {spec.quality:.2f} |")
    if not args.quick:
        hb2 = HarmonicBalance(rotor, "w", HBOptions(harmonics=80, samples=2048, subharmonic=2))
        ws, us = [2.16], [simulation_start(hb2, 2.16, transient=1500, steps_per_period=4096)]
        for w in (2.157, 2.154, 2.152, 2.1505, 2.1495, 2.149):
            g = us[-1] if len(us) < 2 else us[-1] + (us[-1] - us[-2]) * (w - ws[-1]) / (ws[-1] - ws[-2])
            us.append(solve(hb2, g, w))
            ws.append(w)
        for w, u in zip(ws, us):
            if w in (2.16, 2.154, 2.149):
                spec = hill_spectrum(hb2, u, w)
                mono = monodromy_rk4(hb2, u, w, 8192)
                print(f"| nu = 2, H = 80 | {w} | {np.abs(mono.multipliers).max():.6f} | "
                      f"{multiplier_distance(spec.multipliers, mono.multipliers):.1e} | {spec.quality:.2f} |")

    print("\n3. HB orbit against simulation over one period (32768 steps), max |x_sim - x_HB| (|x'_sim - x'_HB|)")
    Hs = (20, 40) if args.quick else (10, 20, 40, 80)
    cases = [("f0 = 0.5, w = 2.0 (stable)", rotor, 2.0, 1024, harmonic[2.0], 40)]
    if not args.quick:
        cases.append(("f0 = 0.5, w = 2.1 (unstable)", rotor, 2.1, 1024, harmonic[2.1], 40))
        imp = build_model("bearing_rotor", {"f0": 0.5, "c2": 5.0})
        hb80 = HarmonicBalance(imp, "w", HBOptions(harmonics=80, samples=2048))
        cases.append(("c2 = 5, w = 2.0 (impacts)", imp, 2.0, 2048, imp.start(hb80, 2.0), 80))
    print("| orbit | " + " | ".join(f"H = {H}" for H in Hs) + " | fitted |")
    print("| --- |" + " --- |" * (len(Hs) + 1))
    for label, model, w, samples, u0, H0 in cases:
        errs, cells = {}, []
        for H in Hs:
            hb = HarmonicBalance(model, "w", HBOptions(harmonics=H, samples=samples))
            try:
                u = u0 if H == H0 else solve(hb, resize(u0, 4, H), w)
            except SystemExit:
                cells.append("no solution")
                continue
            ex, ev = one_period_error(model, hb, u, w)
            errs[H] = ex
            cells.append(f"{ex:.1e} ({ev:.1e})")
        good = {H: e for H, e in errs.items() if e > 1e-10}  # above the simulation's error
        if "impacts" in label:
            fit = f"H^-{-np.polyfit(np.log(list(good)), np.log(list(good.values())), 1)[0]:.2f}"
        else:
            fit = f"exp(-{-np.polyfit(list(good), np.log(list(good.values())), 1)[0]:.2f} H)"
        print(f"| {label} | " + " | ".join(cells) + f" | {fit} |")


if __name__ == "__main__":
    main()
