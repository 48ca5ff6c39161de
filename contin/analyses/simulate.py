"""``simulate``: time integration to steady state at given parameter values.

For each value of ``parameter`` the model is integrated by fixed-step RK4
(:func:`contin.timedomain.simulation.simulate`, ``steps_per_period`` steps per forcing
period, contact switching located in time) over ``transient`` revolutions,
then ``record`` revolutions are recorded and classified
(:func:`contin.timedomain.poincare.classify`: ``period-k`` or ``not periodic``, from the
Poincare section at ``tau = 0 mod 2 pi`` and the spectrum). This is the
brute-force computation of the rotor paper (Inagaki, Ishida & Hayashi, Trans.
JSME C 71 (2005), section 3 and Fig. 3, 5, 7: Runge-Kutta with 4096 steps per
revolution, time histories, orbits and spectra of the disc).

Result files: ``simulation.csv`` (one row per value, written as each value
finishes), ``simulation_<i>.npz`` (recorded window and section points),
figures ``simulation_<i>.<format>`` (time history of the observed pair over the last
revolutions, orbit, amplitude spectrum in units of ``w`` down to
:data:`SPECTRUM_FLOOR` of its largest line, the main lines named as multiples
of ``w``) and, for several values, ``simulation_summary.<format>``.

A value whose response is not *settled* (an amplitude growing over the
record, a result that depends on the step, a ``period-1`` response still
converging: :func:`contin.timedomain.poincare.steady_state`) says so in its
row (``settled`` false, ``unsettled`` the reason) and is a shortfall of the
run, which ends ``incomplete``.
"""

from __future__ import annotations

import math
import re
import time
from dataclasses import dataclass
from fractions import Fraction

import numpy as np

from contin.analyses.base import Analysis, RunError
from contin.output.exports import RunData
from contin.output.labels import axis_label, math as mathtext
from contin.scene.budget import simulate_demands
from contin.scene.parse import check_parameter_values
from contin.scene.sweep_plan import parameter_name, sweep_names
from contin.scene.registry import check_output
from contin.scene.schema import Key, SceneError, int_range, is_number
from contin.timedomain.poincare import spectrum, steady_state
from contin.timedomain.simulation import RK4_STABILITY, SimulationError, compile_model
from contin.util.naming import suggest
from contin.util.safe_files import replace_file

__all__ = ["SIMULATE", "Simulate", "SimulatePlan", "check_time_step", "result_columns", "COLUMNS_HEAD",
           "SPECTRUM_FLOOR", "frequency_text", "draw_spectrum", "draw_simulation"]


def _initial_ok(v) -> bool:
    return v in ("rest", "small", "previous") or (isinstance(v, list) and len(v) > 0 and all(is_number(x) for x in v))


def _dofs_ok(v) -> bool:
    return v is None or (isinstance(v, list) and 1 <= len(v) <= 2 and all(isinstance(x, str) for x in v)
                         and len(set(v)) == len(v))


#: scene schema of ``analysis`` for ``type: simulate``
SIMULATE = {
    "type": Key("a string", lambda v: isinstance(v, str) and v != "", None, True),
    "parameter": Key("a string", lambda v: isinstance(v, str) and v != ""),
    "values": Key("a non-empty list of finite numbers",
                   lambda v: isinstance(v, list) and len(v) > 0 and all(is_number(x) for x in v), None),
    "steps_per_period": int_range(4096, 8, 2**20),
    "transient": Key("a number >= 0 (revolutions)", lambda v: is_number(v) and v >= 0, 500),
    "record": int_range(100, 4, 100000, "an integer (revolutions)"),
    "samples_per_period": int_range(64, 8, 2**20),
    "initial": Key("'rest', 'small', 'previous' or a list of 2n numbers (displacements, then velocities)",
                    _initial_ok, "rest"),
    "locate_events": Key("true or false", lambda v: isinstance(v, bool), True),
    "tolerance": Key("a positive number", lambda v: is_number(v) and v > 0, 1e-3),
    "max_period": int_range(8, 1, 64),
    "dofs": Key("a list of one or two dof names (the observed pair, e.g. the disc [x1, y1])", _dofs_ok, None),
    "plot_periods": int_range(8, 1, 100000),
    "seed": int_range(0, 0, 2**63 - 1),
}

COLUMNS_HEAD = ["class", "period", "settled", "spread", "mismatch_1", "mismatch_2", "pattern_ratio",
                "subharmonic_dominance", "growth", "step_change", "unsettled"]
