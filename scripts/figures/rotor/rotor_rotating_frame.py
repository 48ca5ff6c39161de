"""The bearing rotor at f0 = 0 in the frame turning with it: Hopf point, orbit family, exact check of the circle.

Without side load the rotor is rotationally symmetric; in the frame turning with w it is
autonomous (:func:`contin.model.rotating_frame.rotating_frame`). The script prints

1. the critical real part of the forced whirl (an equilibrium there) for the paper's e = 0.5
   (no Hopf point: the harmonic solution is stable) and the Hopf point for e = 0.15, with
   omega_H, the Neimark-Sacker angle 2 pi omega_H / w and rho = omega_H / w;
2. the fixed-frame harmonic branch's Neimark-Sacker point (frequency_response, Floquet,
   4096 and 8192 steps) against it, by the stability tolerance of the event (the event is
   located where |mu| = 1 + tolerance);
3. the rotating-frame periodic orbits from the Hopf point by autonomous shooting, with
   rho = T / T_r along them and the tips of the tongues rho = p/q (q <= 5) they cross;
4. at w = 1.9: the orbit against scipy's DOP853, and the fixed frame's invariant circle
   against the orbit (positions at t = kT and rho T_r - T) by the circle's points N and the
   integrator's steps.

    python scripts/figures/rotor/rotor_rotating_frame.py            # about 40 s (compiled kernels cached)
    python scripts/figures/rotor/rotor_rotating_frame.py --quick    # items 1-3 and one circle, about 10 s
"""

from __future__ import annotations

import argparse
import math
import time
from fractions import Fraction

import numpy as np
from scipy.integrate import solve_ivp

from contin import api
from contin.bifurcation.hopf import (
    EquilibriumProblem,
    follow_equilibrium,
    hopf_test,
)
from contin.engine.branch import SpecialKind
from contin.engine.continuation import ContinuationOptions, continuation
from contin.engine.events import FunctionEvent
from contin.model.catalog import build_model
from contin.model.rotating_frame import rotating_frame, to_fixed
from contin.timedomain.autonomous_shooting import (
    AutonomousOptions,
    AutonomousShootingProblem,
    hopf_orbit_start,
)
from contin.timedomain.invariant_circle import CircleOptions, InvariantCircleProblem

E = 0.15
W = 1.9
#: the tongues whose tips the family may cross: rho = p/q, q <= 5
TIPS = sorted({Fraction(p, q) for q in range(2, 6) for p in range(1, q)})


def rotating_rhs(t, y, w, P):
    """The rotating-frame equations in complex form, independent of contin (for DOP853)."""
    z1, z2, v1, v2 = y[0] + 1j * y[1], y[2] + 1j * y[3], y[4] + 1j * y[5], y[6] + 1j * y[7]
    a1 = (-(P["c1"] + 1j * w * (2 - P["ip"])) * v1 - (1 - w * w + P["ip"] * w * w + 1j * w * P["c1"]) * z1
          + P["alpha"] * z2 + P["e"] * w * w)
    r2 = abs(z2)
    fn = P["kbn"] * (r2 - P["delta"]) + P["cbn"] * (v2 * np.conj(z2)).real / r2 if r2 >= P["delta"] else 0.0
    a2 = (-(P["c2"] + 2j * w * P["beta"]) * v2 - (P["ks2"] * P["alpha"] - P["beta"] * w * w + 1j * w * P["c2"]) * z2
          + P["ks2"] * z1 - z2 / r2 * fn) / P["beta"]
    return [v1.real, v1.imag, v2.real, v2.imag, a1.real, a1.imag, a2.real, a2.imag]


def equilibria(e: float):
    rot = rotating_frame(build_model("bearing_rotor", {"f0": 0.0, "e": e}))
    problem = EquilibriumProblem(rot, "w")
    x = problem.solve(np.array([-0.21, 0.0, -0.1, 0.006]) * e / 0.15, 1.9)
    return rot, problem, x


