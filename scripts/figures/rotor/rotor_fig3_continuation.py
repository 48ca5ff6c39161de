"""The rotor paper's Fig. 3 by continuation: the disc's whirl components from the periodic and torus branches.

Inagaki, Ishida & Hayashi's Fig. 3 plots, against the rotor speed, the radii of the disc's whirl components
along speed sweeps of time simulations (``rotor_fig3.py`` redraws it so). Here the same components come from
solutions:

- the harmonic (``nu = 1``) branch and the 1/2-subharmonic (``nu = 2``) branch of the main job's diagram
  (``scenes/rotor_f0_05.yaml``, or ``rotor_f0_02.yaml`` for ``f0 = 0.2``): the forward whirl at ``+w``
  (``whirl_fwd_1_disc``) and at ``+w/2`` (``whirl_fwd_half_disc``), solid where stable, dashed where not;
- the tori of the self-excited forward whirl: each an invariant circle of the map over one revolution
  (``--points`` points, 4096 RK4 steps a revolution) fitted to a simulation at one of the ``--fit``
  speeds and taken in plain steps of the speed down and up to where it ends
  (:func:`contin.bifurcation.circle_steps.step_circle`); at each circle the forward whirl at ``+w``,
  the self-excited forward whirl at ``p_f`` and the combination, backward at ``p_f - w``
  (:func:`contin.timedomain.circle_measures.circle_whirl`), ``p_f / w``, and the stability
  (:class:`contin.bifurcation.circle_branch.CircleStabilityMonitor`: the normal Lyapunov exponents, a
  simulation started off the circle where they give no verdict; dash-dotted where neither gives one).

Drawn over the simulation sweep (``rotor_fig3_sweeps.csv`` of ``rotor_fig3.py -o DIR``, read with
``--sweeps DIR``, faded; without it the figure shows the solutions alone) into
``rotor_fig3_continued_f0_<f0>.png``; the seconds of the continuation are printed beside those the
sweep took (its rows' wall times; ``scripts/bench/bench_rotor_fig3.py`` times both in one run). The
diagram's result directory (``OUTDIR/diagram``) and the tori's rows (``OUTDIR/torus_f0_<f0>.csv``)
stay; ``--redraw`` draws the figure again from them. At f0 = 0.2 the sweep shows no torus (``--fit`` with
no speed draws the branches alone).

    python scripts/figures/rotor/rotor_fig3_continuation.py --sweeps results/rotor_fig3   # f0 = 0.5, 6 min
    python scripts/figures/rotor/rotor_fig3_continuation.py --f0 0.2 --fit --sweeps results/rotor_fig3
    python scripts/figures/rotor/rotor_fig3_continuation.py --quick     # the first torus, three circles
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from contin.analyses.torus_start import circle_from_simulation
from contin.api import load, run
from contin.bifurcation.circle_branch import CircleStabilityMonitor
from contin.bifurcation.circle_steps import step_circle
from contin.engine.newton import solve_at_parameter
from contin.engine.options import ContinuationOptions
from contin.model.catalog import build_model
from contin.output.figures import figure_style, new_figure, save_figure
from contin.output.results import CsvStream, read_csv
from contin.timedomain.circle_measures import circle_whirl
from contin.timedomain.shooting import ShootingOptions, ShootingProblem
from contin.util.blas import limit_blas_threads

sys.path.insert(0, str(Path(__file__).resolve().parent))
from rotor_fig3 import COMPONENTS, draw_components, draw_pf_ratio, sweeps_from_csv  # noqa: E402

ROOT = Path(__file__).resolve().parents[3]
#: the main job's scene of each static force
SCENES = {0.5: ROOT / "scenes" / "rotor_f0_05.yaml", 0.2: ROOT / "scenes" / "rotor_f0_02.yaml"}
COLOURS = {attr: colour for attr, colour, _ in COMPONENTS}


def torus_rows(f0: float, fit: float, points: int, span: tuple[float, float], step: float, min_step: float,
               stability: bool) -> tuple[list[dict], list[str]]:
    """The torus' circles from a fit at ``fit`` stepped down to ``span[0]`` and up to ``span[1]``: one row
    each (``fit``, ``w``, the radii, ``ratio``, ``stable``), in increasing ``w``, and how each way ended."""
    model = build_model("bearing_rotor", {"f0": f0, "w": fit})
    shooting = ShootingProblem(model, "w", options=ShootingOptions(steps_per_period=4096))
    problem, u = circle_from_simulation(shooting, {"start_simulation": {"transient": 600, "steps_per_period": 1024},
                                                   "torus": {"points": points}}, fit, 40)
    r = solve_at_parameter(problem, u, fit, ContinuationOptions(newton_tol=1e-8, newton_max_iter=12))
    if not r.converged:
        raise SystemExit(f"no circle of {points} points near the simulation at w = {fit}: {r.message}")
    monitor = CircleStabilityMonitor(problem) if stability else None

    def measure(x, lam):
        row = {"fit": fit, "w": float(lam), **circle_whirl(problem, x, lam, 0, 1), "stable": -1}
        if monitor is not None:
            verdict = monitor(x, lam)
            row["stable"] = int(verdict["stable"]) if verdict["evaluated"] else -1
        return row

    def show(lam, x, iterations, row):
        print(f"  w = {lam:8.5f}  p_f/w = {row['ratio']:.5f}  forced {row['forced']:.4f}  self-excited "
              f"{row['self_excited']:.4f}  combination {row['combination']:.4f}  stable {row['stable']:+d}  "
              f"({iterations} Newton steps)", flush=True)

    rows, ends = [], []
    for end in span:
        steps = step_circle(problem, r.x, fit, np.sign(end - fit) * step, end, min_step=min_step, measure=measure,
                            callback=show)
        rows.extend(steps.rows if not rows else steps.rows[1:])
        ends.append(steps.message)
        print(f"  {steps.message}", flush=True)
    rows.sort(key=lambda row: row["w"])
    return rows, ends


def _split(extra: dict, label: str, w, y, verdict, colour: str, styles, lw: float = 1.1) -> None:
    """``y`` over ``w`` as one curve per stability verdict (``styles``: ``{verdict: (line style, word)}``,
    ``verdict`` 1 stable, 0 unstable, -1 none); ``label`` formatted with the word, the first curve of a label
    in the legend (a label starting ``_`` stays out of it)."""
    for value, (style, word) in styles.items():
        mine = verdict == value
        yy = np.where(mine | np.r_[False, mine[:-1]], y, np.nan)  # on to the next point: the curves join
        if np.any(np.isfinite(yy)):
            key = label.format(word)
            while key in extra:
                key = "_" + key
            extra[key] = (w, yy, {"color": colour, "ls": style, "lw": lw})


#: the periodic branches' verdicts (Floquet: always one) and the torus' (Lyapunov exponents: may be none)
PERIODIC_STYLES = {1: ("-", "stable"), 0: ("--", "unstable"), -1: ("-.", "no verdict")}
TORUS_STYLES = {1: ("-", "stable"), 0: (":", "unstable"), -1: ("-.", "no verdict")}


def periodic_curves(result) -> dict:
    """The radius panel's curves of the periodic branches: the forward whirl at ``+w`` of every branch, and
    at ``+w/2`` of the subharmonic ones (stable solid, unstable dashed)."""
    extra: dict = {}
    for br in result.branches:
        if br.torus:
            continue
        verdict = np.asarray(br.stable if br.stable is not None else np.ones(len(br)), dtype=int)
        name = "harmonic" if br.nu == 1 else "1/2-subharmonic"
        _split(extra, f"{name} branch, {{}}" if br.nu == 1 else "_{} +w", br.parameter, br["whirl_fwd_1_disc"],
               verdict, COLOURS["forced"], PERIODIC_STYLES)
        if br.nu == 2:
            _split(extra, f"{name} branch, {{}}", br.parameter, br["whirl_fwd_half_disc"], verdict,
                   COLOURS["subharmonic"], PERIODIC_STYLES)
    return extra


def torus_curves(rows: list[dict]) -> tuple[dict, dict]:
    """Each torus' radii and ``p_f / w`` as curves, thick, one line style per stability verdict."""
    extra: dict = {}
    ratio: dict = {}
    for fit in dict.fromkeys(r["fit"] for r in rows):
        mine = [r for r in rows if r["fit"] == fit]
        w = np.array([r["w"] for r in mine])
        verdict = np.array([r["stable"] for r in mine])
        for attr in ("self_excited", "forced", "combination"):
            label = "torus, {}" if attr == "self_excited" else "_torus {} " + attr
            _split(extra, label, w, np.array([r[attr] for r in mine]), verdict, COLOURS[attr], TORUS_STYLES, 1.8)
        key = r"$p_f/\Omega$ of the tori"
        ratio["_" * len(ratio) + key] = (w, np.array([r["ratio"] for r in mine]), {"color": "k", "lw": 1.2})
    return extra, ratio


