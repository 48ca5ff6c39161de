"""Benchmark: cost per continuation point of a finite-element rotor with a clearance contact, against its dofs.

The rotors are the test rig of :mod:`contin.model.fem.rig` (a 16 mm x 900 mm
steel shaft, the 480 mm disc at the node nearest 550 mm from the top, a
pinned upper bearing at node 0, the disc damper at the disc node, the lower
bearing's holder mass and damping at the last node, where the clearance
contact is) discretised with more and more shaft elements: ``--sizes`` counts
nodes (10, 50, 200 nodes: 40, 200, 800 lateral dofs). Their matrices are read
from ``scripts/bench/data/fe_rotor_{nodes}.npz``, written once in ROSS by
``--write-data`` (:func:`rig_rotor_n`); the timing run needs no ROSS.

For each rotor the model is :func:`contin.model.fem.builder.fe_rotor_model`
with the rig's contact, unbalance and side load (:func:`contin.model.fem.rig.rig_items`,
the nodes moved to this rotor's), harmonic solutions (``nu = 1``) at
``--harmonics`` harmonics with the contact's crossings resolved
(``crossings="interval"``), parameter ``w``. A start at ``w = 1.6``
(:func:`contin.bifurcation.start.contact_start`, a homotopy in the contact
stiffness on the condensed problem) is timed apart. From it ``--points``
continuation steps of ``ds = ds_max`` (shorter only after a rejected step;
Newton tolerance :data:`NEWTON_TOL`) are timed for

(a) the problem condensed exactly onto the contact node (:func:`contin.hb.condensation.condense`),
    the eliminated blocks factored in band storage;
(b) the full problem (a dense Jacobian of ``n (2H+1)`` rows), only where that is at most
    :data:`FULL_LIMIT` (``--full-limit``; else its cost is extrapolated from the measured growth);
(c) the condensed problem with the eliminated blocks factored densely (``banded=False``).

The table gives seconds per stored point (from the stored start to the last
point: the branch's own start is printed apart), residual and Jacobian
evaluations per point, the ratios, and the log-log slopes of (a) and (c)
against the lateral dofs, per point and per evaluation. The last points are
compared with (a): where a path ends at the same ``w`` as (a) (the same
steps), as they are; else (the full branch's arclength also counts the
eliminated dofs; rounding can turn a step of (c) away from (a)'s) with the
condensed solution at that ``w``, by Newton from the nearest point of (a).
``--profile`` adds a cProfile of the condensed run of the largest rotor
(top 8 by own time). ``--quick`` (CI's slow tier): the 10- and 50-node
rotors, 5 points, the full problem of the smallest only.

    python scripts/bench/bench_fe_rotor.py [--quick] [--sizes 10,50,200] [--points 20] [--harmonics 10] [--profile]
    python scripts/bench/bench_fe_rotor.py --write-data    # needs ROSS (pip install 'contin[ross]')
"""

from __future__ import annotations

import argparse
import cProfile
import dataclasses
import io
import math
import os
import pstats
import time
from pathlib import Path

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np

from contin.bifurcation.start import contact_start
from contin.engine.continuation import ContinuationOptions, continuation
from contin.engine.newton import solve_at_parameter
from contin.hb.condensation import CondensedHarmonicBalance, condense
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.model.fem.builder import Units, fe_rotor_model
from contin.model.fem.matrices import RotorMatrices, load_matrices
from contin.model.fem.rig import RIG, rig_items, rig_scales

DATA = Path(__file__).resolve().parent / "data"
#: numbers of nodes of the default run (9, 49, 199 shaft elements)
SIZES = (10, 50, 200)
#: the start speed and the end of the continuation range
W_START, W_END = 1.6, 2.6
#: the full problem is run only when its unknowns n (2H+1) are at most this (a dense LU of that size per step)
FULL_LIMIT = 5000
#: the same with --quick: only the smallest rotor's full problem (at 50 nodes its branch start alone takes a minute)
FULL_LIMIT_QUICK = 1000
#: AFT samples per period
SAMPLES = 256
#: Newton tolerance on the residual (model force units), as in scenes/rotor_fe_rig.yaml. The residual's rounding
#: noise as w moves grows with the mesh (stiffer elements, worse conditioned blocks): about 1e-10 at 200 nodes,
#: where the default 1e-10 makes the corrector stall and the steps shrink
NEWTON_TOL = 1e-9
#: tolerance of the Newton solves that compare the paths (at a fixed w there is no such noise)
COMPARE_TOL = 1e-11


