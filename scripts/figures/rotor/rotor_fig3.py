"""The rotor paper's Fig. 3 from time simulations: the disc's whirl components along up and down speed sweeps.

Inagaki, Ishida & Hayashi, Trans. JSME C 71 (2005), section 3 and Fig. 3
("Resonance of disc (simulation)"): the bearing rotor (eq. 11) integrated by
Runge-Kutta with 4096 steps per revolution, the speed stepped up and then
down, each speed started from the last state of the previous one. Around the
1/2-order subharmonic resonance the disc shows the harmonic (forced) whirl at
``+w``, the self-excited forward whirl at ``p_f``, the combination oscillation
backward at ``p_f - w`` (the paper's ``p_f - p_b = w``) and the entrainment
into the forward ``+w/2`` whirl. The components and the verdict at each speed
come from :func:`contin.timedomain.whirl_sweep.component_sweep` (tolerances
and the record length needed near locking: see there).

For each static force ``f0`` (default 0.5, the paper's Fig. 3, and 0.2) the
script runs the rotor up from rest through a few lower speeds (the run-up,
not recorded), sweeps ``w`` up over ``[1.6, 2.6]``, then down from where the up
sweep ended, and writes

- ``rotor_fig3_sweeps.csv``: one row per run speed (columns ``f0``,
  ``direction``, then :data:`contin.timedomain.whirl_sweep.CSV_COLUMNS`);
- ``rotor_fig3_f0_<f0>.png``: the whirl radii against the rotor speed (one
  colour per component, filled markers for the up sweep, open ones for the
  down sweep) above ``p_f / w`` (the entrained speeds at 1/2, where ``p_f`` is
  locked);

and prints, per ``f0`` and direction, the speed intervals of each verdict and
the run time.

Overlaying other curves (e.g. continuation branches of the torus) on the same
axes: :func:`draw_components` and :func:`draw_pf_ratio` take an ``Axes`` and
``extra = {label: (w, y, style)}``, with ``w`` and ``y`` arrays of one length
and ``style`` a matplotlib format string (``"k-"``) or a dict of keyword
arguments of ``Axes.plot`` (``{"color": "k", "ls": "--"}``); each is drawn with
``label`` in the legend. From another script in this folder::

    from rotor_fig3 import draw_components
    draw_components(ax, {"up": up, "down": down}, extra={"torus, stable": (w, r, "k-")})

    python scripts/figures/rotor/rotor_fig3.py [--quick] [-o OUTDIR] [--f0 0.5 0.2] [--w 1.6 2.6 0.01]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from types import SimpleNamespace
from typing import Mapping

import numpy as np

from contin.model.catalog import build_model
from contin.output.figures import figure_style, new_figure, save_figure
from contin.output.results import CsvStream, read_csv
from contin.timedomain.whirl_sweep import CSV_COLUMNS, Verdict, WhirlSweep, component_sweep
from contin.util.blas import limit_blas_threads

#: paper's settings (section 3): 4096 RK4 steps per revolution. 600 revolutions of transient per speed (each
#: starts from the previous speed's end) and 400 recorded, which tells p_f from its mirror w - p_f down to
#: |p_f/w - 1/2| = 0.004. The up sweep starts from a run-up from rest through lower speeds: started from rest
#: at w = 1.6 itself the rotor falls into a self-excited whirl that coexists with the stable harmonic orbit
FULL = {"w": (1.6, 2.6, 0.01), "transient": 600.0, "record": 400, "steps": 4096, "run_up": (1.2, 1.4, 1.5)}
#: CI smoke run: four speeds, 1024 steps per revolution (the fewest the contact stiffness allows above
#: w = 1.81), short runs, no run-up
QUICK = {"speeds": (1.9, 2.0, 2.16, 2.2), "transient": 150.0, "record": 60, "steps": 1024, "run_up": ()}

#: one colour per component: (WhirlSweep attribute, colour, legend text)
COMPONENTS = (("forced", "tab:blue", r"forward whirl at $+\Omega$"),
              ("subharmonic", "tab:red", r"forward whirl at $+\Omega/2$"),
              ("self_excited", "tab:green", r"self-excited forward whirl at $p_f$"),
              ("combination", "tab:purple", r"combination: backward whirl at $p_f - \Omega$"))
#: marker of each sweep direction (a key of the ``sweeps`` mapping): filled up, open down
DIRECTIONS = {"up": {"marker": "o", "ms": 2.8}, "down": {"marker": "o", "ms": 5.0, "mfc": "none", "mew": 0.8}}


def _direction_style(name: str) -> dict:
    return DIRECTIONS.get(name, {"marker": "s", "ms": 4.0, "mfc": "none"})


def _draw_extra(ax, extra: Mapping[str, tuple] | None) -> None:
    """The caller's curves ``{label: (w, y, style)}`` (style: a format string or a dict of ``plot`` arguments)."""
    for label, (w, y, style) in (extra or {}).items():
        w, y = np.asarray(w, dtype=float), np.asarray(y, dtype=float)
        if w.shape != y.shape:
            raise ValueError(f"extra curve {label!r}: w and y differ in shape, {w.shape} and {y.shape}")
        if isinstance(style, str):
            ax.plot(w, y, style, label=label)
        else:
            ax.plot(w, y, label=label, **dict(style or {}))


