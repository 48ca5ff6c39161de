"""Benchmark: shooting by the variational equations against finite differences, and a branch against simulation.

The bearing rotor at f0 = 0.5 on its stable 1/2-subharmonic orbit (the paper's
stretch C-E), RK4 at T/4096 with the contact switches located, one BLAS
thread; three measurements side by side in one run:

1. **Per linearisation** (``ShootingProblem.linearize``: residual, ``dR/du``
   and ``dR/dlam``) at w = 2.16, nu = 2, with ``M`` = 1 and 4 segments, at the
   state a time simulation from rest reaches after ``--settle`` revolutions:
   ``jacobian="variational"`` (the variational equations integrated with the
   state, one integration per segment) against ``jacobian="differences"``
   (central differences of the flow map, ``4 n + 1`` integrations per
   segment). Each is the fastest of ``--repeat`` runs after a warm-up (the
   problem's cache of linearisations emptied before each). The ratio
   differences / variational is printed.
2. **Agreement** of the two at the same state: the multipliers (periodic
   Schur of the factors) as ``max |mu_var - mu_diff|`` after optimal pairing,
   and ``max |dR/du_var - dR/du_diff| / max |dR/du|``.
3. **A branch against brute force**: the orbit converged at w = 2.16 and
   continued by the engine (variational shooting, two segments, the flow's
   multipliers as its stability monitor) over ``--window``; then, at each of
   its stored speeds, the paper-style brute force of
   ``scripts/bench/bench_rotor.py`` (``--starts`` initial states, ``--revolutions``
   revolutions, the last 40 classified). Printed per speed: the branch's
   verdict and the classes the starts reached, the +w/2 forward whirl radius
   of the disc on the branch and on the settled simulation; then the ratio
   brute force / branch.

``--quick`` is a smoke run for CI (short settling, one repeat, a short branch,
one start at two speeds, short runs): its figures mean nothing.

    python scripts/bench/bench_shooting.py [--quick] [--settle 1500] [--repeat 5] [--window 2.16 2.17]
                                           [--starts 3] [--revolutions 3000]
"""

from __future__ import annotations

import argparse
import os
import sys
import time

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np
from bench_rotor import RECORD, start_states

W0 = 2.16
S = 4096  # RK4 steps per revolution, as the rotor paper


def whirl_radius(x: np.ndarray, t: np.ndarray, w: float) -> float:
    """``|F|`` of the disc's ``x1 + i y1 = F e^{i w t / 2} + ...``: the mean over whole pairs of revolutions
    (the rectangle rule is exact for a trigonometric polynomial of the window)."""
    return float(abs(np.mean((x[:, 0] + 1j * x[:, 1]) * np.exp(-0.5j * w * t))))


def branch_radius(problem, u: np.ndarray, w: float) -> float:
    """The +w/2 radius on the shooting orbit ``u`` (two revolutions, sampled at the RK4 steps)."""
    T = problem.period_at(w)
    t = np.arange(2 * S) * T / (2 * S)
    x, _ = problem.orbit(u, w, t)
    return whirl_radius(x.T, t, w)


def timed_linearisation(problem, u, lam: float, repeat: int) -> float:
    """Fastest of ``repeat`` linearisations after a warm-up, the cache of linearisations emptied before each."""
    problem.linearize(u, lam)
    best = np.inf
    for _ in range(repeat):
        problem._cache.clear()  # else the second call is a cache hit
        t0 = time.perf_counter()
        problem.linearize(u, lam)
        best = min(best, time.perf_counter() - t0)
    return best