#: the text columns (not measures a plot can show)
TEXT_COLUMNS = ("class", "lines", "unsettled")
N_LINES = 4
WHIRL_COLUMNS = {"+w/2": "whirl_fwd_half", "-w/2": "whirl_bwd_half", "+w": "whirl_fwd_1", "-w": "whirl_bwd_1"}


def result_columns(parameter: str, dof_names) -> list:
    """The columns of ``simulation.csv``: the parameter, the classification, the spectral lines, the dofs' measures."""
    cols = [parameter] + COLUMNS_HEAD
    for j in range(1, N_LINES + 1):
        cols += [f"line{j}_freq", f"line{j}_amp"]
    cols += ["lines"] + list(WHIRL_COLUMNS.values())
    for d in dof_names:
        cols += [f"amp_{d}", f"max_{d}", f"min_{d}", f"mean_{d}"]
    cols += ["events", "unresolved_events", "periods", "steps_per_period", "wall_time", "cost_per_period_us"]
    return cols


def _row(parameter, value, res, cls, dof_names) -> dict:
    row = {parameter: float(value), "class": cls.label, "period": cls.period, "settled": cls.settled,
           "spread": cls.spread, "mismatch_1": cls.mismatch.get(1), "mismatch_2": cls.mismatch.get(2),
           "pattern_ratio": cls.pattern_ratio, "subharmonic_dominance": cls.subharmonic_dominance,
           "growth": cls.growth, "step_change": cls.step_change, "unsettled": cls.unsettled}
    for key in ("subharmonic_dominance", "growth", "step_change"):  # inf as the largest float (CSV, strict JSON)
        if row[key] is not None and not math.isfinite(row[key]):
            row[key] = 1e300
    for j, (f, a) in enumerate(cls.lines[:N_LINES], start=1):
        row[f"line{j}_freq"], row[f"line{j}_amp"] = f, a
    row["lines"] = " ".join(f"{f:+.4f}:{a:.4g}" for f, a in cls.lines)
    for key, col in WHIRL_COLUMNS.items():
        row[col] = abs(cls.whirl[key])
    for i, d in enumerate(dof_names):
        x = res.x[:, i]
        row.update({f"amp_{d}": float(np.ptp(x) / 2), f"max_{d}": float(x.max()), f"min_{d}": float(x.min()),
                    f"mean_{d}": float(x.mean())})
    row.update({"events": res.events, "unresolved_events": res.unresolved_events, "periods": res.periods,
                "steps_per_period": res.steps_per_period, "wall_time": res.wall_time,
                "cost_per_period_us": res.cost_per_period_us})
    return row


def _initial_state(a, model, previous, rng):

    n = model.n_dof
    init = a["initial"]
    if isinstance(init, list):
        if len(init) != 2 * n:
            raise SceneError("analysis.initial", f"2n = {2 * n} numbers (displacements of {list(model.dof_names)}, "
                             f"then velocities)", f"{len(init)} numbers")
        y = np.array(init, dtype=float)
        return y[:n], y[n:]
    if init == "previous" and previous is not None:
        return previous[:n].copy(), previous[n:].copy()
    if init == "small":
        return 1e-3 * rng.standard_normal(n), 1e-3 * rng.standard_normal(n)
    return np.zeros(n), np.zeros(n)


