"""``backbone``: free conservative periodic solutions, frequency unknown, versus amplitude.

For each requested linear mode about the static equilibrium, the backbone
problem of :mod:`contin.bifurcation.backbone` (harmonic balance of the model
under its static load, the period mean of its excitation
(:func:`contin.modal.equilibrium.static_model`), a phase condition, an
unfolding parameter that vanishes on the solutions, and the amplitude of the
observed dof as the continuation parameter) is followed over ``range`` of
that amplitude, starting at the linear natural frequency. ``summary.json``
names the excitations that vary in time (``dropped_excitations``): only
their mean loads the equilibrium.

Scene keys: ``mode`` (an integer or a list: 1 = lowest), ``dof`` (a dof or
a linear observable of the model, e.g. the belt's ``w``), ``range`` (of the
amplitude, both positive with ``spacing: log``), ``amplitude`` (``peak``:
``(max - min)/2`` over a period, which is ``max|x|`` for an oscillation
symmetric about zero; ``rms``: RMS of the oscillating part), ``spacing``
(``log``: the points are spaced in ``ln A``), ``harmonics``, ``samples``,
``continuation``.

Result files: ``branches.csv`` (one row per point: ``branch``, ``nu`` = 1,
``mode``, ``amplitude``, ``frequency``, ``stable``/``n_unstable``/
``max_multiplier`` empty (a conservative orbit is neutrally stable),
``unfolding`` (the unfolding parameter, zero to rounding on a true
solution), the measures of every dof, the model's own columns,
``newton_iterations``, ``residual_norm``), ``special_points.csv``
(``frequency_min`` / ``frequency_max`` where the frequency turns, e.g. from
softening to hardening; ``fold`` where the amplitude turns; ``bp``; ``end``)
and ``backbone.png`` (amplitude against frequency, the linear frequencies
dotted).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import matplotlib
import numpy as np

from contin.analyses.base import Analysis, RunError, ScaleCheck
from contin.bifurcation.backbone import BackboneError, BackboneProblem, frequency_extremum_event
from contin.engine.continuation import ContinuationOptions, continuation
from contin.hb.measures import measure_names, point_measures
from contin.modal.equilibrium import ModalError, time_varying_excitations
from contin.output.dense import dense_branch
from contin.output.labels import model_symbols, quantity
from contin.output.plotting import SPECIAL, bifurcation_diagram
from contin.scene.budget import backbone_demands
from contin.scene.registry import check_output, shortfalls
from contin.scene.schema import Key, SceneError, is_int, is_number, mapping, string

__all__ = ["BACKBONE", "Backbone", "BackbonePlan", "result_columns"]


def _modes_ok(v) -> bool:
    return (is_int(v) and v >= 1) or (isinstance(v, list) and len(v) > 0 and all(is_int(x) and x >= 1 for x in v)
                                      and len(set(v)) == len(v))


BACKBONE = {
    "type": string(required=True),
    "mode": Key("an integer >= 1 or a list of distinct integers >= 1 (linear modes, 1 = lowest)", _modes_ok, 1),
    "dof": string(),
    "range": Key("a list of two different numbers [start, end] (amplitudes)",
                 lambda v: isinstance(v, list) and len(v) == 2 and all(is_number(x) for x in v) and v[0] != v[1],
                 required=True),
    "amplitude": string("peak", ("peak", "rms")),
    "spacing": string("log", ("log", "linear")),
    "harmonics": Key("an integer from 1 to 200", lambda v: is_int(v) and 1 <= v <= 200, 5),
    "samples": Key("an integer from 2*harmonics+1 to 2**16, or null",
                   lambda v: v is None or (is_int(v) and 3 <= v <= 2**16), None),
    "continuation": mapping(),
}

EXTRA = ["interval_lo", "interval_hi", "located", "detail"]


def result_columns(model, H: int) -> dict:
    """``measures`` and the columns of ``branches.csv`` and ``special_points.csv`` of a backbone of ``model``."""
    measures = measure_names(model.dof_names, 5, H) + (
        list(getattr(model, "observable_names", ())) if getattr(model, "observables", None) else [])
    head = ["branch", "nu", "mode", "amplitude", "frequency", "stable", "n_unstable", "max_multiplier", "unfolding"]
    return {"measures": measures, "branches.csv": head + measures + ["newton_iterations", "residual_norm"],
            "special_points.csv": ["branch", "kind", "mode", "amplitude", "frequency", "index"] + measures + EXTRA}


class _BackboneRecorder:
    """Streams the rows of ``branches.csv`` and ``special_points.csv``."""

    def __init__(self, sink, model, H):
        self.model = model
        self.observables = getattr(model, "observables", None)
        cols = result_columns(model, H)
        self.measures = cols["measures"]
        self.columns = cols["branches.csv"]
        self.special_columns = cols["special_points.csv"]
        self.rows = sink.table("branches.csv", self.columns)
        self.special = sink.table("special_points.csv", self.special_columns)
        self.n_rows = 0
        self.curves: dict = {}
        self.special_list: list = []

    def _measures(self, u):
        out = point_measures(u, self.model.n_dof, self.model.dof_names, 5)
        if self.observables is not None:
            out.update(self.observables(u, self.model.n_dof, 1))
        return out

    def point(self, bid, prob, branch, i):
        u, w, eps = prob.split(branch.unknowns[i])
        A, _ = prob.amplitude_target(float(branch.parameter[i]))
        row = {"branch": bid, "nu": 1, "mode": prob.mode, "amplitude": A, "frequency": w, "unfolding": eps,
               "newton_iterations": int(branch.newton_iterations[i]),
               "residual_norm": float(branch.residual_norms[i])}
        row.update(self._measures(u))
        self.rows.write(row)
        c = self.curves.setdefault(bid, {"x": [], "y": [], "mode": prob.mode, "omega0": prob.omega0,
                                         "offset": self.n_rows - i, "lam": [], "v": [], "direction": []})
        c["x"].append(w)
        c["y"].append(A)
        # the unknowns and the tangent in their units, for the dense curve
        c["lam"].append(float(branch.parameter[i]))
        c["v"].append(np.array(branch.unknowns[i], dtype=float))
        su, sl = branch.info.get("unknown_scale"), branch.info.get("parameter_scale")
        t = np.asarray(branch.tangents[i], dtype=float)
        if su is not None and sl is not None:
            c["scale"] = np.append(np.broadcast_to(np.asarray(su, dtype=float), (t.size - 1,)), float(sl))
        c["direction"].append(t * c["scale"] if su is not None and sl is not None else None)
        self.n_rows += 1

    def specials(self, bid, prob, branch):
        off = self.curves.get(bid, {}).get("offset", 0)
        for sp in branch.special_points:
            kind = sp.kind.value
            if kind == "start":
                continue
            u, w, _ = prob.split(sp.unknowns)
            if kind == "user":
                t0, t1 = sp.test_values if len(sp.test_values) == 2 else (0.0, 0.0)
                # the frequency component of the tangent goes from - to + at a minimum
                kind = "frequency_min" if t0 < 0 < t1 or t0 < 0 <= t1 else "frequency_max"
            A, _ = prob.amplitude_target(float(sp.parameter))
            row = {"branch": bid, "kind": kind, "mode": prob.mode, "amplitude": A, "frequency": w,
                   "index": off + min(max(sp.index, 0), len(branch) - 1),
                   "interval_lo": min(prob.amplitude_target(v)[0] for v in sp.interval),
                   "interval_hi": max(prob.amplitude_target(v)[0] for v in sp.interval), "located": bool(sp.located),
                   "detail": sp.message}
            row.update(self._measures(u))
            self.special.write(row)
            self.special_list.append(row)

    def close(self):
        self.rows.close()
        self.special.close()


@dataclass(frozen=True)
class BackbonePlan:
    """The checked choices of a ``backbone`` scene.

    Attributes
    ----------
    A0, A1 : float
        The amplitude range (start, end).
    log : bool
        The points are spaced in ``ln A``.
    options : ContinuationOptions
        ``analysis.continuation`` (its direction set per mode by the run).
    problems : tuple of BackboneProblem
        One per mode.
    columns : dict
        :func:`result_columns`.
    """

    A0: float
    A1: float
    log: bool
    options: ContinuationOptions
    problems: tuple
    columns: dict


class Backbone(Analysis):
    """``backbone``: free conservative periodic solutions against their amplitude (module docstring)."""

    name = "backbone"
    summary = "Free conservative periodic solutions against their amplitude."
    required = "dof, range"
    schema = BACKBONE

    def demands(self, scene, model) -> list:
        return backbone_demands(scene, model)

    def plan(self, scene, model) -> BackbonePlan:
        """Every check of a ``backbone`` scene with its model (the range, the options, one problem per mode)."""
        a = scene.analysis
        modes = a["mode"] if isinstance(a["mode"], list) else [a["mode"]]
        A0, A1 = float(a["range"][0]), float(a["range"][1])
        log = a["spacing"] == "log"
        if log and min(A0, A1) <= 0:
            raise scene.error("analysis.range", "two positive amplitudes (spacing: log)", a["range"])
        if not log and min(A0, A1) < 0:
            raise scene.error("analysis.range", "two non-negative amplitudes", a["range"])
        if A0 == 0:
            raise scene.error("analysis.range", "a start amplitude above zero (the branch starts from the linear "
                              "mode at a small amplitude)", a["range"])
        try:
            opts = ContinuationOptions.from_dict({"ds": 0.01, "ds_max": 0.05, **a["continuation"]})
        except ValueError as exc:
            raise SceneError("analysis.continuation", "valid continuation options", None, hint=f": {exc}") from None
        problems = []
        for mode in modes:
            try:
                problems.append(BackboneProblem(model, mode, a["dof"], a["harmonics"], a["samples"], a["amplitude"],
                                                log))
            except ModalError as exc:  # the backbone's own errors, and its static problem's
                key = "analysis.dof" if "neither a dof" in str(exc) or "does not move" in str(exc) else \
                    "analysis.mode" if "mode must" in str(exc) else "model"
                raise SceneError(key, "a backbone the model can have", None, hint=f": {exc}") from None
            except ValueError as exc:
                raise SceneError("analysis", "a discretisation the model can use", None, hint=f": {exc}") from None
        cols = result_columns(problems[0].model, problems[0].H)
        check_output(scene, cols["branches.csv"][2:])
        return BackbonePlan(A0=A0, A1=A1, log=log, options=opts, problems=tuple(problems), columns=cols)

    def describe(self, plan: BackbonePlan, scene, model) -> list[str]:
        a = scene.analysis
        return [f"  free periodic solutions of mode(s) {a['mode']}, {a['amplitude']} amplitude of "
                f"{a['dof'] or 'the first observable'} over {a['range']} ({a['spacing']} spacing), harmonics "
                f"H={a['harmonics']}; unknowns: {model.n_dof * (2 * a['harmonics'] + 1) + 2} = {model.n_dof} dof x "
                f"(2H+1) + frequency + unfolding parameter"]

    def scale_checks(self, plan: BackbonePlan) -> list[ScaleCheck]:
        return [ScaleCheck("analysis.continuation.unknown_scale", plan.options, p.m + 2,
                           f"{p.m} coefficients, the frequency and the amplitude") for p in plan.problems]

    def run(self, plan: BackbonePlan, ctx):
        """Follow each mode's backbone over the amplitude range; tables and summary."""
        scene, model = ctx.scene, ctx.model
        a = scene.analysis
        A0, A1, log, opts, problems = plan.A0, plan.A1, plan.log, plan.options, plan.problems
        rec = _BackboneRecorder(ctx.sink, problems[0].model, problems[0].H)
        t0 = time.perf_counter()
        info = []
        try:
            for bid, prob in enumerate(problems):
                lam0, lam1 = prob.parameter_of(A0), prob.parameter_of(A1)
                try:
                    v0 = prob.start(A0, opts)
                except BackboneError as exc:
                    raise RunError(f"backbone of mode {prob.mode}: {exc}") from None

                def callback(branch, i, bid=bid, prob=prob):
                    rec.point(bid, prob, branch, i)
                    ctx.progress.update(f"backbone of mode {prob.mode}: amplitude "
                                        f"{prob.amplitude_target(branch.parameter[i])[0]:.4g}, "
                                        f"frequency {branch.unknowns[i][prob.m]:.6g}",
                                        parameter=branch.parameter, bounds=(lam0, lam1), task=f"backbone {bid}")
                    return not ctx.stop_requested

                o = opts.replace(direction=1 if lam1 > lam0 else -1)
                br = continuation(prob, v0, lam0, tuple(sorted((lam0, lam1))), o, parameter_name="amplitude",
                                  events=[frequency_extremum_event(prob)], callback=callback, solve_start=False)
                rec.specials(bid, prob, br)
                W = br.unknowns[:, prob.m] if len(br) else np.array([])
                eps = np.abs(br.unknowns[:, prob.m + 1]).max() if len(br) else math.nan
                info.append({"branch": bid, "nu": 1, "mode": prob.mode, "linear_frequency": prob.omega0,
                             "points": len(br), "status": br.status.value, "message": br.message,
                             "frequency_range": [float(W.min()), float(W.max())] if len(br) else None,
                             "max_abs_unfolding": float(eps),
                             "frequency_extrema": [float(s.data.get("frequency", math.nan)) for s in br.special_points
                                                   if s.kind.value == "user"]})
                if ctx.stop_requested:
                    ctx.interrupted = True
                    break
        finally:
            rec.close()
        ctx.timings["continuation"] = time.perf_counter() - t0
        missing = shortfalls(info, "amplitude")
        part = {
            "observed": problems[0].observe,
            "amplitude": a["amplitude"],
            "harmonics": problems[0].H,
            "samples": problems[0].hb.N,
            "unknowns": problems[0].m + 2,
            "linear_frequencies": [float(w) for w in problems[0].omega_all],
            "static_equilibrium": [float(v) for v in problems[0].x0],
            "dropped_excitations": time_varying_excitations(model),
            "branches": info,
            "rows": rec.n_rows,
            "special_points": len(rec.special_list),
            "shortfalls": missing,
        }
        draw = (lambda: _plot(ctx, rec, problems[0], log)) if ctx.sink.writes else None
        return self.outcome(ctx, part, shortfalls=missing, draw=draw)