def _direction_keys(ax, sweeps) -> None:
    """Grey legend entries for the sweep directions (the colours stand for the components)."""
    for name in sweeps:
        ax.plot([], [], ls="none", color="0.35", label=f"sweep {name}", **_direction_style(name))


def draw_components(ax, sweeps: Mapping[str, WhirlSweep], extra: Mapping[str, tuple] | None = None) -> None:
    """Whirl radii of the disc against the rotor speed, as the paper's Fig. 3.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
    sweeps : mapping of str to WhirlSweep
        By sweep direction (``"up"``, ``"down"``: filled and open markers); one colour per component,
        a component drawn only where present (radius > 0).
    extra : mapping of str to (ndarray, ndarray, str or dict), optional
        More curves ``{label: (w, radius, style)}`` drawn over the markers (continuation branches).
    """
    for attr, color, text in COMPONENTS:
        for name, sw in sweeps.items():
            r = getattr(sw, attr)
            m = r > 0.0
            ax.plot(sw.w[m], r[m], ls="none", color=color, **_direction_style(name))
        ax.plot([], [], ls="none", marker="o", ms=5, color=color, label=text)
    _direction_keys(ax, sweeps)
    _draw_extra(ax, extra)
    ax.set_xlabel(r"rotor speed $\Omega$")
    ax.set_ylabel("whirl radius of the disc")
    ax.set_ylim(bottom=0.0)


def draw_pf_ratio(ax, sweeps: Mapping[str, WhirlSweep], extra: Mapping[str, tuple] | None = None) -> None:
    """The self-excited whirl's frequency over the speed, ``p_f / w``; entrained speeds at 1/2 (``p_f`` locked).

    Parameters
    ----------
    ax : matplotlib.axes.Axes
    sweeps : mapping of str to WhirlSweep
    extra : mapping of str to (ndarray, ndarray, str or dict), optional
        More curves ``{label: (w, ratio, style)}`` (e.g. a torus branch's second frequency over ``w``).
    """
    green, red = COMPONENTS[2][1], COMPONENTS[1][1]
    for name, sw in sweeps.items():
        st = _direction_style(name)
        ax.plot(sw.w[sw.has_pf], sw.pf[sw.has_pf] / sw.w[sw.has_pf], ls="none", color=green, **st)
        locked = sw.verdict == Verdict.ENTRAINED.value
        ax.plot(sw.w[locked], np.full(int(locked.sum()), 0.5), ls="none", color=red, **st)
    ax.axhline(0.5, color="0.5", lw=0.7, ls=":")
    ax.plot([], [], ls="none", marker="o", ms=5, color=green, label=r"$p_f/\Omega$ (quasi-periodic)")
    ax.plot([], [], ls="none", marker="o", ms=5, color=red, label=r"entrained: $p_f = \Omega/2$")
    _draw_extra(ax, extra)
    ax.set_xlabel(r"rotor speed $\Omega$")
    ax.set_ylabel(r"$p_f/\Omega$")