def rotor_file(nodes: int) -> Path:
    return DATA / f"fe_rotor_{nodes}.npz"


def disc_node(n_el: int) -> int:
    """The node nearest the disc's place, ``RIG['a']`` below the upper bearing (on a tie, the upper one)."""
    pos = np.arange(n_el + 1) * (RIG["length"] / n_el)
    return int(np.argmin(np.abs(pos - RIG["a"])))


def rig_rotor_n(n_el: int):
    """The rig of :func:`contin.model.fem.rig.rig_rotor` with ``n_el`` equal shaft elements, as a ``ross.Rotor``.

    The disc and its damper at :func:`disc_node`, the upper (pinned) bearing at
    node 0, the lower bearing (holder mass and damping, no spring: the contact
    is added by the model) at node ``n_el``. Needs ROSS.
    """
    from contin.model.fem.ross_bridge import import_ross

    rs = import_ross()
    r, s = RIG, rig_scales()
    steel = rs.Material(name="rig_steel", rho=r["rho"], E=r["E"], G_s=r["G"])
    shaft = [rs.ShaftElement(r["length"] / n_el, idl=0.0, odl=r["diameter"], material=steel, beta=r["shaft_beta"])
             for _ in range(n_el)]
    nd = disc_node(n_el)
    disc = rs.DiskElement.from_geometry(n=nd, material=steel, width=r["disc_width"], i_d=r["diameter"],
                                        o_d=r["disc_diameter"], tag="disc")
    mwn = s["m1"] * s["wn"]
    upper = rs.BearingElement(n=0, kxx=r["upper_stiffness"], cxx=0.0, tag="upper")
    disc_damper = rs.BearingElement(n=nd, kxx=0.0, cxx=r["c1"] * mwn, tag="disc_damping")
    lower = rs.BearingElement(n=n_el, kxx=0.0, cxx=r["c2"] * mwn, mxx=r["beta"] * s["m1"], tag="lower")
    return rs.Rotor(shaft, [disc], [upper, disc_damper, lower])


def write_data(sizes) -> None:
    """Build each rotor in ROSS and write its matrices (:meth:`RotorMatrices.save`)."""
    from contin.model.fem.ross_bridge import from_ross

    DATA.mkdir(parents=True, exist_ok=True)
    for nodes in sizes:
        rm = from_ross(rig_rotor_n(nodes - 1), f"ROSS 2.3: the rig with {nodes - 1} shaft elements "
                                               "(scripts/bench/bench_fe_rotor.py)")
        rm.save(rotor_file(nodes))
        print(f"wrote {rotor_file(nodes).name}: {rm.n_nodes} nodes, {rm.n_dof} lateral dofs, disc at node "
              f"{int(rm.discs[0, 0])} ({rm.positions[int(rm.discs[0, 0])]:.4f} m), "
              f"{rotor_file(nodes).stat().st_size / 1024:.0f} kB")


def read_rotor(nodes: int) -> RotorMatrices:
    path = rotor_file(nodes)
    if not path.is_file():
        raise SystemExit(f"{path}: missing; write it once with ROSS installed: "
                         f"python scripts/bench/bench_fe_rotor.py --write-data --sizes {nodes}")
    return load_matrices(path)