def _plot(ctx, rec, prob, log):
    out = ctx.scene.output
    symbols = {**model_symbols(ctx.model), "frequency": r"\omega"}
    measure = f"{'rms' if ctx.scene.analysis['amplitude'] == 'rms' else 'amp'}_{prob.observe}"
    labels = {"frequency": r"frequency $\omega$", "amplitude": quantity(measure, symbols), **(out["labels"] or {})}

    def evaluate(lam, V):
        return V[:, prob.m], np.array([prob.amplitude_target(v)[0] for v in lam])

    curves, special = [], []
    for bid, c in rec.curves.items():
        points = [{"x": s["frequency"], "y": s["amplitude"], "index": s["index"] - c["offset"], "changes": False}
                  for s in rec.special_list if s["branch"] == bid and s["kind"] in SPECIAL]
        special += [{"x": s["frequency"], "y": s["amplitude"], "kind": s["kind"], "branch": bid}
                    for s in rec.special_list if s["branch"] == bid]
        directions = np.array(c["direction"]) if all(d is not None for d in c["direction"]) else None
        d = dense_branch(np.array(c["lam"]), np.array(c["v"]), evaluate, directions=directions, scale=c.get("scale"),
                         special=points, node_xy=(np.array(c["x"]), np.array(c["y"])), log_y=log)
        curves.append({"x": d["x"], "y": d["y"], "stable": None, "id": bid, "label": f"mode {c['mode']}"})

    def natural_frequencies(ax):
        colors = matplotlib.rcParams["axes.prop_cycle"].by_key().get("color", ["C0"])
        for k, c in enumerate(rec.curves.values()):
            ax.axvline(c["omega0"], color=colors[k % len(colors)], ls=":", lw=0.8)
        ax.plot([], [], ls=":", lw=0.8, color="0.4", label="linear natural frequency")

    return bifurcation_diagram(curves, special, "frequency", "amplitude", ctx.sink.path("backbone"), units=out["units"],
                               labels=labels, symbols=symbols, title=out["title"], extra=natural_frequencies,
                               formats=out["formats"], dpi=out["dpi"], style=out["style"], log_y=log)