def figure(f0: float, sweeps: Mapping[str, WhirlSweep], steps: int, stem: Path,
           extra: Mapping[str, tuple] | None = None, extra_ratio: Mapping[str, tuple] | None = None) -> list[str]:
    """Both panels for one ``f0``, legends beside each; returns the file names written.

    ``extra`` and ``extra_ratio``: more curves for the radius panel and the ``p_f / w`` panel
    (see :func:`draw_components`).
    """
    with figure_style("contin"):
        fig = new_figure(figsize=(7.6, 8.2))
        top, bottom = fig.subplots(2, 1, sharex=True, height_ratios=(2.2, 1.0))
        draw_components(top, sweeps, extra)
        draw_pf_ratio(bottom, sweeps, extra_ratio)
        top.set_title(rf"bearing rotor, $f_0 = {f0:g}$: time simulation, {steps} steps per revolution")
        top.set_xlabel("")  # the speed axis is labelled once, under the lower panel
        top.tick_params(labelbottom=True)
        for ax in (top, bottom):
            ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=7.5, borderaxespad=0.0)
        return save_figure(fig, stem)


def sweeps_from_csv(path: Path) -> dict[float, dict[str, SimpleNamespace]]:
    """The sweeps of an earlier run's ``rotor_fig3_sweeps.csv``, ``{f0: {direction: sweep}}``.

    Each sweep holds the arrays that :func:`draw_components`, :func:`draw_pf_ratio` and
    :func:`verdict_ranges` read (``w``, the radii, ``pf``, ``has_pf``, ``verdict``), in the run's order.
    """
    rows = read_csv(path)
    out: dict[float, dict[str, SimpleNamespace]] = {}
    for f0 in dict.fromkeys(rows["f0"].tolist()):
        out[f0] = {}
        for name in dict.fromkeys(rows["direction"][rows["f0"] == f0].tolist()):
            m = (rows["f0"] == f0) & (rows["direction"] == name)
            has_pf = rows["has_pf"][m].astype(bool)
            out[f0][name] = SimpleNamespace(
                w=rows["w"][m], forced=rows["forced_radius"][m], subharmonic=rows["subharmonic_radius"][m],
                self_excited=rows["self_excited_radius"][m], combination=rows["combination_radius"][m],
                pf=np.where(has_pf, np.nan_to_num(rows["pf"][m].astype(float)), 0.0), has_pf=has_pf,
                verdict=rows["verdict"][m].astype(str), wall_time=rows["wall_time"][m])
    return out


def run_sweeps(f0: float, speeds, transient: float, record: int, steps: int, run_up=()):
    """The bearing rotor at ``f0``: ``("run-up", sweep)`` over the ``run_up`` speeds from rest (when given), then
    ``("up", sweep)`` over ``speeds`` and ``("down", sweep)`` back, each started from the last one's final state
    (:func:`contin.timedomain.whirl_sweep.component_sweep`, ``transient`` + ``record`` revolutions a speed,
    ``steps`` RK4 steps a revolution); a generator, so that a caller times and writes each as it ends."""
    model = build_model("bearing_rotor", {"f0": f0})
    state = None
    parts = ([("run-up", tuple(run_up))] if len(run_up) else []) + [("up", speeds), ("down", speeds[::-1])]
    for name, ws in parts:
        sw = component_sweep(model, {"f0": f0}, ws, transient_periods=transient, record_periods=record,
                             steps_per_period=steps, x0=None if state is None else state[:model.n_dof],
                             v0=None if state is None else state[model.n_dof:])
        state = sw.final_state
        yield name, sw


def report(f0: float, name: str, sw, seconds: float) -> None:
    """Print the speed intervals of each verdict and the range of p_f of one sweep."""
    ranges = verdict_ranges(sw)
    print(f"f0 = {f0:g}, sweep {name}: {seconds:.1f} s ({1e3 * sw.wall_time.mean():.0f} ms per speed)")
    for v in Verdict:
        if v.value in ranges:
            print(f"  {v.value:16s} w = {_ranges_text(ranges[v.value])}")
    pf = sw.pf[sw.has_pf] / sw.w[sw.has_pf]
    if pf.size:
        print(f"  p_f / w from {pf.min():.4f} to {pf.max():.4f} (p_f from "
              f"{sw.pf[sw.has_pf].min():.4f} to {sw.pf[sw.has_pf].max():.4f})")


def verdict_ranges(sw: WhirlSweep) -> dict[str, list[tuple[float, float]]]:
    """Speed intervals (first, last speed of a run of equal verdicts, in increasing w) of each verdict."""
    order = np.argsort(sw.w)
    w, v = sw.w[order], sw.verdict[order]
    out: dict[str, list] = {}
    start = 0
    for i in range(1, w.size + 1):
        if i == w.size or v[i] != v[start]:
            out.setdefault(str(v[start]), []).append((float(w[start]), float(w[i - 1])))
            start = i
    return out