def check_time_step(model, params: dict, steps_per_period, key: str, lines: dict | None = None,
                    where: str = "", frequency: str | None = None) -> None:
    """What :func:`contin.timedomain.simulation.simulate` refuses before integrating, as a ``SceneError`` naming ``key``.

    A positive forcing frequency, a mass matrix it can invert, and a step
    ``h = T / steps_per_period`` within RK4's stability limit for the
    stiffest mode with every contact closed.

    Parameters
    ----------
    model : Model
    params : dict
        Parameter values by name (the others: the model's).
    steps_per_period : int
    key : str
        The scene key that sets ``steps_per_period`` (named when it is too small).
    where : str
        Where in the scene the parameter values come from (for messages).
    frequency : str, optional
        The forcing-frequency parameter (default the model's declared one).
    """
    lines = lines or {}
    try:
        model.check_variable(None, params)
    except ValueError as exc:
        raise SceneError(where or "analysis.parameter", "values the model can take without being rebuilt", None,
                         lines.get(where), hint=f": {exc}") from None
    p = model.parameter_vector(params)
    freq = model.frequency if frequency is None else frequency
    w = float(p[model.parameter_index(freq)])
    at = ", ".join(f"{k} = {v:g}" for k, v in params.items())
    if not (math.isfinite(w) and w > 0):
        key_w = where if freq in params and where else f"model.parameters.{freq}"
        raise SceneError(key_w, f"a forcing frequency {freq} > 0 for a time simulation", w, lines.get(key_w))
    try:
        cm = compile_model(model)
        cm.arguments(p)
    except SimulationError as exc:
        raise SceneError("model", "a model that can be integrated in time", None, hint=f": {exc}") from None
    h = 2.0 * math.pi / w / steps_per_period
    rate = cm.fastest_rate(p)
    if rate * h > RK4_STABILITY:
        need = rate * 2.0 * math.pi / w / RK4_STABILITY
        need = f"{math.ceil(need)}" if need <= 2**20 else f"{need:.3g} (more than the 2**20 allowed)"
        raise SceneError(key, f"at least {need} steps per period{' at ' + at if at else ''}: the stiffest mode "
                         f"(|lambda| = {rate:.4g} with the contacts closed) makes RK4 unstable with h = T/"
                         f"{steps_per_period} (h*|lambda| = {rate * h:.3g} > {RK4_STABILITY})", steps_per_period,
                         lines.get(key))


@dataclass(frozen=True)
class SimulatePlan:
    """The checked choices of a ``simulate`` scene.

    Attributes
    ----------
    parameter : str
        The parameter set to each value (``analysis.parameter``, else the forcing frequency).
    values : tuple of float
        Its values (``analysis.values``, else the model's own value).
    observed : tuple of str
        The observed dofs (``analysis.dofs``, else the first two).
    dofs : tuple of int
        Their indices.
    """

    parameter: str
    values: tuple
    observed: tuple
    dofs: tuple


