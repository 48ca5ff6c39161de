"""The rotor's self-excited whirl as an invariant circle: the torus branch from the Neimark-Sacker point.

The bearing rotor at f0 = 0.5 (scenes/rotor_f0_05.yaml) loses the stability of its harmonic whirl at
a Neimark-Sacker point near w = 1.8508. The script finds the flow's harmonic orbit there (a
simulation from rest at w - 0.002, where it is stable, then Newton on the flow map), starts the
invariant circle of the stroboscopic map from the critical multiplier's eigenvector
(:func:`contin.timedomain.invariant_circle.circle_start`) and follows it
(:func:`contin.bifurcation.circle_branch.follow_circle`, its ends told), printing the rotation number and the circle's spread in the disc's x against w, how the
branch ended, and the torus' stability at three of its points
(:func:`contin.timedomain.invariant_circle.circle_lyapunov`).

    python scripts/figures/rotor/rotor_torus_circle.py                      # N = 15, 4096 steps, ~2 min
    python scripts/figures/rotor/rotor_torus_circle.py --points 33          # locks at rho = 2/5
    python scripts/figures/rotor/rotor_torus_circle.py --quick              # a smoke run
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from contin.bifurcation.circle_branch import follow_circle
from contin.engine.continuation import ContinuationOptions
from contin.model.catalog import build_model
from contin.timedomain.invariant_circle import CircleOptions, circle_lyapunov, circle_start
from contin.timedomain.shooting import ShootingOptions, periodic_orbit
from contin.timedomain.simulation import simulate

#: the harmonic branch's Neimark-Sacker point (docs/tutorials/rotor.md)
W_NS = 1.8508364869


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, default=15, help="N, points of the circle (odd)")
    ap.add_argument("--steps", type=int, default=4096, help="RK4 steps a forcing period")
    ap.add_argument("--max-points", type=int, default=160, help="stored points of the branch at most")
    ap.add_argument("--quick", action="store_true", help="N = 7, 1024 steps, 6 points (a smoke run)")
    args = ap.parse_args(argv)
    if args.quick:
        args.points, args.steps, args.max_points = 7, 1024, 6
    model = build_model("bearing_rotor", {"f0": 0.5})
    n = model.n_dof
    w0 = W_NS - 0.002
    run = simulate(model, {"w": w0}, np.zeros(n), np.zeros(n), periods=400, steps_per_period=1024, record_every=1024)
    orbit = periodic_orbit(model, {"w": w0}, run.section[-1], ShootingOptions(steps_per_period=args.steps))
    orbit = periodic_orbit(model, {"w": W_NS}, orbit.state, ShootingOptions(steps_per_period=args.steps))
    mu = orbit.multipliers[np.argsort(-np.abs(orbit.multipliers))][:2]
    print(f"harmonic orbit of the flow at w = {W_NS}: converged {orbit.converged}, leading multipliers "
          f"{np.round(mu, 6)} (|mu| = {np.abs(mu[0]):.6f})")
    t0 = time.perf_counter()
    problem, u0, tangent = circle_start(model, "w", orbit.state, W_NS,
                                        options=CircleOptions(points=args.points, steps_per_period=args.steps),
                                        eps=0.01)
    br = follow_circle(problem, u0, W_NS, (1.6, 2.1), ContinuationOptions(ds=0.01, max_points=args.max_points),
                       tangent=tangent)
    print(f"torus branch (N = {args.points}, {args.steps} steps): {len(br)} points in "
          f"{time.perf_counter() - t0:.1f} s, {br.status.value}: {br.message}")
    print("       w      rho   spread of the disc's x over the circle")
    for k in sorted(set(range(0, len(br), max(1, len(br) // 12))) | {len(br) - 1}):
        U, rho = problem.blocks(br.unknowns[k])
        print(f"  {br.parameter[k]:.6f}  {rho:.5f}  {np.ptp(U[:, 0]):.4f}")
    print("stability (Lyapunov exponents of the map along the circle, per forcing period):")
    for k in sorted({min(len(br) - 1, 3), len(br) // 2, len(br) - 1}):
        ly = circle_lyapunov(problem, br.unknowns[k], br.parameter[k], iterations=20 if args.quick else 150)
        verdict = {True: "stable", False: "unstable", None: "undecided"}[ly.stable]
        print(f"  w = {br.parameter[k]:.6f}: largest normal {ly.largest_normal:+.4f}, tangential "
              f"{ly.exponents[ly.tangent]:+.4f}: {verdict}")
    folds = [sp.parameter for sp in br.special_points if sp.kind.value == "fold"]
    if folds:
        distinct = sorted({round(w, 6) for w in folds})
        print(f"{len(folds)} folds, at w = " + ", ".join(f"{w:.6f}" for w in distinct))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