def _fade_markers(ax) -> None:
    """The simulation's markers faded under the curves of the solutions."""
    for line in ax.lines:
        if line.get_linestyle() in ("None", "none", ""):
            line.set_alpha(0.35)
        else:
            line.set_zorder(3)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--f0", type=float, default=0.5, choices=sorted(SCENES), help="static lateral force")
    ap.add_argument("--fit", type=float, nargs="*", default=(1.9, 2.1, 2.3),
                    help="speeds of the simulations a torus is fitted to (one torus each; none: no torus)")
    ap.add_argument("--points", type=int, default=31, help="N, points of the circle (odd)")
    ap.add_argument("--span", type=float, nargs=2, default=(1.6, 2.6), help="speeds the tori are stepped to")
    ap.add_argument("--step", type=float, default=0.02, help="largest step of a torus in the speed")
    ap.add_argument("--min-step", type=float, default=1e-3, help="where a torus' steps end")
    ap.add_argument("--sweeps", type=Path, default=None, metavar="DIR",
                    help="DIR/rotor_fig3_sweeps.csv of rotor_fig3.py, drawn under the solutions")
    ap.add_argument("-o", "--outdir", type=Path, default=Path("results/rotor_fig3_continued"))
    ap.add_argument("--quick", action="store_true", help="the first torus only, one circle each way, no stability")
    ap.add_argument("--redraw", action="store_true", help="draw from OUTDIR's diagram and torus rows (no run)")
    args = ap.parse_args(argv)
    limit_blas_threads(1)  # the steps end where Newton fails near a corner: rounding decides, so fix it
    span, min_step, stability, fits = tuple(args.span), args.min_step, True, list(args.fit)
    if args.quick and fits:
        fits = fits[:1]
        args.points, span, min_step, stability = 31, (fits[0] - 0.01, fits[0] + 0.01), 2e-3, False
    args.outdir.mkdir(parents=True, exist_ok=True)
    table = args.outdir / f"torus_f0_{args.f0:g}.csv"
    if args.redraw:
        result = None if args.quick else load(args.outdir / "diagram")
        got = read_csv(table) if table.exists() else {}
        rows = [{k: float(got[k][i]) for k in got} for i in range(len(got.get("w", ())))]
        t0 = t2 = time.perf_counter()
    else:
        t0 = time.perf_counter()
        result = None
        if not args.quick:
            result = run(str(SCENES[args.f0]), args.outdir / "diagram")
            print(f"periodic branches ({SCENES[args.f0].name}): {result.status}, {time.perf_counter() - t0:.1f} s")
        t1 = time.perf_counter()
        rows = []
        for fit in fits:
            print(f"torus of f0 = {args.f0:g}: circle of {args.points} points fitted at w = {fit}", flush=True)
            mine, _ = torus_rows(args.f0, fit, args.points, span, args.step, min_step, stability)
            print(f"torus over w in [{mine[0]['w']:.5f}, {mine[-1]['w']:.5f}], {len(mine)} circles", flush=True)
            rows += mine
        t2 = time.perf_counter()
        print(f"tori {t2 - t1:.1f} s")
        if rows:
            out = CsvStream(table, list(rows[0]))
            try:
                for row in rows:
                    out.write(row)
            finally:
                out.close()
    sweeps = {}
    if args.sweeps is not None:
        sweeps = sweeps_from_csv(args.sweeps / "rotor_fig3_sweeps.csv").get(args.f0, {})
        if sweeps and not args.redraw:
            seconds = sum(float(sw.wall_time.sum()) for sw in sweeps.values())
            print(f"continuation {t2 - t0:.1f} s against the simulation sweep's {seconds:.1f} s (its rows' wall "
                  f"times): {seconds / (t2 - t0):.1f}x")
    extra = periodic_curves(result) if result is not None else {}
    more, extra_ratio = torus_curves(rows) if rows else ({}, {})
    extra.update(more)
    with figure_style("contin"):
        fig = new_figure(figsize=(7.8, 8.2))
        top, bottom = fig.subplots(2, 1, sharex=True, height_ratios=(2.2, 1.0))
        draw_components(top, sweeps, extra)
        draw_pf_ratio(bottom, sweeps, extra_ratio)
        for ax in (top, bottom):
            _fade_markers(ax)
        where = "over the simulation sweep (markers)" if sweeps else "alone"
        what = "branches and tori" if rows else "branches"
        top.set_title(rf"bearing rotor, $f_0 = {args.f0:g}$: {what} {where}", fontsize=10)
        top.set_xlabel("")
        top.tick_params(labelbottom=True)
        for ax in (top, bottom):
            ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=7.0, borderaxespad=0.0)
        names = save_figure(fig, args.outdir / f"rotor_fig3_continued_f0_{args.f0:g}")
    print(f"wrote {', '.join(names)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