class Simulate(Analysis):
    """``simulate``: time integration to steady state, classified periodic or not (module docstring)."""

    name = "simulate"
    summary = "Time integration to steady state, classified periodic or not."
    required = "none required"
    schema = SIMULATE

    def validate(self, data, model, analysis, lines) -> None:
        """Refuse parameter values that make no physical sense (a negative frequency, mass, ...)."""
        if analysis["values"] is not None:
            check_parameter_values(model, analysis, parameter_name(model, analysis),
                                   [("analysis.values", analysis["values"])], lines)

    def demands(self, scene, model) -> list:
        return simulate_demands(scene, model)

    def plan(self, scene, model) -> SimulatePlan:
        """Every check of a ``simulate`` scene with its model.

        Everything the integrator refuses before integrating is checked at each
        value (:func:`check_time_step`).
        """
        a = scene.analysis
        param, _ = sweep_names(scene, model, need_frequency=False)
        values = a["values"] if a["values"] is not None else [model.parameters[param]]
        S = a["steps_per_period"]
        spp = a["samples_per_period"]
        if S % spp:
            raise scene.error("analysis.samples_per_period", f"a divisor of steps_per_period = {S}", spp)
        names = list(model.dof_names)
        obs = a["dofs"] or names[: min(2, len(names))]
        for d in obs:
            if d not in names:
                raise scene.error("analysis.dofs", f"names among the dofs {names}", d, hint=suggest(d, names))
        if isinstance(a["initial"], list) and len(a["initial"]) != 2 * len(names):
            raise scene.error("analysis.initial", f"2n = {2 * len(names)} numbers (displacements of {names}, then "
                              "velocities)", f"{len(a['initial'])} numbers")
        for value in values:
            check_time_step(model, {param: float(value)}, S, "analysis.steps_per_period", scene.lines,
                            "analysis.values" if a["values"] is not None else f"model.parameters.{param}")
        cols = result_columns(param, names)
        check_output(scene, [c for c in cols if c not in TEXT_COLUMNS])
        return SimulatePlan(parameter=param, values=tuple(values), observed=tuple(obs),
                            dofs=tuple(names.index(d) for d in obs))

    def run(self, plan: SimulatePlan, ctx):
        """Integrate at each value, classify the recorded window; the table, the windows and the summary.

        With a result directory each value's window is ``simulation_<i>.npz``;
        in memory it is the outcome's ``data["simulation_<i>"]`` (the same arrays).
        """
        scene, model = ctx.scene, ctx.model
        a = scene.analysis
        param, values, obs, dofs = plan.parameter, list(plan.values), list(plan.observed), list(plan.dofs)
        S = a["steps_per_period"]
        spp = a["samples_per_period"]
        names = list(model.dof_names)
        rng = np.random.default_rng(a["seed"])
        out = ctx.sink.table("simulation.csv", result_columns(param, names))
        records, rows = [], []
        windows = RunData()
        previous = None
        t_all = time.perf_counter()
        try:
            for i, value in enumerate(values):
                if ctx.stop_requested:
                    ctx.interrupted = True
                    break
                x0, v0 = _initial_state(a, model, previous, rng)

                def progress(done, total, i=i, value=value):
                    ctx.progress.update(f"simulate {param}={value:.6g} ({i + 1}/{len(values)}): "
                                        f"{done:.0f}/{total:.0f} revolutions",
                                        fraction=(i + min(done / total, 1.0)) / len(values) if total > 0 else None)

                try:
                    res, cls = steady_state(model, {param: value}, x0, v0, transient=a["transient"],
                                            record=a["record"], steps_per_period=S, samples_per_period=spp,
                                            locate_events=a["locate_events"], dofs=dofs, tol=a["tolerance"],
                                            max_period=a["max_period"], progress=progress,
                                            should_stop=lambda: ctx.stop_requested)
                except SimulationError as exc:  # what it refuses before integrating was checked: numerics
                    raise RunError(f"simulation at {param} = {value:g}: {exc}") from None
                except ValueError as exc:  # not expected after plan(): say which setting
                    raise SceneError("analysis", "settings the simulation can use", None, hint=f": {exc}") from None
                if cls is None:
                    ctx.interrupted = True  # stopped by the user mid-run: keep the values that are complete
                    break
                previous = res.final_state
                row = _row(param, value, res, cls, names)
                out.write(row)
                rows.append(row)
                window = {"t": res.t, "x": res.x, "v": res.v, "section": res.section,
                          "section_t": np.arange(res.section.shape[0]) * res.period, "dof_names": np.array(names),
                          "parameter": param, "value": float(value)}
                path = ctx.sink.path(f"simulation_{i}.npz")
                if path is None:
                    windows[f"simulation_{i}"] = window
                else:
                    replace_file(path, lambda fh, w=window: np.savez_compressed(fh, **w), binary=True)
                records.append({"index": i, "value": float(value), "class": cls.label, "period": cls.period,
                                "settled": cls.settled, "unsettled": cls.unsettled, "growth": cls.growth,
                                "step_change": cls.step_change, "note": cls.note, "events": res.events,
                                "unresolved_events": res.unresolved_events, "wall_time": res.wall_time,
                                "compile_time": res.compile_time, "cost_per_period_us": res.cost_per_period_us,
                                "notes": res.notes,
                                "_plot": (res.t, res.x[:, dofs].copy(), res.period, res.w, cls)})
        finally:
            out.close()
        ctx.timings["simulation"] = time.perf_counter() - t_all
        # a response that is no steady state is not what the scene asked for
        missing = [f"simulation at {param} = {r['value']:.10g} not settled: {r['unsettled']}"
                   for r in records if not r["settled"]]
        part = {
            "parameter": param,
            "values": [float(v) for v in values],
            "completed": len(records),
            "steps_per_period": S,
            "transient": a["transient"],
            "record": int(math.ceil(a["record"] / 2.0)) * 2,
            "locate_events": a["locate_events"],
            "dofs": obs,
            "results": [{k: v for k, v in r.items() if not k.startswith("_")} for r in records],
            "classes": {c: sum(1 for r in records if r["class"] == c) for c in sorted({r["class"] for r in records})},
            "shortfalls": missing,
        }
        draw = (lambda: _plot(ctx, param, obs, records)) if ctx.sink.writes else None
        return self.outcome(ctx, part, shortfalls=missing, data=None if ctx.sink.writes else windows, draw=draw)


#: a spectrum is drawn down to this fraction of its largest line (below it: leakage and rounding)
SPECTRUM_FLOOR = 1e-6


def frequency_text(f: float, w: str = "w", max_denominator: int = 8, tol: float = 2e-3) -> str:
    """Mathtext for a frequency given in units of ``w``: ``w/2``, ``3w/2``, ``-w``, else ``0.59w``.

    Parameters
    ----------
    f : float
        Frequency / w (signed: a backward whirl is negative).
    w : str
        Mathtext of the forcing frequency's symbol.
    max_denominator : int
        Fractions ``p/q`` with ``q`` up to this are written as fractions.
    tol : float
        How close to ``p/q`` counts as equal.
    """
    fr = Fraction(float(f)).limit_denominator(max_denominator)
    if abs(float(fr) - f) > tol:
        return f"${f:.3g}\\,{w}$"
    if fr == 0:
        return "$0$"
    sign = "-" if fr < 0 else ""
    num, den = abs(fr.numerator), fr.denominator
    head = w if num == 1 else f"{num}{w}"
    return f"${sign}{head}$" if den == 1 else f"${sign}{head}/{den}$"


