"""The rotor's large self-excited torus by steps in the speed: where its circle exists, where it locks.

The bearing rotor at f0 = 0.5 whirls quasi-periodically over w = 1.66-1.96 in the simulations of the
paper's Fig. 3 (docs/tutorials/rotor.md). Here that torus is found as an invariant circle of the map over
one revolution, fitted to a simulation at ``--start`` (:func:`contin.analyses.torus_start.circle_from_simulation`),
and followed in plain steps of the speed (:func:`contin.bifurcation.circle_steps.step_circle`: at each
speed Newton at fixed ``w`` from the line through the last two circles, the step halved where Newton
fails and grown again after a success). Printed at each speed: the rotation number
``rho``, the second frequency ``w2``, the disc's forced, self-excited and combination amplitudes in x
(:func:`contin.timedomain.circle_measures.circle_measures`) and Newton's iterations; where the steps
collapse, the nearest ``p/q`` (q <= 12) to ``rho``, and what the last circle's linearisation says of
the end (the smallest singular values, the tangent's ``w`` component: a smooth fold has both near zero).

Plain steps pass the corners and the thin resonance tongues that a pseudo-arclength branch of the circle
crawls into; where they fail, steps at a fixed size of the circle turn a fold of the torus (printed, the
steps then go back the other way) or pass on (docs/theory/quasi-periodic.md).

    python scripts/figures/rotor/rotor_torus_steps.py                       # N = 61, down then up from 1.9 (10 min)
    python scripts/figures/rotor/rotor_torus_steps.py --quick               # N = 31, one step each way
    python scripts/figures/rotor/rotor_torus_steps.py --from-ns --points 31 # the unstable torus, 1 min
    python scripts/figures/rotor/rotor_torus_steps.py --points 31 --range 1.6 2.1 --step 0.02 --min-step 1e-3
                                         # down through the fold of tori to the Neimark-Sacker point (1 min)

``--from-ns`` starts instead from the torus born at the harmonic orbit's Neimark-Sacker point near 1.8508
(the orbit by shooting from a simulation at 1.84, the circle branch by arclength down to ``--ns-to``, as
``scenes/rotor_torus.yaml``) and steps it down to ``--range``'s first value, the normal Lyapunov exponent
printed at every circle (unstable: positive).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from contin.analyses.torus_start import circle_from_simulation
from contin.bifurcation.circle_branch import CircleStabilityMonitor
from contin.bifurcation.circle_steps import step_circle
from contin.engine.newton import solve_at_parameter
from contin.engine.options import ContinuationOptions
from contin.model.catalog import build_model
from contin.timedomain.circle_measures import circle_measures
from contin.timedomain.shooting import ShootingOptions, ShootingProblem


def follow(problem, u, w, dw0, end, min_step, dofs, monitor=None, turn_to=None):
    """Steps from the circle ``u`` at ``w`` towards ``end`` (turning at a fold towards ``turn_to``); the rows
    printed (with ``monitor``, a :class:`CircleStabilityMonitor`, the normal Lyapunov exponent), and the
    farthest speed reached the way of ``dw0`` (past a fold the steps come back)."""
    def show(lam, x, iterations, m):
        exp = "" if monitor is None else f" {monitor(x, lam)['normal_exponent']:+10.4f}"
        print(f"  {lam:9.5f} {x[-1]:9.6f} {m['frequency2']:9.5f} {m['forced_x1']:8.4f} {m['free_x1']:8.4f} "
              f"{m['comb_x1']:8.4f} {iterations:4d}{exp}", flush=True)

    steps = step_circle(problem, u, w, dw0, end, min_step=min_step, turn_to=turn_to,
                        measure=lambda x, lam: circle_measures(problem, x, lam, dofs), callback=show)
    for f in steps.folds:
        lo, hi = f["interval"]
        print(f"  a fold of the torus at w = {f['lam']:.8f} ({'located' if f['located'] else 'not located'}: "
              f"between {lo:.8f} and {hi:.8f}); the steps turned there")
    if not steps.reached:
        print(f"  {steps.message}")
        wall(problem, steps.unknowns[-1], float(steps.parameter[-1]))
    return float(np.max(steps.parameter) if dw0 > 0 else np.min(steps.parameter))


def wall(problem, u, w):
    """What the last circle's linearisation says of the end: a smooth fold in ``w`` has ``R_u`` singular and a
    tangent of the branch with no ``w`` component; the unknowns scaled as a mean square over the points (the
    largest state times sqrt(N)), ``rho`` and ``w`` by 1."""
    _, Ju, Jw = problem.linearize(u, w)
    U, _ = problem.blocks(u)
    scale = np.r_[np.full(U.size, np.abs(U).max() * np.sqrt(problem.points)), 1.0, 1.0]
    A = np.c_[Ju, Jw] * scale
    _, sv, vt = np.linalg.svd(A)
    tangent = vt[-1] / np.linalg.norm(vt[-1])
    print(f"  at the last circle: smallest singular values {sv[-1]:.3g} of [R_u R_w] and "
          f"{np.linalg.svd(A[:, :-1], compute_uv=False)[-1]:.3g} of R_u (scaled; the largest {sv[0]:.3g}); the "
          f"tangent's w component {abs(tangent[-1]):.3f}, rho component {abs(tangent[-2]):.3f}")


def from_ns(points: int, steps: int, to: float):
    """The circle problem of the torus born at the Neimark-Sacker point near 1.8508 and its circle at ``to``:
    the harmonic orbit by shooting from a simulation at 1.84, followed up with its multipliers, the circle
    branch from the point followed down by arclength to ``to`` (:func:`contin.bifurcation.diagram.follow`)."""
    from contin.bifurcation.diagram import follow as follow_diagram  # deferred: this mode only
    from contin.bifurcation.torus_branch import TorusSettings  # deferred: as above
    from contin.timedomain.shooting import periodic_orbit  # deferred: as above
    from contin.timedomain.simulation import simulate  # deferred: as above

    model = build_model("bearing_rotor", {"f0": 0.5, "w": 1.84})
    opts = ShootingOptions(steps_per_period=steps)
    run = simulate(model, {"w": 1.84}, None, None, periods=400, steps_per_period=1024, record_every=1024)
    orbit = periodic_orbit(model, {"w": 1.84}, run.final_state, opts)
    shooting = ShootingProblem(model, "w", options=opts)
    d = follow_diagram(shooting, orbit.state, 1.84, (to, 1.9), {"ds": 0.01, "newton_tol": 1e-9},
                       stability={"method": "floquet"}, switch=("ns",), torus=TorusSettings(points=points))
    j = next(i for i, b in enumerate(d.branches) if b.info.get("torus"))
    br = d.branches[j]
    print(f"torus from the Neimark-Sacker point at w = {br.parameter[0]:.6f} by arclength down to "
          f"w = {br.parameter[-1]:.5f} ({len(br)} circles, {br.status.value})")
    return model, d.problems[j], br.unknowns[-1], float(br.parameter[-1])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, default=61, help="N, points of the circle (odd)")
    ap.add_argument("--steps", type=int, default=4096, help="RK4 steps a revolution")
    ap.add_argument("--start", type=float, default=1.9, help="speed of the simulation the circle is fitted to")
    ap.add_argument("--range", type=float, nargs=2, default=(1.6, 2.1), help="speeds to go to, down and up")
    ap.add_argument("--step", type=float, default=0.01, help="largest step in w")
    ap.add_argument("--min-step", type=float, default=1e-5, help="smallest step in w")
    ap.add_argument("--quick", action="store_true", help="N = 31, one step each way")
    ap.add_argument("--from-ns", action="store_true", help="the torus born at the Neimark-Sacker point, down")
    ap.add_argument("--ns-to", type=float, default=1.79, help="where its arclength branch hands over to the steps")
    args = ap.parse_args(argv)
    min_step = args.min_step
    if args.quick:
        args.points, args.range, min_step = 31, (args.start - 0.01, args.start + 0.01), 2e-3
    if args.from_ns:
        t0 = time.perf_counter()
        model, problem, u, w = from_ns(args.points, args.steps, args.ns_to)
        monitor = CircleStabilityMonitor(problem, simulation=0)
        print(f"  {'w':>9} {'rho':>9} {'w2':>9} {'forced':>8} {'free':>8} {'comb':>8} {'its':>4} {'normal exp':>10}")
        reached = follow(problem, u, w, -args.step, args.range[0], 1e-3, model.dof_names, monitor)
        print(f"circle found down to w = {reached:.5f} in {time.perf_counter() - t0:.0f} s")
        return 0
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
    reached = [follow(problem, r.x, args.start, -args.step, args.range[0], min_step, model.dof_names,
                      turn_to=args.range[1]),
               follow(problem, r.x, args.start, args.step, args.range[1], min_step, model.dof_names,
                      turn_to=args.range[0])]
    print(f"circle found over w in [{reached[0]:.5f}, {reached[1]:.5f}] in {time.perf_counter() - t0:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
