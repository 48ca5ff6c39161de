"""Benchmark: a quasi-periodic (torus) branch against the time-simulation sweep that draws the same curve.

Forced van der Pol oscillator x'' - mu (1 - x^2) x' + x = F cos(w t), mu = 0.1, F = 0.15, over
w in [0.8, 0.95] (quasi-periodic below the entrainment boundary w = 0.951).

- contin: the periodic branch with Hill stability, the switch at its Neimark-Sacker point and the torus
  branch down to w = 0.8 (H1 = H2 = 12), every point a torus with its second frequency and lines;
  stability of the torus points by simulation is timed separately (it is optional).
- the sweep: at each w of the torus branch, contin's compiled RK4 integrates the equation from the
  previous speed's final state through a transient, then records enough periods to separate the lines,
  and contin's spectral-line estimator picks the second frequency and the amplitudes (as a paper's
  simulation figure is made).

- the same tori as invariant circles (N = 21 points, 1024 RK4 steps a period): the periodic branch by
  shooting from w = 0.97 down, its Neimark-Sacker point, the circle branch to w = 0.8 with the stability
  of every point from its Lyapunov exponents (contin.bifurcation.circle_branch).

All are timed in this run, side by side; the script prints the times, the ratios, the largest
difference between the balance and the sweep in the second frequency and in the self-excited line's
amplitude, and the circle's second frequency at w = 0.8 against the balance's.

    python scripts/bench/bench_torus.py [--quick]
"""

from __future__ import annotations

import argparse
import os
import time

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np

from contin.api.system import System
from contin.bifurcation.diagram import follow
from contin.bifurcation.torus_branch import TorusSettings, TorusStabilityMonitor
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.hb.torus import TorusOptions
from contin.timedomain.simulation import simulate
from contin.timedomain.spectral_lines import spectral_lines

MU, F = 0.1, 0.15


def model():
    return System(dofs=["x"], parameters={"mu": MU, "F": F, "w": 0.8}, mass=[[1]], damping=[["-mu"]],
                  stiffness=[[1]], forces=[{"dof": "x", "expr": "mu*x**2*x_dot"}],
                  excitation=[{"dof": "x", "expr": "F*cos(tau)"}], frequency="w").model


def torus_branch(H: int):
    hb = HarmonicBalance(model(), "w", HBOptions(5))
    d = follow(hb, hb.linear_solution(0.8), 0.8, (0.8, 0.97), {"ds": 0.02}, stability={"method": "hill"},
               switch=("ns",), torus=TorusSettings(TorusOptions(H, H), stability="none"))
    return d.branches[1], d.problems[1]


def circle_branch(points: int, steps: int):
    """The tori as invariant circles: shooting from w = 0.97 down, the circle from its Neimark-Sacker point."""
    from contin.timedomain.shooting import ShootingOptions, ShootingProblem

    m = model()
    run = simulate(m, {"w": 0.97}, np.array([1.0]), np.zeros(1), periods=300, steps_per_period=steps,
                   record_every=steps)
    sp = ShootingProblem(m, "w", None, ShootingOptions(steps_per_period=steps))
    d = follow(sp, run.final_state, 0.97, (0.8, 0.97), {"ds": 0.02, "direction": -1},
               stability={"method": "floquet"}, switch=("ns",), torus=TorusSettings(points=points))
    return d.branches[1], d.problems[1]


def sweep(m, speeds, transient: int, record: int, steps: int):
    """Second frequency and self-excited amplitude at each speed, from a simulation sweep."""
    out = []
    x0, v0 = np.array([2.0]), np.array([0.0])
    for w in speeds:
        p = {"mu": MU, "F": F, "w": float(w)}
        r = simulate(m, p, x0, v0, periods=transient + record, steps_per_period=steps, record_every=steps // 16,
                     record_from=transient)
        x0, v0 = r.x[-1], r.v[-1]
        lines = spectral_lines(r.t, r.x[:, 0], count=4, floor=1e-3)
        free = min((ln for ln in lines if abs(ln.frequency - w) > 1e-3 * w), key=lambda ln: abs(ln.frequency - 1.0))
        out.append((free.frequency, free.amplitude))
    return np.array(out)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="small settings (for CI)")
    a = ap.parse_args(argv)
    H = 6 if a.quick else 12
    m = model()
    torus_branch(4)  # compile everything once: the timings below are of warm code
    t0 = time.perf_counter()
    br, qp = torus_branch(H)
    t_torus = time.perf_counter() - t0
    keep = br.parameter < 0.95  # away from the boundary, where the sweep's lines are resolved
    speeds, U = br.parameter[keep], br.unknowns[keep]
    if a.quick:
        speeds, U = speeds[::4], U[::4]
    t0 = time.perf_counter()
    mon = TorusStabilityMonitor(qp, TorusSettings(stability="simulation", periods=150, steps_per_period=128))
    verdicts = [mon(u, w) for u, w in zip(U, speeds)]
    t_stab = time.perf_counter() - t0
    transient, record = (100, 200) if a.quick else (400, 1000)
    sweep(m, speeds[:1], 10, 20, 128)  # compile the integrator
    t0 = time.perf_counter()
    sim = sweep(m, speeds, transient, record, 128)
    t_sim = time.perf_counter() - t0
    j = qp.basis.pair(0, 1)[0]
    d_w2 = np.max(np.abs(U[:, -1] - sim[:, 0]) / U[:, -1])
    free = np.array([qp.amplitudes(u)[j, 0] for u in U])
    d_amp = np.max(np.abs(free - sim[:, 1]) / sim[:, 1])
    n = len(speeds)
    print(f"torus branch (H1 = H2 = {H}): {len(br)} points in {t_torus:.2f} s; {n} of them below w = 0.95")
    print(f"stability of those {n} points by simulation (150 periods each, two runs): {t_stab:.2f} s, "
          f"{sum(bool(v['stable']) for v in verdicts)} stable")
    print(f"simulation sweep over the same {n} speeds ({transient} + {record} periods each, 128 steps per "
          f"period, spectral lines): {t_sim:.2f} s")
    print(f"ratio sweep / torus branch: {t_sim / t_torus:.1f}; with the stability check: "
          f"{t_sim / (t_torus + t_stab):.1f}")
    print(f"largest relative difference: second frequency {d_w2:.2e}, self-excited line {d_amp:.2e}")
    N = 11 if a.quick else 21
    circle_branch(5, 256)  # compile the flow and its variational equations once
    t0 = time.perf_counter()
    cb, cp = circle_branch(N, 1024)
    t_circle = time.perf_counter() - t0
    stable = int(np.sum(np.asarray(cb.point_data["stable"], dtype=bool) & np.asarray(cb.point_data["evaluated"],
                                                                                      dtype=bool)))
    print(f"invariant circles (N = {N}, 1024 steps a period): periodic branch by shooting and the circle branch, "
          f"{len(cb)} points with their Lyapunov exponents ({stable} stable) in {t_circle:.2f} s; "
          f"ratio sweep / circle branch: {t_sim / t_circle:.1f}")
    if cb.parameter[-1] == br.parameter[-1] == 0.8:
        print(f"second frequency at w = 0.8: circle {cp.second_frequency(cb.unknowns[-1], 0.8):.10f}, "
              f"balance {br.unknowns[-1, -1]:.10f}")


if __name__ == "__main__":
    main()