def harmonic_ns(steps: int, tolerance: float) -> float:
    res = api.frequency_response(api.System.builtin("bearing_rotor", parameters={"f0": 0.0, "e": E}),
                                 parameter="w", range=[1.9, 2.05], start=1.9, harmonics=40, samples=1024,
                                 stability="floquet",
                                 stability_options={"steps_per_period": steps, "tolerance": tolerance},
                                 continuation={"ds": 0.01, "newton_tol": 1e-11})
    return next(p.parameter for b in res.branches for p in b.special_points if p.kind == "ns")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="items 1-3 and one circle (N = 31, 8192 steps)")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()

    # 1. equilibria and the Hopf point
    _, p05, x05 = equilibria(0.5)
    br05, h05 = follow_equilibrium(p05, x05, 1.9, (1.2, 4.0))
    tests = np.asarray(br05.point_data["hopf_test"], dtype=float)
    print(f"e = 0.5: forced whirl for w in [1.2, 4]: critical real part in [{min(tests):.5f}, {max(tests):.5f}], "
          f"{len(h05)} Hopf points")
    rot, problem, x = equilibria(E)
    _, hopf = follow_equilibrium(problem, x, 1.9, (1.9, 2.05))
    hp = hopf[0]
    print(f"e = {E}: Hopf point w_H = {hp.lam:.12f}, omega_H = {hp.omega:.12f}, Re = {hp.real_part:.1e}, "
          f"dRe/dw = {hp.slope:.5f}; NS angle 2 pi omega_H / w = {2 * math.pi * hp.omega / hp.lam:.10f}, "
          f"rho = omega_H / w = {hp.omega / hp.lam:.10f}; bearing penetration {math.hypot(*hp.state[2:]) - 0.1:.2e}")
    assert hopf_test(problem.eigenvalues(hp.state, hp.lam)) < 1e-12

    # 2. the harmonic branch's Neimark-Sacker point
    print("harmonic branch (H = 40, Floquet) Neimark-Sacker point minus w_H, by the event's tolerance:")
    for steps in (4096,) if args.quick else (4096, 8192):
        for tol in (1e-6, 1e-8, 1e-10, 1e-12):
            print(f"  {steps} steps, tolerance {tol:.0e}: {harmonic_ns(steps, tol) - hp.lam:+.2e}")

    # 3. the orbit family and the tongue tips it crosses
    shoot, u0, tangent = hopf_orbit_start(rot, hp, options=AutonomousOptions(steps=4096), eps=0.02)

    def rho(u, lam):
        return 2.0 * math.pi / lam / shoot.split(u)[1]

    event = FunctionEvent(lambda pt: np.array([rho(pt.u, pt.lam) - float(f) for f in TIPS]), name="tip",
                          kind=SpecialKind.LOCKING)
    family = continuation(shoot, u0, hp.lam, (1.68, 2.0), ContinuationOptions(ds=0.02, ds_max=0.1, max_points=120),
                          parameter_name="w", tangent=tangent, solve_start=False, events=[event])
    print(f"orbit family: {len(family)} points, {family.status.value} ({family.message}); rho = T/T_r from "
          f"{rho(family.unknowns[0], family.parameter[0]):.6f} (w = {family.parameter[0]:.6f}) to "
          f"{rho(family.unknowns[-1], family.parameter[-1]):.6f} (w = {family.parameter[-1]:.6f})")
    for sp in family.special_points:
        if sp.kind == SpecialKind.LOCKING:
            r = rho(sp.unknowns, sp.parameter)
            print(f"  tongue tip rho = {Fraction(r).limit_denominator(5)}: w = {sp.parameter:.10f}, "
                  f"T_r = {shoot.split(sp.unknowns)[1]:.8f}")
    print("  (no tip rho = 1/2, T_r = 2T: the family starts at rho = omega_H / w_H < 1/2 and rho falls with w)")

    # 4. at w = 1.9: the orbit against DOP853 and the invariant circle against the orbit
    to_w = continuation(shoot, u0, hp.lam, (W, 2.0), ContinuationOptions(ds=0.02, ds_max=0.1, max_points=60),
                        parameter_name="w", tangent=tangent, solve_start=False)
    u_ref = to_w.unknowns[-1]  # at the range end w = W
    P = {n: float(v) for n, v in rot.parameters.items()}
    for steps in (4096,) if args.quick else (4096, 8192, 16384):
        sh = AutonomousShootingProblem(rot, "w", options=AutonomousOptions(steps=steps, section=shoot.section))
        u = sh.solve(u_ref, W)
        z, Tr = sh.split(u)
        sol = solve_ivp(rotating_rhs, (0.0, Tr), z, method="DOP853", rtol=1e-11, atol=1e-13, args=(W, P),
                        dense_output=True)
        ref = sol.sol(np.linspace(0.0, Tr, 65)).T
        orb = sh.orbit(u, W, 64)
        print(f"orbit at w = {W}, {steps} steps: T_r = {Tr:.12f}, against DOP853: positions "
              f"{np.max(np.abs(orb[:, :4] - ref[:, :4])):.1e}, state {np.max(np.abs(orb - ref)):.1e}")
    fixed = build_model("bearing_rotor", {"f0": 0.0, "e": E})
    runs = [(31, 8192)] if args.quick else [(15, 4096), (21, 4096), (31, 4096), (41, 4096), (41, 8192), (41, 16384)]
    print("invariant circle of the fixed frame against the orbit (positions at t = kT; rho T_r - T):")
    for N, steps in runs:
        k_r = 8 * math.ceil(2 * steps / (8 * N))  # the orbit's own steps: twice the circle's a period or more
        sh = AutonomousShootingProblem(rot, "w", options=AutonomousOptions(steps=N * k_r, section=shoot.section))
        u = sh.solve(u_ref, W)
        _, Tr = sh.split(u)
        U = to_fixed(rot, sh.orbit(u, W)[::k_r][:N], W, 0.0)
        T = 2 * math.pi / W
        circle = InvariantCircleProblem(fixed, "w", options=CircleOptions(points=N, steps_per_period=steps), anchor=U)
        Uc, r = circle.blocks(circle.solve(circle.unknowns(U, T / Tr), W, tol=1e-12))
        print(f"  N = {N:2d}, {steps:5d} steps: positions {np.max(np.abs(Uc[:, :4] - U[:, :4])):.1e}, velocities "
              f"{np.max(np.abs(Uc[:, 4:] - U[:, 4:])):.1e}, rho T_r - T = {r * Tr - T:+.1e}")
    print(f"{time.perf_counter() - t0:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
