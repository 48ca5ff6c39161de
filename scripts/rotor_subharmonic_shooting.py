"""The rotor's 1/2-subharmonic branch of the equations of motion, by shooting, against the harmonic balance.

The nu = 2 branch of scenes/rotor_f0_05.yaml (harmonic balance, H = 80 harmonics of w/2)
ends where the bearing starts to skim its casing (README, "Bearing rotor"). This script
follows the same branch on the flow map of the time integrator itself
(contin.shooting.ShootingProblem: Newton and pseudo-arclength steps of the continuation
engine on phi_T(z) - z, the orbit's period being two revolutions), from the motion a
time simulation at w = 2.16 settles on, both ways, and prints its folds, kinks and ends
and the largest multiplier of the integrated flow along it, so that one sees how far the
equations of motion themselves can be followed smoothly and where the flow map is
non-smooth (the bearing grazing its casing).

    python scripts/rotor_subharmonic_shooting.py            # both ways, ~4 min on two cores
    python scripts/rotor_subharmonic_shooting.py --quick    # a short stretch, ~30 s
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from contin.blas import limit_blas_threads
from contin.catalog import build_model
from contin.continuation import ContinuationOptions, continuation
from contin.shooting import ShootingOptions, ShootingProblem, periodic_orbit
from contin.simulation import simulate

W0 = 2.16


def follow_both_ways(model, quick: bool, w0: float = W0):
    """The nu = 2 branch of the integrated flow through the motion a time simulation settles on at ``w0``.

    Returns ``(model, options, [(direction, Branch), ...])``, or None when no periodic orbit is found
    there (the reason printed); the branches carry the monitor's ``max_multiplier``.
    """
    opt = ShootingOptions(steps_per_period=4096, subharmonic=2)
    revolutions = 300 if quick else 1500
    run = simulate(model, {"w": w0}, periods=revolutions, steps_per_period=4096, record_every=4096)
    orb = periodic_orbit(model, {"w": w0}, run.final_state, opt)
    print(f"start: time simulation at w = {w0} ({revolutions} revolutions from rest), then shooting: "
          f"{orb.message}; largest multiplier {np.abs(orb.multipliers).max():.5f}")
    if not orb.converged:
        return None
    prob = ShootingProblem(model, "w", options=opt)
    span = (w0 - 0.004, w0 + 0.004) if quick else (2.1, 2.25)
    out = []
    for direction in (-1, 1):
        t = time.perf_counter()
        br = continuation(prob, orb.state, w0, span, ContinuationOptions(ds=0.01, ds_max=0.05, direction=direction,
                                                                          newton_tol=1e-9),
                          parameter_name="w", monitors=[prob.monitor], solve_start=False)
        stable = np.asarray(br.point_data["max_multiplier"]) < 1.0
        changes = [float(br.parameter[i + 1]) for i in range(len(br) - 1) if stable[i] != stable[i + 1]]
        turns = ", ".join(f"{sp.kind.value} {sp.parameter:.8f}" for sp in br.special_points
                          if sp.kind.value in ("fold", "kink"))
        print(f"\n== {'down' if direction < 0 else 'up'} in w: {len(br)} points, w from {br.parameter.min():.6f} "
              f"to {br.parameter.max():.6f} [{time.perf_counter() - t:.0f} s]")
        print(f"  folds and kinks: {turns or 'none'}")
        print(f"  stability changes (largest multiplier crossing 1) near w = "
              f"{', '.join(f'{c:.5f}' for c in changes) or 'none'}")
        print(f"  end: {br.status.value}: {br.message}")
        out.append((direction, br))
    return opt, out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="a short stretch either side of the start")
    ap.add_argument("--f0", type=float, default=0.5)
    args = ap.parse_args(argv)
    limit_blas_threads(1)
    t0 = time.perf_counter()
    if follow_both_ways(build_model("bearing_rotor", {"f0": args.f0}), args.quick) is None:
        return 1
    print(f"\ntotal {time.perf_counter() - t0:.1f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
