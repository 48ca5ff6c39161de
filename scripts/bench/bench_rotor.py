"""Benchmark: the rotor's f0 = 0.5 diagram against the paper-style brute-force sweep of time simulations.

Three measurements, side by side in one run, with one BLAS thread:

1. **The main job** (``scenes/rotor_f0_05.yaml``: the harmonic branch over
   w = 1.6..2.6 and the 1/2-subharmonic branch both ways, with Floquet
   stability by monodromy), run once to load the compiled kernels and then
   timed (``--runs`` times, the fastest kept: the machine is shared).
2. **Brute force, as the rotor paper did it**: at each of ``--speeds``
   evenly spaced speeds over the same range, eq. 11 is integrated by RK4 at
   T/4096 from ``--starts`` initial states (at rest, a small random state,
   a large forward whirl) for ``--revolutions`` revolutions, the last 40
   classified (:func:`contin.timedomain.poincare.classify`) as ``harmonic`` (period 1),
   ``subharmonic`` (period 2) or ``neither``. Each speed's classes are
   printed beside what the diagram says there (the stable branches through
   it), with the verdict: they agree when every class a start reached is
   one the diagram has there. Where no start reaches a stable solution of
   the diagram (harmonic or 1/2-subharmonic), the simulation is run once
   more from that solution (a stored point near the speed, at its own
   speed): if it stays there, both attractors coexist and the starts missed
   the diagram's. The ratio brute force / diagram is the point of the tool.
3. **The floor** of the main job: its number of stored points times the cost
   of one LU of its bordered corrector matrix plus one monodromy (on the
   branches handed to shooting, one linearisation: the variational flow,
   whose factors give the multipliers, and ``dR/dlambda``), measured here on
   a point of each branch; the ratio main job / floor says what is left to gain.

``--every k`` simulates only every k-th speed and extrapolates the
brute-force time (the ratio is then marked so). ``--quick`` is a smoke run
for CI: a part of the harmonic branch at H = 12, a few speeds, short runs.

    python scripts/bench/bench_rotor.py [--quick] [--speeds 21] [--starts 3] [--revolutions 3000] [--every 1] [--runs 2]
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
RECORD = 40  # revolutions classified at the end of each simulation
HALF_WHIRL = 1e-3  # a nu = 2 row counts as subharmonic from this disc whirl at +w/2 on


def run(name, overrides, outdir):
    from contin.app.runner import run_scene
    from contin.scene.parse import load_scene

    scene = load_scene(ROOT / "scenes" / f"{name}.yaml", overrides)
    return scene, run_scene(scene, outdir, progress=False)


def diagram_classes(rows, w: float) -> set:
    """The classes of the stable branches through speed w (nu = 2 with a +w/2 whirl counts as subharmonic)."""
    out = set()
    for b in np.unique(rows["branch"]):
        m = rows["branch"] == b
        ws, nu = rows["w"][m], int(rows["nu"][m][0])
        st = np.array([bool(s) for s in rows["stable"][m]])
        for i in range(len(ws) - 1):
            if min(ws[i], ws[i + 1]) <= w <= max(ws[i], ws[i + 1]):
                j = i if abs(ws[i] - w) <= abs(ws[i + 1] - w) else i + 1  # the nearer stored point
                if st[j] and not (nu == 2 and rows["whirl_fwd_half_disc"][m][j] < HALF_WHIRL):
                    out.add({1: "harmonic", 2: "subharmonic"}[nu])
    return out or {"neither"}


def start_states(n_starts: int, rng):
    """Initial (x, v): at rest, a small random state, a large forward whirl of the disc."""
    states = [(np.zeros(4), np.zeros(4)), (1e-3 * rng.normal(size=4), np.zeros(4)),
              (np.array([1.5, 0.0, 0.1, 0.0]), np.array([0.0, 1.5, 0.0, 0.1]))]
    return states[:n_starts]


def brute_force(model, w: float, starts, revolutions: int) -> tuple[set, float]:
    from contin.timedomain.poincare import steady_state

    t0 = time.perf_counter()
    found = set()
    for x0, v0 in starts:
        _, res = steady_state(model, {"w": w}, x0=x0, v0=v0, transient=revolutions - RECORD, record=RECORD)
        found.add({1: "harmonic", 2: "subharmonic"}.get(res.period if res is not None else None, "neither"))
    return found, time.perf_counter() - t0


CLASS_NU = {"harmonic": 1, "subharmonic": 2}


def from_the_diagram(outdir: Path, scene, rows, w: float, revolutions: int, kind: str = "harmonic"):
    """Simulate from the stored stable orbit of class ``kind`` (``harmonic`` or ``subharmonic``) nearest to w,
    at its own speed: does it persist?

    The state at t = 0 from the row's problem (:class:`contin.model.periodic.PeriodicProblem`'s ``orbit``): a
    harmonic-balance row's coefficients, a shooting row's segment starts (cut at its own section). Returns
    ``(class, w_point)``, or None where the diagram has no stable point of that class near w.
    """
    from contin.analyses.frequency_response import build_problem
    from contin.analyses.shooting_rows import stored_shooting_problem
    from contin.app.pointplot import load_state_row
    from contin.timedomain.poincare import steady_state
    from contin.output.expansion import StoredExpansion
    from contin.scene.build import build_model
    from contin.scene.parse import Scene

    nu = CLASS_NU[kind]
    ok = (np.asarray(rows["nu"]) == nu) & np.array([bool(s) for s in rows["stable"]])
    if nu == 2:
        ok &= np.asarray(rows["whirl_fwd_half_disc"], dtype=float) >= HALF_WHIRL
    if not ok.any():
        return None
    row = int(np.flatnonzero(ok)[np.argmin(np.abs(np.asarray(rows["w"])[ok] - w))])
    rec = load_state_row(outdir, row)
    header = rec["branch_record"]
    H = int(rec.get("H") or header.get("H") or scene.analysis["harmonics"])
    sub = Scene({**scene.data, "analysis": {**scene.analysis, "subharmonic": nu, "harmonics": H, "starts": []}},
                scene.source, scene.lines)
    model = build_model(sub)
    hb = build_problem(sub, model)
    if header.get("method") == "shooting":
        problem, u = stored_shooting_problem(hb, {**header, "nu": nu}), np.asarray(rec["u"], dtype=float)
    else:
        problem, u = hb.full, StoredExpansion(hb)(header, rec["u"], rec["lam"])  # the full coefficients
    x, xd = problem.orbit(u, float(rec["lam"]), np.zeros(1))
    _, res = steady_state(model, {"w": float(rec["lam"])}, x0=x[:, 0], v0=xd[:, 0], transient=revolutions - RECORD,
                          record=RECORD)
    return {1: "harmonic", 2: "subharmonic"}.get(res.period if res is not None else None, "neither"), rec["lam"]


def floor_per_point(outdir: Path, scene) -> dict:
    """Time of one LU of the bordered corrector matrix and of one monodromy, per branch order nu."""
    from contin.analyses.frequency_response import build_problem, engine_problem
    from contin.output.checkpoint import read_records
    from contin.engine.newton import factorize
    from contin.scene.build import build_model
    from contin.scene.parse import Scene
    from contin.stability import StabilityOptions, floquet_multipliers

    recs = [r for r in read_records(outdir / "state.jsonl") if r["type"] == "point"]
    out = {}
    for key, sc in [("analysis", scene)] + [(f"starts[{i}]", None) for i in range(len(scene.analysis["starts"]))]:
        a = dict(scene.analysis)
        if sc is None:
            a.update(scene.analysis["starts"][int(key[7:-1])])
        a["starts"] = []
        sub = Scene({**scene.data, "analysis": a}, scene.source, scene.lines)
        model = build_model(sub)
        hb = build_problem(sub, model)
        nu = int(a.get("subharmonic") or 1)
        rec = next((r for r in recs if int(r["nu"]) == nu), None)
        if rec is None or nu in out:
            continue
        full = hb.full
        u, lam = np.array(rec["u"]), float(rec["lam"])  # the engine's unknowns (kept dofs when condensed)
        problem = engine_problem(sub, hb)
        u_full = problem.expand(u, lam) if problem is not hb else u
        _, Ju, Jlam = hb.linearize(u_full, lam)
        A = np.zeros((Ju.shape[0] + 1, Ju.shape[0] + 1))
        A[:-1, :-1], A[:-1, -1], A[-1] = Ju, Jlam, 1.0
        opts = StabilityOptions(method="floquet", **dict(a.get("stability_options") or {}))
        t_lu = min(_timed(lambda: factorize(A)) for _ in range(20))
        t_mono = min(_timed(lambda: floquet_multipliers(full, u_full, lam, opts)) for _ in range(3))
        out[nu] = (t_lu, t_mono, A.shape[0])
        if nu > 1 and "shooting" not in out:
            # the legs handed to shooting: one linearisation (variational flow, dR/dlambda) and one LU a point
            from contin.analyses.shooting_rows import ShootingSettings, shooting_problem

            sh = shooting_problem(hb, ShootingSettings(**dict(a.get("shooting") or {})), nu)
            z = sh.start_unknowns(_first_state(full, u_full, lam), lam)
            _, Js, Jl = sh.linearize(z, lam)  # the kernels loaded
            B = np.zeros((Js.shape[0] + 1, Js.shape[0] + 1))
            B[:-1, :-1], B[:-1, -1], B[-1] = Js, Jl, 1.0
            t_lin = min(_timed(lambda: sh.linearize(z, lam + 1e-9 * _)) for _ in range(1, 4))  # uncached
            out["shooting"] = (min(_timed(lambda: factorize(B)) for _ in range(20)), t_lin, B.shape[0])
    return out


def _first_state(full, u, lam) -> np.ndarray:
    """The state ``(x, x')`` at ``t = 0`` of a harmonic-balance orbit."""
    x, v = full.orbit(u, lam, np.zeros(1))
    return np.concatenate([np.ravel(x), np.ravel(v)])


def _timed(fun) -> float:
    t0 = time.perf_counter()
    fun()
    return time.perf_counter() - t0


def main(argv=None) -> int:
    from contin.model.catalog import build_model
    from contin.output.results import read_csv

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="small settings (a smoke run; the figures mean nothing)")
    ap.add_argument("--speeds", type=int, default=21, help="speeds of the brute-force sweep over the scene's range")
    ap.add_argument("--starts", type=int, default=3, choices=(1, 2, 3), help="initial states per speed")
    ap.add_argument("--revolutions", type=int, default=3000, help="revolutions simulated from each start")
    ap.add_argument("--every", type=int, default=1, help="simulate every k-th speed and extrapolate the time")
    ap.add_argument("--runs", type=int, default=2, help="timed runs of the main job after the warm-up (fastest kept)")
    args = ap.parse_args(argv)
    overrides = []
    if args.quick:
        overrides = ["analysis.range=[2.1, 2.2]", "analysis.start=2.1", "analysis.harmonics=12", "analysis.samples=256",
                     "analysis.starts=[]"]
        args.speeds, args.revolutions, args.runs = 2, 100, 1
    tmp = Path(tempfile.mkdtemp(prefix="bench_rotor_"))

    # 1. the main job: a warm-up run (loads or compiles the kernels), then the timed ones
    if not args.quick:
        run("rotor_f0_05", overrides, tmp / "warm")
    times = []
    for k in range(args.runs):
        t0 = time.perf_counter()
        scene, summary = run("rotor_f0_05", overrides, tmp / f"diagram{k}")
        times.append(time.perf_counter() - t0)
    t_diagram = min(times)
    outdir = tmp / f"diagram{int(np.argmin(times))}"
    rows = read_csv(outdir / "branches.csv")
    branches = summary["analysis"]["branches"]
    print(f"main job: {t_diagram:.2f} s warm (fastest of {args.runs}: {', '.join(f'{t:.2f}' for t in times)} s), "
          f"{len(rows['w'])} stored points on {len(branches)} branches")
    for b in branches:
        print(f"  branch {b['branch']} (nu={b['nu']}): {b['points']} points, {b['status']}: {b['message'][:110]}")

    # 2. brute force at the same speeds
    lo, hi = scene.analysis["range"]
    grid = np.linspace(lo, hi, args.speeds)
    every = max(args.every, 1)
    simulated = np.arange(0, len(grid), every)
    model = build_model("bearing_rotor", {"f0": 0.5})
    starts = start_states(args.starts, np.random.default_rng(1))
    print(f"\nbrute force: {len(simulated)} of {len(grid)} speeds w = {lo:g}..{hi:g}, {len(starts)} starts each, "
          f"{args.revolutions} revolutions of RK4 at T/4096 (the last {RECORD} classified)")
    print(f"{'w':>8s} {'brute force':>24s} {'diagram':>24s} {'agree':>6s} {'time s':>7s}")
    t_bf, n_agree, differ = [], 0, []
    for i in simulated:
        w = float(grid[i])
        found, dt = brute_force(model, w, starts, args.revolutions)
        t_bf.append(dt)
        dg = diagram_classes(rows, w)
        ok = found <= dg
        n_agree += ok
        if not ok:
            differ += [(w, kind) for kind in sorted(dg & set(CLASS_NU)) if kind not in found]
        print(f"{w:8.4f} {'+'.join(sorted(found)):>24s} {'+'.join(sorted(dg)):>24s} {'yes' if ok else 'NO':>6s} {dt:7.2f}")
    total = float(np.sum(t_bf)) * len(grid) / len(simulated)
    how = "measured" if len(simulated) == len(grid) else f"extrapolated from {len(simulated)} speeds"
    print(f"same classes at {n_agree} of {len(simulated)} speeds (every class a start reached is a stable branch "
          "of the diagram there)")
    for w, kind in differ:
        # the starts missed the diagram's attractor, or the diagram is wrong: integrate from its orbit to tell
        got = from_the_diagram(outdir, scene, rows, w, args.revolutions, kind)
        if got is not None:
            print(f"  w = {w:.4f}: from the diagram's stable {kind} orbit at w = {got[1]:.4f} the simulation stays "
                  f"{got[0]} ({'coexisting attractors' if got[0] == kind else 'THE DIAGRAM IS WRONG THERE'})")
    print(f"brute force {total:.1f} s ({how}); main job {t_diagram:.2f} s; "
          f"ratio brute force / main job = {total / t_diagram:.1f}x")

    # 3. the main job against its floor
    fl = floor_per_point(outdir, scene)
    floor, parts = 0.0, []
    for b in branches:
        if b.get("handed_over_from") is not None and "shooting" in fl:
            t_lu, t_lin, order = fl["shooting"]  # the multipliers come with the linearisation's factors
            floor += b["points"] * (t_lu + t_lin)
            parts.append(f"nu={b['nu']} (shooting): {b['points']} x ({1e3 * t_lu:.2f} ms LU of order {order} + "
                         f"{1e3 * t_lin:.1f} ms linearisation)")
        elif b["nu"] in fl:
            t_lu, t_mono, order = fl[b["nu"]]
            floor += b["points"] * (t_lu + t_mono)
            parts.append(f"nu={b['nu']}: {b['points']} x ({1e3 * t_lu:.2f} ms LU of order {order} + "
                         f"{1e3 * t_mono:.1f} ms monodromy)")
    print(f"\nfloor: {floor:.2f} s = " + " + ".join(parts))
    print(f"main job / floor = {t_diagram / floor:.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