def rotor_problem(rotor: RotorMatrices, H: int) -> HarmonicBalance:
    """The harmonic balance of the rotor with the rig's contact, unbalance and side load, parameter ``w``."""
    disc, lower = int(rotor.discs[0, 0]), rotor.n_nodes - 1
    items = rig_items()
    items = {"contact": dataclasses.replace(items["contact"], node=lower),
             "unbalance": tuple(dataclasses.replace(u, node=disc) for u in items["unbalance"]),
             "side_load": dataclasses.replace(items["side_load"], node=disc)}
    model = fe_rotor_model(rotor, **items, units=Units(1e-3, rig_scales()["m1"], None))
    params = dict(model.parameters)
    params["w"] = W_START
    return HarmonicBalance(model, "w", HBOptions(harmonics=H, subharmonic=1, crossings="interval",
                                                 samples=max(SAMPLES, 4 * H + 1)), params)


def options(points: int) -> ContinuationOptions:
    """Steps of at most ``ds = ds_max`` (shorter only after a rejected step), ``points`` of them after the start."""
    return ContinuationOptions(ds=0.005, ds_max=0.005, max_points=points + 1, direction=1, newton_tol=NEWTON_TOL)


@dataclasses.dataclass(frozen=True)
class Timing:
    """One path's continuation.

    Attributes
    ----------
    branch : Branch
    per_point : float
        Seconds per step, from the stored start to the last point (nan with no step).
    evaluations : float
        Residual and Jacobian evaluations per step.
    start : float
        Seconds of the branch's own start (Newton at ``W_START``, the initial
        tangent: an SVD of the Jacobian), paid once per branch, so kept out of
        the cost per point.
    """

    branch: object
    per_point: float
    evaluations: float
    start: float

    @property
    def steps(self) -> int:
        return max(len(self.branch) - 1, 0)


def timed_branch(problem, u0, points: int) -> Timing:
    """The continuation from ``u0`` at ``W_START``, timed point by point."""
    stamps, evals = [], []

    def stamp(branch, index):
        stamps.append(time.perf_counter())
        evals.append(problem.evaluations)

    t = time.perf_counter()
    br = continuation(problem, u0, W_START, (W_START, W_END), options(points), parameter_name="w", callback=stamp)
    if len(stamps) < 2:
        return Timing(br, math.nan, math.nan, (stamps[0] if stamps else time.perf_counter()) - t)
    k = len(stamps) - 1
    return Timing(br, (stamps[-1] - stamps[0]) / k, (evals[-1] - evals[0]) / k, stamps[0] - t)


def relative(a, b) -> float:
    return float(np.linalg.norm(np.asarray(a) - np.asarray(b)) / max(np.linalg.norm(b), 1e-300))


def slope(x, y) -> float:
    """The log-log slope of ``y`` against ``x`` (least squares), nan with fewer than two points."""
    if len(x) < 2:
        return math.nan
    return float(np.polyfit(np.log(x), np.log(y), 1)[0])


def fmt(v, spec=".3g") -> str:
    return "-" if v is None or (isinstance(v, float) and math.isnan(v)) else format(v, spec)


def profile_run(problem, u0, points: int) -> str:
    """The top 8 functions by own time of one condensed continuation, as pstats prints them."""
    prof = cProfile.Profile()
    prof.enable()
    continuation(problem, u0, W_START, (W_START, W_END), options(points), parameter_name="w")
    prof.disable()
    out = io.StringIO()
    pstats.Stats(prof, stream=out).strip_dirs().sort_stats("tottime").print_stats(8)
    return out.getvalue()


def measure(nodes: int, H: int, points: int, full_limit: int) -> dict:
    """One rotor: the start, then the three paths; their times, points and last points."""
    rotor = read_rotor(nodes)
    hb = rotor_problem(rotor, H)
    ca = condense(hb, require=True)
    cc = CondensedHarmonicBalance(hb, ca.dofs, banded=False)
    t = time.perf_counter()
    u_full = contact_start(hb, W_START)
    row = {"nodes": nodes, "n": hb.n, "eliminated": int(ca.eliminated.size), "size_c": ca.size,
           "size_full": hb.size, "band": ca.band, "start": time.perf_counter() - t, "hb": hb, "ca": ca, "cc": cc}
    u0 = ca.restrict(u_full)
    row["a"] = timed_branch(ca, u0, points)
    row["c"] = timed_branch(cc, u0, points)
    row["b"] = timed_branch(hb, u_full, points) if hb.size <= full_limit else None
    row["u0"] = u0
    return row