def linearisations(model, z: np.ndarray, segments, repeat: int) -> list[tuple]:
    """Measurements 1 and 2 at the state ``z``: per ``M``, (M, t_var, t_diff, multiplier diff, Jacobian diff)."""
    from contin.stability import multiplier_distance
    from contin.timedomain.shooting import ShootingOptions, ShootingProblem

    out = []
    for M in segments:
        probs = {jac: ShootingProblem(model, "w", options=ShootingOptions(steps_per_period=S, subharmonic=2,
                                                                          segments=M, jacobian=jac))
                 for jac in ("variational", "differences")}
        assert all(p.jacobian == jac for jac, p in probs.items()), [p.notes for p in probs.values()]
        u = probs["variational"].start_unknowns(z, W0)
        t = {jac: timed_linearisation(p, u, W0, repeat) for jac, p in probs.items()}
        mu = {jac: p.multipliers(u, W0) for jac, p in probs.items()}
        J = {jac: p.linearize(u, W0)[1] for jac, p in probs.items()}
        jdiff = float(np.abs(J["variational"] - J["differences"]).max() / np.abs(J["differences"]).max())
        out.append((M, t["variational"], t["differences"], multiplier_distance(mu["variational"], mu["differences"]),
                    jdiff, mu["variational"]))
    return out


def shooting_branch(model, z: np.ndarray, window, max_points):
    """Measurement 3, the shooting side: the orbit through ``z`` converged at ``W0`` and continued over ``window``.

    Returns the problem, the branch and the seconds both took.
    """
    from contin.engine.continuation import ContinuationOptions, continuation
    from contin.engine.newton import solve_at_parameter
    from contin.stability import stability_events
    from contin.timedomain.shooting import (
        ShootingOptions,
        ShootingProblem,
        ShootingStability,
    )

    t0 = time.perf_counter()
    problem = ShootingProblem(model, "w", options=ShootingOptions(steps_per_period=S, subharmonic=2, segments=2))
    start = solve_at_parameter(problem, problem.start_unknowns(z, W0), W0)
    if not start.converged:
        raise SystemExit(f"no orbit at w = {W0} from the settled state: {start.message} (raise --settle)")
    mon = ShootingStability(problem)
    # the steps and the turn test (relaxed for grazing corners) of scripts/figures/rotor/rotor_subharmonic_shooting.py
    opts = ContinuationOptions(ds=0.01, ds_max=0.05, newton_tol=1e-9, max_angle_deg=89.0, max_points=max_points,
                               direction=1 if window[1] > W0 else -1)
    br = continuation(problem, start.x, W0, tuple(sorted(window)), opts, parameter_name="w", monitors=[mon],
                      events=stability_events(mon), solve_start=False)
    return problem, br, time.perf_counter() - t0


def settle(model, w: float, x0, v0, revolutions: int):
    """bench_rotor.py's brute force from one start: the class of the last RECORD revolutions and their +w/2 radius."""
    from contin.timedomain.poincare import steady_state

    res, cls = steady_state(model, {"w": w}, x0=x0, v0=v0, transient=revolutions - RECORD, record=RECORD)
    kind = {1: "harmonic", 2: "subharmonic"}.get(cls.period if cls is not None else None, "neither")
    return kind, whirl_radius(res.x, res.t, w)