def draw_spectrum(ax, f, amp, *, lines=(), w: str = "w", fmax: float = 3.0, floor: float = SPECTRUM_FLOOR,
                  label: str | None = None, stems: bool = False, annotate: bool = True, **style) -> None:
    """Draw an amplitude spectrum on a log scale, cut at a noise floor, its main lines named.

    Parameters
    ----------
    ax : matplotlib Axes
    f : ndarray, shape (F,)
        Frequency / w (signed for a two-sided whirl spectrum).
    amp : ndarray, shape (F,)
    lines : sequence of (float, float)
        The lines to name (frequency / w, amplitude); by default the four largest values.
    w : str
        Mathtext of the frequency's symbol (the names read ``w/2``, ``w``, ...).
    fmax : float
        ``|f|`` drawn up to this.
    floor : float
        The axis starts at ``floor`` times the largest amplitude drawn: leakage
        and rounding (1e-16 relative) are not drawn.
    stems : bool
        Vertical stems (a line spectrum, e.g. harmonic amplitudes) instead of a curve.
    annotate : bool
        Name the lines.
    """
    f, amp = np.asarray(f, float), np.asarray(amp, float)
    keep = np.abs(f) <= fmax
    f, amp = f[keep], amp[keep]
    top = float(amp.max()) if amp.size and amp.max() > 0 else 1.0
    lo = top * floor
    if stems:
        shown = amp >= lo
        ax.vlines(f[shown], lo, amp[shown], lw=2.0, label=label, **style)
        ax.plot(f[shown], amp[shown], "o", ms=3.5, **style)
    else:
        ax.plot(f, np.maximum(amp, lo), lw=0.9, label=label, **style)
    ax.set_yscale("log")
    ax.set_ylim(lo, top * 3.0)
    if not annotate:
        return
    if not len(lines):
        order = np.argsort(amp)[::-1][:4]
        lines = [(f[j], amp[j]) for j in order if amp[j] >= 1e3 * lo]
    ax.autoscale_view()
    placed = []  # boxes of the names placed, in points: a name that would cover one moves aside or is left out
    for fl, al in sorted(lines, key=lambda t: -t[1]):
        if abs(fl) > fmax or al < lo:
            continue
        text = frequency_text(fl, w)
        x, y = ax.transData.transform((fl, al)) * 72.0 / ax.figure.dpi
        width = 5.5 * len(re.sub(r"\\[A-Za-z]+", "x", text.strip("$")).replace("\\,", "")) + 4.0
        for dx, ha in ((0.0, "center"), (3.0, "left"), (-3.0, "right")):
            x0 = x + dx - (0.5 * width if ha == "center" else 0.0 if ha == "left" else width)
            box = (x0, y + 2.0, x0 + width, y + 14.0)
            if not any(box[0] < b[2] and b[0] < box[2] and box[1] < b[3] and b[1] < box[3] for b in placed):
                placed.append(box)
                ax.annotate(text, (fl, al), textcoords="offset points", xytext=(dx, 4), ha=ha, fontsize=8)
                break


