"""The invariant circle of the forced van der Pol oscillator: convergence in its points N and in the RK4 steps.

x'' - 0.1 (1 - x^2) x' + x = 0.15 cos(w t) at w = 0.92, outside the entrainment region
(scenes/van_der_pol.yaml). The circle (:class:`contin.timedomain.invariant_circle.InvariantCircleProblem`)
is solved by Newton from the section of the quasi-periodic harmonic balance (H1 = H2 = 12) for

- N = 9 .. 31 points at 8192 RK4 steps a forcing period, against N = 41 at 8192 steps;
- 256 .. 4096 steps at N = 41, against 8192 steps at N = 41;

and prints, for each, the error of the rotation number and the largest error of the circle (its
interpolant on 64 angles, the state (x, x')), with the fitted rate of the steps (RK4: 4), and the
difference to the harmonic balance's section and its w2 / w (mod 1).

    python scripts/figures/van_der_pol/vdp_circle_accuracy.py          # about 20 s
    python scripts/figures/van_der_pol/vdp_circle_accuracy.py --quick  # a smoke run
"""

from __future__ import annotations

import argparse
import math

import numpy as np

from contin.bifurcation.diagram import follow
from contin.bifurcation.torus_branch import TorusSettings
from contin.engine.newton import solve_at_parameter
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.hb.torus import TorusOptions
from contin.timedomain.invariant_circle import CircleOptions, InvariantCircleProblem

from vdp_torus_accuracy import model  # the same oscillator (a sibling script)

W = 0.92


def balance_point(H: int):
    """The quasi-periodic harmonic balance's point nearest W on its torus branch, and its problem."""
    hb = HarmonicBalance(model(), "w", HBOptions(5))
    d = follow(hb, hb.linear_solution(0.9), 0.9, (0.9, 0.97), {"ds": 0.02}, stability={"method": "hill"},
               switch=("ns",), torus=TorusSettings(TorusOptions(H, H), stability="none"))
    br, qp = d.branches[1], d.problems[1]
    i = int(np.argmin(np.abs(br.parameter - W)))
    return qp, br.unknowns[i], float(br.parameter[i])


def section(qp, u, w, theta) -> np.ndarray:
    """The balance's states at forcing phase 0 and second angle ``theta``, shape (len(theta), 2)."""
    return np.array([np.concatenate([a.ravel() for a in qp.state_at(u, w, np.zeros(1), phase2=t)]) for t in theta])


def solve(qp, u_qp, w, N: int, S: int):
    """The circle with N points and S steps: ``(unknowns, problem)``."""
    prob = InvariantCircleProblem(model(), "w", options=CircleOptions(points=N, steps_per_period=S))
    U0 = section(qp, u_qp, w, 2 * np.pi * np.arange(N) / N)
    prob.set_anchor(U0)
    res = solve_at_parameter(prob, prob.unknowns(U0, (u_qp[-1] / w) % 1.0), w, factor_final=False)
    if not res.converged:
        raise SystemExit(f"N = {N}, S = {S}: {res.message}")
    return res.x, prob


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="two settings each (a smoke run)")
    args = ap.parse_args(argv)
    qp, u_qp, w = balance_point(12)
    theta = 2 * np.pi * np.arange(64) / 64
    S_ref, N_ref = (1024, 21) if args.quick else (8192, 41)
    x_ref, p_ref = solve(qp, u_qp, w, N_ref, S_ref)
    rho_ref, C_ref = x_ref[-1], p_ref.points_on_circle(x_ref, theta)
    scale = float(np.sqrt(np.mean(C_ref ** 2)))

    def errors(x, p):
        return abs(x[-1] - rho_ref), float(np.abs(p.points_on_circle(x, theta) - C_ref).max()) / scale

    print(f"forced van der Pol at w = {w:.6f}; reference N = {N_ref}, {S_ref} steps: rho = {rho_ref:.14f}")
    print("\npoints N (steps %d)   |rho - ref|   circle error (relative to the RMS state)" % S_ref)
    for N in ((9, 15) if args.quick else (9, 11, 15, 21, 31)):
        e = errors(*solve(qp, u_qp, w, N, S_ref))
        print(f"  {N:4d}               {e[0]:9.1e}   {e[1]:9.1e}")
    print(f"\nsteps (N = {N_ref})          |rho - ref|   circle error")
    steps = (256, 512) if args.quick else (256, 512, 1024, 2048, 4096)
    errs = []
    for S in steps:
        e = errors(*solve(qp, u_qp, w, N_ref, S))
        errs.append(e)
        print(f"  {S:5d}               {e[0]:9.1e}   {e[1]:9.1e}")
    slope = np.polyfit(np.log(steps), np.log([e[1] for e in errs]), 1)[0]
    print(f"  rate of the circle error in the steps: {-slope:.2f} (RK4: 4)")
    U_qp = section(qp, u_qp, w, theta)
    print(f"\nagainst the quasi-periodic harmonic balance (H1 = H2 = 12): |rho - (w2 / w mod 1)| = "
          f"{abs(rho_ref - (u_qp[-1] / w) % 1.0):.1e}, section {np.abs(U_qp - C_ref).max() / scale:.1e} "
          f"(relative to the RMS state {scale:.4f}); second frequency {u_qp[-1]:.12f} = w (1 + rho) "
          f"{w * (1.0 + rho_ref):.12f}")
    assert math.isfinite(slope)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