def _ranges_text(ranges) -> str:
    return ", ".join(f"{a:.3f}" if a == b else f"{a:.3f}-{b:.3f}" for a, b in ranges)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="four speeds, short runs (the CI smoke run)")
    ap.add_argument("-o", "--outdir", type=Path, default=Path("results/rotor_fig3"))
    ap.add_argument("--f0", type=float, nargs="+", default=[0.5, 0.2], help="static lateral forces (paper: 0.5, 0.2)")
    ap.add_argument("--w", type=float, nargs=3, metavar=("START", "STOP", "STEP"), default=None,
                    help=f"speed grid (default {' '.join(map(str, FULL['w']))})")
    ap.add_argument("--transient", type=float, default=None, help="revolutions dropped at each speed")
    ap.add_argument("--record", type=int, default=None, help="revolutions recorded at each speed")
    ap.add_argument("--steps", type=int, default=None, help="RK4 steps per revolution (paper: 4096)")
    ap.add_argument("--run-up", type=float, nargs="*", default=None, metavar="W",
                    help=f"speeds run from rest before the up sweep (default {' '.join(map(str, FULL['run_up']))})")
    ap.add_argument("--from", dest="source", type=Path, default=None, metavar="DIR",
                    help="redraw the figures from DIR/rotor_fig3_sweeps.csv of an earlier run (no simulation)")
    args = ap.parse_args(argv)
    limit_blas_threads(1)
    if args.source is not None:
        args.outdir.mkdir(parents=True, exist_ok=True)
        for f0, sweeps in sweeps_from_csv(args.source / "rotor_fig3_sweeps.csv").items():
            for name, sw in sweeps.items():
                report(f0, name, sw, float(sw.wall_time.sum()))
            steps = args.steps or FULL["steps"]
            print(f"  wrote {', '.join(figure(f0, sweeps, steps, args.outdir / f'rotor_fig3_f0_{f0:g}'))}")
        return 0
    base = QUICK if args.quick else FULL
    if args.w is not None:
        lo, hi, step = args.w
        speeds = np.round(np.arange(lo, hi + 0.5 * step, step), 10)
    elif args.quick:
        speeds = np.array(QUICK["speeds"])
    else:
        lo, hi, step = FULL["w"]
        speeds = np.round(np.arange(lo, hi + 0.5 * step, step), 10)
    transient = base["transient"] if args.transient is None else args.transient
    record = base["record"] if args.record is None else args.record
    steps = base["steps"] if args.steps is None else args.steps
    run_up = base["run_up"] if args.run_up is None else tuple(args.run_up)
    out = args.outdir
    out.mkdir(parents=True, exist_ok=True)
    start = "from rest" + (f" through w = {', '.join(f'{w:g}' for w in run_up)}" if run_up else "")
    print(f"bearing rotor, f0 = {', '.join(f'{f:g}' for f in args.f0)}: {speeds.size} speeds in "
          f"[{speeds.min():g}, {speeds.max():g}] up ({start}), then down; RK4 with {steps} steps per revolution, "
          f"{transient:g} transient + {record} recorded revolutions per speed")
    csv = CsvStream(out / "rotor_fig3_sweeps.csv", ["f0", "direction", *CSV_COLUMNS])
    t_all = time.perf_counter()
    try:
        for f0 in args.f0:
            sweeps = {}
            t0 = time.perf_counter()
            for name, sw in run_sweeps(f0, speeds, transient, record, steps, run_up):
                if name == "run-up":
                    print(f"f0 = {f0:g}, run-up: " + ", ".join(f"w = {w:g} {v}" for w, v in zip(sw.w, sw.verdict)))
                else:
                    sweeps[name] = sw
                    for row in sw.to_rows():
                        csv.write({"f0": f0, "direction": name, **row})
                    report(f0, name, sw, time.perf_counter() - t0)
                t0 = time.perf_counter()
            names = figure(f0, sweeps, steps, out / f"rotor_fig3_f0_{f0:g}")
            print(f"  wrote {', '.join(names)}")
    finally:
        csv.close()
    print(f"total {time.perf_counter() - t_all:.1f} s; results in {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
