"""The rotor's self-excited whirl as an invariant circle: the torus branch from the Neimark-Sacker point.

The bearing rotor at f0 = 0.5 (scenes/rotor_f0_05.yaml) loses the stability of its harmonic whirl at
a Neimark-Sacker point near w = 1.8508. The script finds the flow's harmonic orbit there (a
simulation from rest at w - 0.002, where it is stable, then Newton on the flow map), starts the
invariant circle of the stroboscopic map from the critical multiplier's eigenvector
(:func:`contin.timedomain.invariant_circle.circle_start`) and follows it
(:func:`contin.bifurcation.circle_branch.follow_circle`, its ends told), printing the rotation number and the circle's spread in the disc's x against w, how the
branch ended, and the torus' stability at three of its points
(:func:`contin.timedomain.invariant_circle.circle_lyapunov`). Where the torus locks at ``p/q``, the
periodic orbits of ``q`` forcing periods are found a little further on inside the tongue
(:func:`contin.bifurcation.circle_branch.locked_orbits`), and a simulation from the stable one, disturbed,
is checked to return to it.

    python scripts/figures/rotor/rotor_torus_circle.py                      # N = 15, 4096 steps, ~2 min
    python scripts/figures/rotor/rotor_torus_circle.py --points 33          # locks at rho = 2/5
    python scripts/figures/rotor/rotor_torus_circle.py --quick              # a smoke run
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from contin.bifurcation.circle_branch import follow_circle, locked_orbits
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
    locks = [sp for sp in br.special_points if sp.kind.value == "locking"]
    if locks:
        report_locking(problem, br, model, locks[-1], args.steps)
    folds = [sp.parameter for sp in br.special_points if sp.kind.value == "fold"]
    if folds:
        distinct = sorted({round(w, 6) for w in folds})
        print(f"{len(folds)} folds, at w = " + ", ".join(f"{w:.6f}" for w in distinct))
    return 0


def report_locking(problem, br, model, lock, steps) -> None:
    """The orbits of ``q`` periods a little inside the tongue, and a simulation from the circle settling on one."""
    q = int(str(lock.data["rational"]).split("/")[-1])
    u, w_end = br.unknowns[-1], float(br.parameter[-1])
    ahead = np.sign(br.parameter[-1] - br.parameter[-2]) or -1.0
    for dw in (2e-4, 1e-3, 3e-3):
        w = w_end + ahead * dw
        t0 = time.perf_counter()
        orbits = locked_orbits(problem, u, w, q, starts=11, max_iter=20)
        print(f"orbits of {q} periods at w = {w:.6f}: {len(orbits)} found in {time.perf_counter() - t0:.1f} s")
        for o in orbits:
            mu = np.abs(o.multipliers)
            print(f"  rotation {o.rotation}, largest |mu| {mu.max():.5f} ({'stable' if mu.max() < 1 else 'unstable'}), "
                  f"{o.distance:.1e} from the circle's points")
        stable = [o for o in orbits if np.abs(o.multipliers).max() < 1]
        if stable:
            break
    else:
        return
    # a long simulation from the stable orbit disturbed by 1e-3, sampled once a period (the torus itself is
    # unstable here: the Neimark-Sacker point is subcritical, the harmonic whirl below it stable)
    n = model.n_dof
    Z = stable[0].unknowns.reshape(q, -1)
    z = Z[0] + 1e-3
    run = simulate(model, {"w": w}, z[:n], z[n:], periods=1500, steps_per_period=steps, record_every=steps)
    gap = max(float(np.min(np.max(np.abs(Z - y), axis=1))) for y in run.section[-q:])
    print(f"a simulation from it disturbed by 1e-3 at w = {w:.6f}, 1500 periods: its last {q} sections lie "
          f"{gap:.1e} from the orbit's states")


if __name__ == "__main__":
    raise SystemExit(main())
