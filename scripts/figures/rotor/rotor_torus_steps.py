"""The rotor's large self-excited torus by steps in the speed: where its circle exists, where it locks.

The bearing rotor at f0 = 0.5 whirls quasi-periodically over w = 1.66-1.96 in the simulations of the
paper's Fig. 3 (docs/tutorials/rotor.md). Here that torus is found as an invariant circle of the map over
one revolution, fitted to a simulation at ``--start`` (:func:`contin.analyses.torus_start.circle_from_simulation`),
and followed in plain steps of the speed: at each speed Newton at fixed ``w``
(:func:`contin.engine.newton.solve_at_parameter`) from the line through the last two circles, the step
halved where Newton fails and grown again after a success. Printed at each speed: the rotation number
``rho``, the second frequency ``w2``, the disc's forced, self-excited and combination amplitudes in x
(:func:`contin.timedomain.circle_measures.circle_measures`) and Newton's iterations; where the steps
collapse, the nearest ``p/q`` (q <= 12) to ``rho``.

Plain steps cannot turn at a fold of the branch, but they step over the thin resonance tongues that a
pseudo-arclength branch of the circle crawls into (docs/theory/quasi-periodic.md).

    python scripts/figures/rotor/rotor_torus_steps.py                       # N = 61, down then up from 1.9 (8 min)
    python scripts/figures/rotor/rotor_torus_steps.py --quick               # N = 31, one step each way
"""

from __future__ import annotations

import argparse
import time
from fractions import Fraction

import numpy as np

from contin.analyses.torus_start import circle_from_simulation
from contin.engine.newton import solve_at_parameter
from contin.engine.options import ContinuationOptions
from contin.model.catalog import build_model
from contin.timedomain.circle_measures import circle_measures
from contin.timedomain.shooting import ShootingOptions, ShootingProblem


def follow(problem, u, w, dw0, end, min_step, dofs):
    """Steps from the circle ``u`` at ``w`` towards ``end``; the rows printed, and the last speed reached."""
    opts = ContinuationOptions(newton_tol=1e-8, newton_max_iter=12)
    hist, dw = [(w, u)], dw0
    while (end - w) * dw0 > 1e-12 and abs(dw) >= min_step:
        wn = w + dw if (end - w - dw) * dw0 > 0 else end
        (wa, ua), (wb, ub) = hist[-2] if len(hist) > 1 else hist[-1], hist[-1]
        guess = ub if wb == wa else ub + (ub - ua) * (wn - wb) / (wb - wa)
        r = solve_at_parameter(problem, guess, wn, opts)
        if not r.converged:
            dw /= 2.0
            continue
        w, u = wn, r.x
        hist.append((w, u))
        m = circle_measures(problem, u, w, dofs)
        print(f"  {w:9.5f} {u[-1]:9.6f} {m['frequency2']:9.5f} {m['forced_x1']:8.4f} {m['free_x1']:8.4f} "
              f"{m['comb_x1']:8.4f} {r.iterations:4d}", flush=True)
        dw = float(np.sign(dw0)) * min(abs(dw) * 1.5, abs(dw0))
    if (end - w) * dw0 > 1e-12:
        rho = float(hist[-1][1][-1])
        near = Fraction(rho).limit_denominator(12)
        print(f"  the steps collapsed below {min_step:g} beyond w = {w:.5f}: rho = {rho:.6f}, "
              f"{rho - float(near):+.1e} from {near.numerator}/{near.denominator}")
    return w


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, default=61, help="N, points of the circle (odd)")
    ap.add_argument("--steps", type=int, default=4096, help="RK4 steps a revolution")
    ap.add_argument("--start", type=float, default=1.9, help="speed of the simulation the circle is fitted to")
    ap.add_argument("--range", type=float, nargs=2, default=(1.6, 2.1), help="speeds to go to, down and up")
    ap.add_argument("--step", type=float, default=0.01, help="largest step in w")
    ap.add_argument("--quick", action="store_true", help="N = 31, one step each way")
    args = ap.parse_args(argv)
    min_step = 1e-5
    if args.quick:
        args.points, args.range, min_step = 31, (args.start - 0.01, args.start + 0.01), 2e-3
    model = build_model("bearing_rotor", {"f0": 0.5, "w": args.start})
    shooting = ShootingProblem(model, "w", options=ShootingOptions(steps_per_period=args.steps))
    t0 = time.perf_counter()
    problem, u = circle_from_simulation(shooting, {"start_simulation": {"transient": 600, "steps_per_period": 1024},
                                                   "torus": {"points": args.points}}, args.start, 40)
    r = solve_at_parameter(problem, u, args.start, ContinuationOptions(newton_tol=1e-8, newton_max_iter=12))
    if not r.converged:
        print(f"no circle at w = {args.start}: {r.message}")
        return 1
    print(f"circle of {args.points} points ({args.steps} RK4 steps a revolution) fitted to a simulation at "
          f"w = {args.start} and corrected")
    print(f"  {'w':>9} {'rho':>9} {'w2':>9} {'forced':>8} {'free':>8} {'comb':>8} {'its':>4}")
    reached = [follow(problem, r.x, args.start, -args.step, args.range[0], min_step, model.dof_names),
               follow(problem, r.x, args.start, args.step, args.range[1], min_step, model.dof_names)]
    print(f"circle found over w in [{reached[0]:.5f}, {reached[1]:.5f}] in {time.perf_counter() - t0:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