def _plot(ctx, param, obs, records) -> list:
    out = ctx.scene.output
    files = []
    n_plot = ctx.scene.analysis["plot_periods"]
    model = ctx.model
    sym = getattr(model, "symbols", None)
    wsym = mathtext(model.frequency, sym).strip("$")
    units, labels = out["units"], out["labels"]
    from contin.output.figures import figure_style, new_figure, save_figure  # deferred: matplotlib, to draw

    with figure_style(out["style"]):
        for r in records:
            fig = new_figure((13.0, 4.2))
            axs = fig.subplots(1, 3)
            draw_simulation(axs, r["_plot"], obs, model, n_plot, units=units, labels=labels, symbols=sym, w=wsym)
            fig.suptitle(out["title"] or f"{model.name}: {mathtext(param, sym)} = {r['value']:.6g}: "
                         f"{r['class']}" + ("" if r["settled"] else " (not settled)"))
            files += save_figure(fig, ctx.sink.path(f"simulation_{r['index']}"), out["formats"], out["dpi"])
        if len(records) > 1:
            fig = new_figure((7.0, 4.8))
            ax = fig.add_subplot()
            v = np.array([r["value"] for r in records])
            fw = np.array([abs(r["_plot"][4].whirl["+w/2"]) for r in records])
            f1 = np.array([abs(r["_plot"][4].whirl["+w"]) for r in records])
            ax.plot(v, f1, "-", color="0.6", lw=0.8, label=f"component $+{wsym}$ (filled markers)")
            ax.plot(v, fw, "-", color="tab:blue", lw=0.8, label=f"component $+{wsym}/2$ (open markers)")
            style = {1: ("o", "tab:green"), 2: ("s", "tab:red")}
            seen = set()
            for vi, a1, a2, r in zip(v, f1, fw, records):
                m, c = style.get(r["period"], ("D", "tab:purple") if r["period"] else ("x", "k"))
                ax.plot(vi, a2, m, color=c, mfc="none", label=r["class"] if r["class"] not in seen else None)
                seen.add(r["class"])
                ax.plot(vi, a1, m, color=c, ms=4)
            ax.set_xlabel(axis_label(param, units, labels, sym))
            pair = " + i\\,".join(mathtext(d, sym).strip("$") for d in obs)
            ax.set_ylabel(f"forward whirl radius of ${pair}$" if len(obs) == 2 else f"amplitude of ${pair}$")
            ax.set_title(out["title"] or f"{model.name}: forward whirl components against {mathtext(param, sym)}")
            ax.legend(loc="best")
            files += save_figure(fig, ctx.sink.path("simulation_summary"), out["formats"], out["dpi"])
    return files


def draw_simulation(axs, data, obs, model, n_plot: int, *, units=None, labels=None, symbols=None, w: str = "w"):
    """Draw one simulated value into three axes: time history, orbit (or phase portrait), spectrum.

    Parameters
    ----------
    axs : sequence of 3 matplotlib Axes
    data : tuple
        ``(t (N,), x (N, k), T, w, classification)`` of the observed dofs (k = 1 or 2).
    obs : list of str
        The observed dofs.
    model : Model
    n_plot : int
        Revolutions of the time history.
    w : str
        Mathtext of the forcing frequency's symbol.
    """
    t, x, T, wv, cls = data
    sel = t >= t[-1] - n_plot * T
    for j, d in enumerate(obs):
        axs[0].plot(t[sel] / T, x[sel, j], lw=1.0, label=mathtext(d, symbols))
    axs[0].set_xlabel("time $t/T$ (revolutions)")
    same = {(units or {}).get(d) for d in obs}
    axs[0].set_ylabel("displacement" + (f" [{same.pop()}]" if len(same) == 1 and None not in same else ""))
    axs[0].set_title(f"last {n_plot} revolutions")
    axs[0].legend(loc="upper right")
    if x.shape[1] == 2:
        axs[1].plot(x[:, 0], x[:, 1], lw=0.5)
        P = cls.section
        i0, i1 = model.dof_index(obs[0]), model.dof_index(obs[1])
        axs[1].plot(P[:, i0], P[:, i1], ".", color="tab:red", ms=4, label="Poincaré section")
        axs[1].set_xlabel(axis_label(obs[0], units, labels, symbols))
        axs[1].set_ylabel(axis_label(obs[1], units, labels, symbols))
        axs[1].set_aspect("equal", adjustable="datalim")
        axs[1].legend(loc="upper right")
        axs[1].set_title("orbit")
        f, amp = spectrum(t, x[:, 0] + 1j * x[:, 1], wv)
        axs[2].set_xlabel(f"frequency / ${w}$  (+ forward, − backward whirl)")
    else:
        axs[1].plot(x[:-1, 0], np.diff(x[:, 0]) / np.diff(t), lw=0.5)
        axs[1].set_xlabel(axis_label(obs[0], units, labels, symbols))
        axs[1].set_ylabel(axis_label(obs[0] + "_dot", units, labels, symbols))
        axs[1].set_title("phase portrait")
        f, amp = spectrum(t, x[:, 0], wv)
        axs[2].set_xlabel(f"frequency / ${w}$")
    draw_spectrum(axs[2], f, amp, lines=cls.lines[:6], w=w)
    axs[2].set_ylabel("amplitude")
    axs[2].set_title("spectrum (Hann window)")