def condensed_at(ca, branch, lam: float):
    """The condensed solution at ``lam`` by Newton from the point of ``branch`` nearest in ``lam``, expanded."""
    i = int(np.argmin(np.abs(branch.parameter - lam)))
    res = solve_at_parameter(ca, branch.unknowns[i], lam, ContinuationOptions(newton_tol=COMPARE_TOL,
                                                                              newton_max_iter=20))
    return ca.expand(res.x, lam) if res.converged else res.message


def agreement(row) -> list:
    """The last points of (c) and (b) against (a) (see the module docstring), one line each."""
    ca = row["ca"]
    ba, out = row["a"].branch, []
    for key, name, problem in (("c", "dense elimination (c)", row["cc"]), ("b", "full (b)", None)):
        if row[key] is None or not len(row[key].branch) or not len(ba):
            continue
        other = row[key].branch
        lam = other.parameter[-1]
        u = other.unknowns[-1] if problem is None else problem.expand(other.unknowns[-1], lam)
        same = lam == ba.parameter[-1]
        ref = ca.expand(ba.unknowns[-1], lam) if same else condensed_at(ca, ba, lam)
        how = "both ending at w" if same else "(a) solved anew at this path's last w"
        if isinstance(ref, str):
            out.append(f"{name}: the condensed Newton at w = {lam:.10f} did not converge: {ref}")
        else:
            out.append(f"{name} against (a), {how} = {lam:.10f}: |u - u_a|/|u_a| = {relative(u, ref):.1e}")
    return out


