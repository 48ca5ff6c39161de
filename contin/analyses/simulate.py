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
plots ``simulation_<i>.png`` (time history of the observed pair over the last
revolutions, orbit, amplitude spectrum in units of ``w``) and, for several
values, ``simulation_summary.png``.
"""

from __future__ import annotations

import math
import time

import numpy as np

from contin.scene.parse import model_frequency
from contin.scene.registry import register_analysis
from contin.util.naming import suggest
from contin.scene.schema import Key, SceneError, int_range, is_number

__all__ = ["SIMULATE", "check", "check_time_step", "run", "COLUMNS_HEAD"]


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
                "subharmonic_dominance"]
N_LINES = 4
WHIRL_COLUMNS = {"+w/2": "whirl_fwd_half", "-w/2": "whirl_bwd_half", "+w": "whirl_fwd_1", "-w": "whirl_bwd_1"}


def _columns(parameter: str, dof_names) -> list:
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
           "pattern_ratio": cls.pattern_ratio, "subharmonic_dominance": cls.subharmonic_dominance}
    if row["subharmonic_dominance"] is not None and not math.isfinite(row["subharmonic_dominance"]):
        row["subharmonic_dominance"] = 1e300
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
    from contin.timedomain.simulation import RK4_STABILITY, SimulationError, compile_model

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


def validate(data, model, analysis, lines) -> None:
    """Refuse parameter values that make no physical sense (a negative frequency, mass, ...)."""
    from contin.scene.parse import check_parameter_values

    if analysis["values"] is not None:
        check_parameter_values(model, analysis, analysis["parameter"] or model_frequency(model, analysis),
                               [("analysis.values", analysis["values"])], lines)


def check(scene, model) -> dict:
    """Every check of a ``simulate`` scene with its model; returns its setup.

    Everything the integrator refuses before integrating is checked at each
    value (:func:`check_time_step`).

    Returns
    -------
    dict
        ``param``, ``values``, ``obs`` (observed dof names) and ``dofs``
        (their indices).
    """
    from contin.scene.registry import check_output

    a = scene.analysis
    param = a["parameter"] or model_frequency(scene.model, a)
    if param not in model.parameters:
        raise scene.error("analysis.parameter", f"a parameter of the model {list(model.parameters)}", param,
                          hint=suggest(param, model.parameters))
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
    cols = _columns(param, names)
    check_output(scene, [c for c in cols if c not in ("class", "lines")])
    return {"param": param, "values": values, "obs": obs, "dofs": [names.index(d) for d in obs]}


@register_analysis("simulate", SIMULATE, validate=validate, check=check)
def run(ctx) -> dict:
    """Run a ``simulate`` scene; returns its part of ``summary.json``."""
    from contin.timedomain.poincare import steady_state
    from contin.output.results import CsvStream
    from contin.scene.registry import RunError
    from contin.timedomain.simulation import SimulationError

    scene, model = ctx.scene, ctx.model
    a = scene.analysis
    plan = ctx.plan  # check(), made before anything was written
    param, values, obs, dofs = plan["param"], plan["values"], plan["obs"], plan["dofs"]
    S = a["steps_per_period"]
    spp = a["samples_per_period"]
    names = list(model.dof_names)
    rng = np.random.default_rng(a["seed"])
    out = CsvStream(ctx.outdir / "simulation.csv", _columns(param, names))
    records, rows = [], []
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
                                    f"{done:.0f}/{total:.0f} revolutions")

            try:
                res, cls = steady_state(model, {param: value}, x0, v0, transient=a["transient"], record=a["record"],
                                        steps_per_period=S, samples_per_period=spp,
                                        locate_events=a["locate_events"], dofs=dofs, tol=a["tolerance"],
                                        max_period=a["max_period"], progress=progress,
                                        should_stop=lambda: ctx.stop_requested)
            except SimulationError as exc:  # what it refuses before integrating was checked: numerics
                raise RunError(f"simulation at {param} = {value:g}: {exc}") from None
            except ValueError as exc:  # not expected after check(): say which setting
                raise SceneError("analysis", "settings the simulation can use", None, hint=f": {exc}") from None
            if cls is None:
                ctx.interrupted = True  # stopped by the user mid-run: keep the values that are complete
                break
            previous = res.final_state
            row = _row(param, value, res, cls, names)
            out.write(row)
            rows.append(row)
            np.savez_compressed(ctx.outdir / f"simulation_{i}.npz", t=res.t, x=res.x, v=res.v,
                                section=res.section, section_t=np.arange(res.section.shape[0]) * res.period,
                                dof_names=np.array(names), parameter=param, value=float(value))
            records.append({"index": i, "value": float(value), "class": cls.label, "period": cls.period,
                            "settled": cls.settled, "note": cls.note, "events": res.events,
                            "unresolved_events": res.unresolved_events, "wall_time": res.wall_time,
                            "compile_time": res.compile_time, "cost_per_period_us": res.cost_per_period_us,
                            "notes": res.notes,
                            "_plot": (res.t, res.x[:, dofs].copy(), res.period, res.w, cls)})
    finally:
        out.close()
    ctx.timings["simulation"] = time.perf_counter() - t_all
    ctx.plot = lambda: _plot(ctx, param, obs, records)
    return {
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
    }


def _plot(ctx, param, obs, records) -> list:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from contin.timedomain.poincare import spectrum

    files = []
    n_plot = ctx.scene.analysis["plot_periods"]
    model = ctx.model
    for r in records:
        t, x, T, w, cls = r["_plot"]
        fig, axs = plt.subplots(1, 3, figsize=(13, 3.9), constrained_layout=True)
        sel = t >= t[-1] - n_plot * T
        for j, d in enumerate(obs):
            axs[0].plot(t[sel] / T, x[sel, j], lw=1.0, label=d)
        axs[0].set_xlabel("t / T (revolutions)")
        axs[0].set_ylabel("displacement")
        axs[0].set_title(f"last {n_plot} revolutions")
        axs[0].legend(fontsize=8)
        if x.shape[1] == 2:
            axs[1].plot(x[:, 0], x[:, 1], lw=0.5)
            P = cls.section
            i0, i1 = model.dof_index(obs[0]), model.dof_index(obs[1])
            axs[1].plot(P[:, i0], P[:, i1], ".", color="tab:red", ms=4, label="Poincare section")
            axs[1].set_xlabel(obs[0])
            axs[1].set_ylabel(obs[1])
            axs[1].set_aspect("equal", adjustable="datalim")
            axs[1].legend(fontsize=7, loc="upper right")
            axs[1].set_title("orbit")
            f, amp = spectrum(t, x[:, 0] + 1j * x[:, 1], w)
            axs[2].set_xlabel("frequency / w  (+ forward, - backward whirl)")
        else:
            axs[1].plot(x[:-1, 0], np.diff(x[:, 0]) / np.diff(t), lw=0.5)
            axs[1].set_xlabel(obs[0])
            axs[1].set_ylabel(obs[0] + "_dot")
            axs[1].set_title("phase portrait")
            f, amp = spectrum(t, x[:, 0], w)
            axs[2].set_xlabel("frequency / w")
        keep = np.abs(f) <= 3.0
        axs[2].plot(f[keep], amp[keep], lw=0.9)
        for fl, al in cls.lines[:4]:
            if abs(fl) <= 3.0:
                axs[2].annotate(f"{fl:+.3g}", (fl, al), textcoords="offset points", xytext=(2, 3), fontsize=7)
        axs[2].set_ylabel("amplitude")
        axs[2].set_yscale("log")
        lo = max(amp[keep].max() * 1e-5, 1e-300) if np.any(keep) else 1e-12
        axs[2].set_ylim(bottom=lo)
        axs[2].set_title("spectrum (Hann window)")
        fig.suptitle(f"{model.name}: {param} = {r['value']:.6g}: {cls.label}"
                     + ("" if cls.settled else " (converging)"))
        path = ctx.outdir / f"simulation_{r['index']}.png"
        fig.savefig(path, dpi=100)
        plt.close(fig)
        files.append(path.name)
    if len(records) > 1:
        fig, ax = plt.subplots(figsize=(7, 4.4), constrained_layout=True)
        v = np.array([r["value"] for r in records])
        fw = np.array([abs(r["_plot"][4].whirl["+w/2"]) for r in records])
        f1 = np.array([abs(r["_plot"][4].whirl["+w"]) for r in records])
        ax.plot(v, f1, "-", color="0.6", lw=0.8)
        ax.plot(v, fw, "-", color="tab:blue", lw=0.8)
        style = {1: ("o", "tab:green"), 2: ("s", "tab:red")}
        seen = set()
        for vi, a1, a2, r in zip(v, f1, fw, records):
            m, c = style.get(r["period"], ("D", "tab:purple") if r["period"] else ("x", "k"))
            lab = r["class"] if r["class"] not in seen else None
            seen.add(r["class"])
            ax.plot(vi, a2, m, color=c, mfc="none", label=lab)
            ax.plot(vi, a1, m, color=c, ms=4)
        ax.set_xlabel(param)
        ax.set_ylabel("whirl radius of " + " + i ".join(obs))
        ax.set_title("+w/2 forward whirl (open markers) and +w (filled)")
        ax.legend(fontsize=8)
        path = ctx.outdir / "simulation_summary.png"
        fig.savefig(path, dpi=100)
        plt.close(fig)
        files.append(path.name)
    return files
