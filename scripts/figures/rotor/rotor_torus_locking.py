"""Where the rotor's large torus ends going up: simulations settle on an orbit of q forcing periods.

The torus of the self-excited whirl born at the Neimark-Sacker point near w = 1.8508 (f0 = 0.5) turns at
its fold near 1.6626 and comes back up stable; its circle steps end near 1.968 with the rotation number
at 9/20 (docs/theory/quasi-periodic.md). This script asks the simulations what lies beyond: a sweep up in
the speed, each speed started from the last one's final state, ``--periods`` forcing periods at each
(RK4, ``--steps`` a revolution, the bearing's contacts located). Printed at each speed: the largest
``|x_{k+q} - x_k|`` over the last ``q`` sections (zero on an orbit of ``q`` periods), and Newton on
``phi_{qT}(z) = z`` (multiple shooting, ``--segments`` segments) from the section nearest its ``q``-th
successor, with the moduli of the orbit's largest multipliers where it converges (all below 1: the
simulation has settled on a stable orbit of ``q`` periods, the torus has locked); and the invariant circle
of 31 points fitted to the last ``--record`` sections (:func:`contin.timedomain.circle_fit.fit_circle`):
its rotation number and misfit (small: the motion lies on a torus).

    python scripts/figures/rotor/rotor_torus_locking.py            # 1.960 .. 1.974, 4000 periods each (1 min)
    python scripts/figures/rotor/rotor_torus_locking.py --quick    # one speed, 300 periods at T/1024
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from contin.model.catalog import build_model
from contin.timedomain.circle_fit import fit_circle
from contin.timedomain.shooting import ShootingOptions, periodic_orbit
from contin.timedomain.simulation import simulate


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--speeds", type=float, nargs="+",
                    default=[1.960, 1.968, 1.970, 1.971, 1.972, 1.973, 1.974, 1.975, 1.976, 1.978],
                    help="the speeds, in the order swept (the first from a run-up from rest)")
    ap.add_argument("--q", type=int, default=20, help="forcing periods of the orbit sought")
    ap.add_argument("--periods", type=int, default=4000, help="forcing periods simulated at each speed")
    ap.add_argument("--steps", type=int, default=4096, help="RK4 steps a revolution")
    ap.add_argument("--segments", type=int, default=4, help="shooting segments of the q periods")
    ap.add_argument("--record", type=int, default=300, help="sections the circle is fitted to")
    ap.add_argument("--quick", action="store_true", help="one speed, 300 periods at T/1024")
    args = ap.parse_args(argv)
    if args.quick:
        args.speeds, args.periods, args.steps, args.record = [1.972], 300, 1024, 100
    q, S = args.q, args.steps
    model = build_model("bearing_rotor", {"f0": 0.5, "w": args.speeds[0]})
    n = model.n_dof
    opts = ShootingOptions(steps_per_period=S, subharmonic=q, segments=args.segments, max_iter=30)
    x0 = v0 = None
    t0 = time.perf_counter()
    print(f"bearing rotor, f0 = 0.5: sweep up, {args.periods} periods a speed; orbits of q = {q} periods")
    print(f"  {'w':>7} {'circle rho':>10} {'misfit':>8} {'max |x_k+q - x_k|':>18}  Newton on the orbit of q periods")
    for w in args.speeds:
        run = simulate(model, {"w": w}, x0, v0, periods=args.periods, steps_per_period=S, record_every=S,
                       record_from=args.periods - max(2 * q, args.record))
        sec = np.asarray(run.section, dtype=float)
        x0, v0 = run.final_state[:n], run.final_state[n:]
        try:
            fit = fit_circle(sec[-args.record:], 31)
            circle = f"{fit.rho % 1.0:10.6f} {fit.misfit:8.2e}"
        except ValueError:  # sections all alike: a periodic orbit of one period
            circle = f"{'none':>10} {'':>8}"
        gap = np.abs(sec[q:] - sec[:-q]).max(axis=1)
        orbit = periodic_orbit(model, {"w": w}, sec[int(np.argmin(gap))], opts)
        if orbit.converged:
            mu = np.sort(np.abs(orbit.multipliers))[::-1][:3]
            said = "stable" if mu[0] < 1.0 else "unstable"
            found = f"converged, {said}: largest multipliers {', '.join(f'{m:.4f}' for m in mu)}"
        else:
            found = f"no orbit ({orbit.message})"
        print(f"  {w:7.4f} {circle} {gap[-1]:18.2e}  {found}", flush=True)
    print(f"done in {time.perf_counter() - t0:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