def report(rows, points: int, limit: int) -> None:
    """The table, the growth, the skipped full problems, short branches and the agreement of the paths."""
    paths = ("a", "b", "c")

    def each(r, get, spec):
        return "/".join(fmt(get(r[k]), spec) if r[k] is not None else "-" for k in paths)

    print(f"{'nodes':>5} {'dofs':>5} {'elim.':>5} {'unknowns c/full':>15} {'band':>5} {'start [s]':>9} "
          f"{'(a) [s/pt]':>10} {'(b) [s/pt]':>10} {'(c) [s/pt]':>10} {'(b)/(a)':>7} {'(c)/(a)':>7} "
          f"{'points a/b/c':>12} {'evals/pt a/b/c':>16}")
    for r in rows:
        a, b, c = (r[k].per_point if r[k] is not None else None for k in paths)
        band = "dense" if r["band"] is None else f"{r['band'][0]},{r['band'][1]}"
        unknowns = f"{r['size_c']}/{r['size_full']}"
        print(f"{r['nodes']:>5} {r['n']:>5} {r['eliminated']:>5} {unknowns:>15} {band:>5} {r['start']:>9.2f} "
              f"{a:>10.4f} {fmt(b, '.4f'):>10} {c:>10.4f} {fmt(b / a if b else None, '.1f'):>7} {c / a:>7.1f} "
              f"{each(r, lambda t: t.steps, 'd'):>12} {each(r, lambda t: t.evaluations, '.1f'):>16}")
    n = [r["n"] for r in rows]
    for what, get in (("point", lambda t: t.per_point), ("evaluation", lambda t: t.per_point / t.evaluations)):
        ga, gc = (slope(n, [get(r[k]) for r in rows]) for k in ("a", "c"))
        print(f"growth of the seconds per {what} with the lateral dofs (log-log slope): (a) {fmt(ga, '.2f')}, "
              f"(c) {fmt(gc, '.2f')}")
    for r in rows:
        print(f"{r['nodes']} nodes, the branches' own start (Newton at w = {W_START}, initial tangent), not in the "
              f"cost per point [s]: {each(r, lambda t: t.start, '.3g')} (a/b/c)")
    full = [r for r in rows if r["b"] is not None]
    gb = slope([r["n"] for r in full], [r["b"].per_point for r in full])
    for r in rows:
        if r["b"] is not None:
            continue
        msg = f"(b) skipped at {r['nodes']} nodes: {r['size_full']} unknowns > {limit}"
        if full:
            g, how = (gb, "measured") if not math.isnan(gb) else (3.0, "assumed: dense LU")
            est = full[-1]["b"].per_point * (r["n"] / full[-1]["n"]) ** g
            msg += (f"; at the growth of (b) (slope {g:.2f}, {how}) a point would take about {est:.3g} s, "
                    f"{est / r['a'].per_point:.0f} times (a)")
        print(msg)
    for r in rows:
        for k in paths:
            t = r[k]
            if t is not None and t.steps < points:
                print(f"{r['nodes']} nodes, path ({k}): stopped after {t.steps} of {points} points: "
                      f"{t.branch.status}: {t.branch.message}")
            if t is not None and t.branch.info.get("n_rejected_steps"):
                print(f"{r['nodes']} nodes, path ({k}): {t.branch.info['n_rejected_steps']} rejected steps (last: "
                      f"{t.branch.info.get('last_failure', '')}), smallest step {t.branch.step_sizes[1:].min():.2g}")
        for line in agreement(r):
            print(f"{r['nodes']} nodes, {line}")


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default=None, help="numbers of nodes, comma-separated (default 10,50,200)")
    ap.add_argument("--points", type=int, default=None, help="continuation steps timed per path (default 20)")
    ap.add_argument("--harmonics", type=int, default=10, help="H")
    ap.add_argument("--quick", action="store_true", help="the 10- and 50-node rotors, 5 points (CI)")
    ap.add_argument("--write-data", action="store_true", help="build the rotors in ROSS and write their files")
    ap.add_argument("--profile", action="store_true", help="cProfile the condensed run of the largest rotor")
    ap.add_argument("--full-limit", type=int, default=None,
                    help=f"largest n (2H+1) for which the full problem is run (default {FULL_LIMIT}, "
                         f"{FULL_LIMIT_QUICK} with --quick)")
    args = ap.parse_args(argv)
    sizes = [int(s) for s in args.sizes.split(",")] if args.sizes else list((10, 50) if args.quick else SIZES)
    points = args.points or (5 if args.quick else 20)
    limit = args.full_limit if args.full_limit is not None else (FULL_LIMIT_QUICK if args.quick else FULL_LIMIT)
    if args.write_data:
        try:
            write_data(sizes)
        except ImportError as exc:
            raise SystemExit(f"--write-data: {exc}") from None
        return
    missing = [str(rotor_file(nodes)) for nodes in sizes if not rotor_file(nodes).is_file()]
    if missing:
        raise SystemExit(f"missing {missing}; write them once with ROSS installed: "
                         f"python scripts/bench/bench_fe_rotor.py --write-data --sizes {args.sizes or '10,50,200'}")
    H = args.harmonics
    print(f"finite-element rig rotors, harmonic solutions (nu = 1), H = {H}, {max(SAMPLES, 4 * H + 1)} samples, "
          f"crossings 'interval'; start at w = {W_START} (contact_start), then {points} continuation steps of "
          f"ds = 0.005 per path; one BLAS thread")
    print("start: contact_start; (a) condensed onto the contact node, banded elimination; (b) full problem, "
          "dense Jacobian; (c) condensed, dense elimination")
    # the compiled kernels of every path are loaded on a small rotor first, untimed
    measure(SIZES[0] if rotor_file(SIZES[0]).is_file() else min(sizes), H, 2, limit)
    rows = [measure(nodes, H, points, limit) for nodes in sizes]
    report(rows, points, limit)
    if args.profile:
        r = max(rows, key=lambda row: row["n"])
        print(f"cProfile of path (a) at {r['nodes']} nodes, {points} points (top 8 by own time):")
        print(profile_run(condense(r["hb"], require=True), r["u0"], points).rstrip())


if __name__ == "__main__":
    main()