def main(argv=None) -> int:
    from contin.model.catalog import build_model
    from contin.timedomain.simulation import simulate
    from contin.util.blas import limit_blas_threads

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="small settings (a smoke run; the figures mean nothing)")
    ap.add_argument("--settle", type=int, default=1500, help="revolutions from rest before the linearisations")
    ap.add_argument("--repeat", type=int, default=5, help="timed linearisations per construction (fastest kept)")
    ap.add_argument("--window", type=float, nargs=2, default=(2.16, 2.17), help="the branch's speeds, from 2.16")
    ap.add_argument("--starts", type=int, default=3, choices=(1, 2, 3), help="initial states per speed")
    ap.add_argument("--revolutions", type=int, default=3000, help="revolutions simulated from each start")
    args = ap.parse_args(argv)
    max_points, speeds = None, None
    if args.quick:
        # 400 revolutions from rest: close enough to the orbit for Newton (100 are not)
        args.settle, args.repeat, args.starts, args.revolutions = 400, 1, 1, 100
        args.window, max_points, speeds = (2.16, 2.17), 3, 2
    if not min(args.window) <= W0 <= max(args.window) or args.window[0] == args.window[1]:
        ap.error(f"--window must contain w = {W0} and have two different ends, got {args.window}")
    limit_blas_threads(1)
    model = build_model("bearing_rotor", {"f0": 0.5})

    # 1-2. per linearisation, at the state a simulation from rest settles on (entrained on the nu = 2 orbit)
    run = simulate(model, {"w": W0}, periods=args.settle, steps_per_period=S, record_every=S)
    z = run.final_state
    print(f"bearing rotor f0 = 0.5, w = {W0}, nu = 2, S = {S}: the state after {args.settle} revolutions from rest")
    print(f"{'M':>3s} {'variational ms':>15s} {'differences ms':>15s} {'ratio':>7s} {'max|dmu|':>10s} "
          f"{'max|dJ|/max|J|':>15s}")
    rows = linearisations(model, z, (1, 4), args.repeat)
    for M, tv, td, dmu, dj, _ in rows:
        print(f"{M:3d} {1e3 * tv:15.1f} {1e3 * td:15.1f} {td / tv:6.1f}x {dmu:10.1e} {dj:15.1e}")
    print("  multipliers |mu| (variational, M = 1): " + ", ".join(f"{m:.6g}" for m in np.abs(rows[0][5])))

    # 3. a shooting branch against brute force at its speeds
    problem, br, t_branch = shooting_branch(model, z, args.window, max_points)
    stable = np.asarray(br.point_data["stable"], dtype=bool)
    print(f"\nshooting branch (variational, M = 2) from w = {W0} over {args.window[0]:g}..{args.window[1]:g}: "
          f"{len(br)} points in {t_branch:.2f} s; {br.status.value}: {br.message[:100]}")
    idx = np.arange(len(br)) if speeds is None else np.arange(min(speeds, len(br)))
    starts = start_states(args.starts, np.random.default_rng(1))
    print(f"brute force at {len(idx)} of its speeds, {len(starts)} starts each, {args.revolutions} revolutions of "
          f"RK4 at T/{S} (the last {RECORD} classified)")
    print(f"{'w':>10s} {'branch':>9s} {'brute force':>22s} {'agree':>6s} {'radius branch':>14s} "
          f"{'radius sim':>11s} {'time s':>7s}")
    t_bf, n_agree, gaps = 0.0, 0, []
    for i in idx:
        w = float(br.parameter[i])
        t0 = time.perf_counter()
        got = [settle(model, w, x0, v0, args.revolutions) for x0, v0 in starts]
        dt = time.perf_counter() - t0
        t_bf += dt
        kinds = {k for k, _ in got}
        ok = kinds <= ({"subharmonic"} if stable[i] else {"harmonic", "neither"})
        n_agree += ok
        sub = [r for k, r in got if k == "subharmonic"]
        r_branch = branch_radius(problem, br.unknowns[i], w)
        gaps += [abs(r - r_branch) for r in sub]
        print(f"{w:10.6f} {'stable' if stable[i] else 'unstable':>9s} {'+'.join(sorted(kinds)):>22s} "
              f"{'yes' if ok else 'NO':>6s} {r_branch:14.6f} "
              f"{(sub[0] if sub else float('nan')):11.6f} {dt:7.2f}")
    print(f"the starts reach the branch's verdict at {n_agree} of {len(idx)} speeds; +w/2 radius of the settled "
          f"subharmonic against the branch's: largest difference {max(gaps, default=float('nan')):.1e}")
    print(f"brute force {t_bf:.1f} s; shooting branch {t_branch:.2f} s; ratio brute force / branch = "
          f"{t_bf / t_branch:.1f}x")
    return 0


if __name__ == "__main__":
    sys.exit(main())
