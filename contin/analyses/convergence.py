"""``convergence``: what accuracy costs, error of quantities of interest against wall time.

A convergence scene embeds an ordinary analysis section (``base``: a
``frequency_response``, ``static``, ``backbone`` or ``simulate`` analysis) and
runs it once per *setting*: a combination of values of accuracy settings
given under ``vary`` by their dotted path in the scene, for example

.. code-block:: yaml

    analysis:
      type: convergence
      base: {type: frequency_response, parameter: w, range: [0.5, 3], harmonics: 9}
      vary:
        analysis.harmonics: [1, 3, 5, 7, 9, 11]     # keys of the base section
        model.parameters.terms: [3, 5]              # parameters (and options) of the model
      combine: product                              # or zip (lists of equal length, taken in step)
      reference: {analysis.harmonics: 25}           # optional: the finest setting
      quantities:
        - {type: fold, index: 0}
        - {type: peak, measure: amp_x}
      budget: 1.0e-6                                # optional: recommend the cheapest setting

Setting paths start with ``analysis.`` (a key of the base section, nested
mappings allowed, e.g. ``analysis.continuation.newton_tol``,
``analysis.stability_options.steps_per_period``; not ``analysis.starts``: the
start to study goes in the base section itself) or ``model.`` (built-in
models: ``model.parameters.NAME``, ``model.options.NAME``; custom models any
key, e.g. ``model.parameters.NAME``). With ``combine: product`` (the default)
every combination of the lists is run, the last key varying fastest; with
``zip`` the lists are taken in step. The reference is the last setting unless
``reference`` names one (values of the ``vary`` paths; paths it leaves out
take their last value); a reference outside the lists is run as well.

Each setting is an ordinary run of the base analysis into
``runs/NN_<label>/`` (plots off); a study held in memory (the Python API)
holds its runs in memory too, and its quantities are read from the runs'
tables (:attr:`contin.output.outcome.Outcome.tables`) either way. Its wall time is measured around the whole
run (model build, start, continuation, stability, result files) with
``time.perf_counter``, after one untimed warm-up run of the first setting so
that numba compilation and cache loading are not counted (``warmup: false``
switches it off); with ``repeat: k`` the smallest of ``k`` timings is kept.
The CPU time of the same run (``time.process_time``) is recorded too; ``cost:
cpu_time`` makes it the cost axis of the plot and of the budget (on a machine
shared with other jobs it varies less than the wall time).

Quantities of interest (``quantities``, a list of mappings with a ``type``
or of type names):

``peak``
    The largest value of a column (``measure``, default ``output.measure``,
    else ``amp_`` of the first dof) over the rows of the selected branches
    (``branch``, ``nu``), refined by the vertex of the parabola through the
    largest stored row and its two neighbours along the branch (``refine``).
``fold`` and ``special``
    The parameter (or the column ``of``) of a located fold (for ``special``:
    of the ``kind`` fold, pd, ns or bp) in ``special_points.csv``: the
    ``index``-th in branch order (default 0), or the one nearest ``near``
    (within ``window`` if given).
``stable_interval``
    Hull ``[from, to]`` of the parameter intervals where a stable solution of
    order ``nu`` exists (:func:`contin.analyses.intervals.stable_intervals`: each end at
    the located change of stability), counting only rows whose ``measure``
    exceeds ``min`` if given (the rotor's harmonic solution seen as
    ``nu = 2`` has no ``+w/2`` whirl); ``ends`` chooses among ``from``,
    ``to``, ``length``.
``value`` and ``static_deflection``
    A column (``measure``; for a static base its ``measure``) at the
    parameter value ``at`` on a branch (default 0): the first crossing of
    ``at`` along the branch, linearly interpolated between stored rows
    (exact where ``at`` is the start of the branch or an end of ``range``,
    where a branch ends exactly). For a ``simulate`` base the table is
    ``simulation.csv`` and ``at`` one of its ``values``.

The error of each quantity is ``|q - q_ref|``, divided by ``|q_ref|`` for
``error: relative`` (the default; per quantity too). A quantity a run does not
produce (no fold, no stable interval, a failed run) is *missing*: its cells
are empty and the ``missing`` column says why.

Settings are labelled by the last part of their paths (``harmonics`` as
``H``, ``samples`` as ``N``, ``terms`` as ``n``, ``steps_per_period`` as
``steps``), or by the names given under ``labels`` (path -> name).

Result files: ``convergence.csv`` (one row per setting: ``setting`` (label),
the values of the ``vary`` paths, ``group`` (the values of all but the last
path: one line of the plot each), ``reference``, ``status``, ``wall_time``,
``cpu_time``, ``points`` (rows written), each quantity and
``<quantity>_error``, ``max_error`` (the largest error over the quantities;
empty when one is missing), ``missing``, ``run`` (the run's directory; empty in memory) and
``message`` (why a run failed, or why a branch ended before its range)), ``convergence.<format>`` (log-log error
against time, one line per quantity, points labelled by setting) and ``summary.json`` (``analysis.table``, the
printed table; ``analysis.recommendation`` for ``budget`` or ``contin run
--budget ERR``: the cheapest setting whose errors are all at most ``ERR``, the
reference excluded since its own error is not measured; ``contin budget OUTDIR
ERR`` gives the same from a finished run without running it again, and redraws
``convergence.png`` with that budget).

The plan of the study (schema, settings, checks) is
:mod:`contin.analyses.convergence_plan`; the quantities of a run, their errors
and the budget are :mod:`contin.analyses.convergence_errors`.
"""

from __future__ import annotations

import json
import math
import re
import time
from pathlib import Path

import matplotlib.ticker

from contin.analyses.base import Analysis, RunContext, RunError
from contin.analyses.convergence_errors import extract, format_table, quantity_error, read_records, recommend
from contin.analyses.convergence_plan import (BASE_TABLES, CONVERGENCE, ConvergencePlan, plan as convergence_plan,
                                              setting_label, slug, validate)
from contin.output.figures import figure_style, legend_below, new_figure, save_figure
from contin.output.labels import math as math_text, quantity
from contin.output.plotting import laid_out_renderer
from contin.output.outcome import Outcome
from contin.scene.schema import SceneError

__all__ = ["Convergence", "draw_convergence", "plot_convergence", "replot"]

#: branch statuses that end a branch before its range (their messages explain a missing quantity)
EARLY_ENDS = ("step_too_small", "start_failed", "newton_failed", "ill_conditioned")


class Convergence(Analysis):
    """Another analysis at several settings of its accuracy: error against cost (this module's docstring)."""

    name = "convergence"
    summary = "Another analysis over a range of harmonics, samples or terms: error against cost."
    required = "base, vary, quantities"
    schema = CONVERGENCE

    def validate(self, data: dict, model: dict, analysis: dict, lines: dict) -> None:
        """``analysis.base``, the setting paths, the quantities and every setting's scene."""
        validate(data, model, analysis, lines)

    def plan(self, scene, model) -> ConvergencePlan:
        """Every setting's scene built and checked, the quantities' columns among those the runs write."""
        return convergence_plan(scene, model)

    def describe(self, plan: ConvergencePlan, scene, model) -> list[str]:
        """The base analysis, its settings and the quantities."""
        a = scene.analysis
        return [f"  the {a['base']['type']} analysis of analysis.base run at {len(plan.settings)} settings of "
                f"{', '.join(a['vary'])} ({a['combine']}); reference {plan.labels[plan.iref]}",
                "  settings: " + "; ".join(plan.labels),
                "  quantities: " + ", ".join(q if isinstance(q, str) else q["type"] for q in a["quantities"])]

    def run(self, plan: ConvergencePlan, ctx: RunContext) -> Outcome:
        """One run of the base analysis per setting (each in ``runs/NN_<label>`` when the run has a directory)."""
        return _run(self, plan, ctx)


def _run(analysis: Convergence, plan: ConvergencePlan, ctx: RunContext) -> Outcome:
    scene = ctx.scene
    a = scene.analysis
    btype = a["base"]["type"]
    table_file = BASE_TABLES[btype]
    quantities, settings, iref, labels = list(plan.quantities), plan.settings, plan.iref, plan.labels
    scenes, defaults, items, kinds = plan.scenes, plan.defaults, list(plan.items), plan.kinds
    columns = plan.columns
    # with a result directory each run keeps its files in runs/; held in memory, so are the runs
    runs_dir = None if ctx.outdir is None else ctx.outdir / "runs"
    if runs_dir is not None:
        runs_dir.mkdir(exist_ok=True)
    t_all = time.perf_counter()
    if a["warmup"]:
        ctx.progress.update(f"warm-up run ({labels[0]}), not timed", task="warm-up")
        try:
            ctx.run_scene(scenes[0], None if runs_dir is None else runs_dir / "warmup", progress=False)
        except RunError:
            pass  # the timed run reports it
        except SceneError as exc:  # plan() ran every check of this setting: a guard, not a path
            raise SceneError("analysis.vary", "settings the base analysis accepts", labels[0],
                             hint=f"; with them: {exc}") from None
        ctx.timings["warmup"] = time.perf_counter() - t_all

    first_complete = [True]

    def check_columns(tables):
        """A column no run writes (plan() refuses those before the run; a guard at the first complete run)."""
        if not first_complete[0]:
            return
        first_complete[0] = False
        try:
            extract(tables, quantities, defaults, table_file, strict=True)
        except KeyError as exc:
            if not re.search(r"'h\d+_", exc.args[0]):
                raise SceneError("analysis.quantities", "columns the base analysis writes", None,
                                 hint=f": {exc.args[0]}") from None

    records = []
    for i, (s, label, sc) in enumerate(zip(settings, labels, scenes)):
        run_dir = None if runs_dir is None else runs_dir / f"{i:02d}_{slug(label)}"
        ctx.progress.update(f"setting {i + 1}/{len(settings)}: {label}", done=i, total=len(settings),
                            task="settings")
        status, message, wall, cpu, points, tables = "complete", "", None, None, None, {}
        for _ in range(a["repeat"]):
            t0, c0 = time.perf_counter(), time.process_time()
            try:
                outcome = ctx.run_scene(sc, run_dir, progress=False)
            except RunError as exc:
                status, message = "failed", " ".join(str(exc).split())
                wall, cpu = time.perf_counter() - t0, time.process_time() - c0  # the time spent until it failed
                break
            except SceneError as exc:  # a value the model refuses at run time (bad input, not a missing value)
                raise SceneError("analysis.vary", "settings the base analysis accepts", label,
                                 hint=f"; with them: {exc}") from None
            dt, dc = time.perf_counter() - t0, time.process_time() - c0
            if wall is None or dt < wall:
                wall, cpu = dt, dc
            summary, tables = outcome.summary, outcome.tables
            status = summary["status"]
            points = (summary.get("analysis") or {}).get("rows")
            # branches that ended early say why (a start that did not converge, a step that collapsed, ...)
            message = "; ".join(f"branch {b.get('branch')}: {b.get('message')}"
                                for b in (summary.get("analysis") or {}).get("branches", [])
                                if b.get("status") in EARLY_ENDS and b.get("message"))
            if status == "interrupted":
                message = "interrupted"
                break
            if status == "incomplete":  # what it computed still counts; the branches that gave up say why
                message = message or summary.get("message", "")
        group = setting_label({k: s[k] for k in list(s)[:-1]}, a["labels"])  # the lines of the plot
        rec = {"setting": label, **s, "group": group, "reference": i == iref, "status": status, "wall_time": wall,
               "cpu_time": cpu, "points": points,
               "run": None if run_dir is None else str(run_dir.relative_to(ctx.outdir)), "message": message}
        if status in ("complete", "incomplete"):
            check_columns(tables)
            vals, miss = extract(tables, quantities, defaults, table_file)
            if message:
                miss = {c: f"{why} ({message})" for c, why in miss.items()}
        else:
            vals, miss = {}, {c: f"run {status}" + (f" ({message})" if message and message != "interrupted" else "")
                              for c in columns}
        rec.update(vals)
        rec["_missing"] = miss
        records.append(rec)
        if status == "interrupted" or ctx.stop_requested:
            ctx.interrupted = True
            break
    ctx.timings["runs"] = time.perf_counter() - t_all
    ref = records[iref] if iref < len(records) else None
    for r in records:
        miss = dict(r.pop("_missing"))
        for c in columns:
            rv = None if ref is None else ref.get(c)
            e = quantity_error(r.get(c), rv, kinds[c])
            r[f"{c}_error"] = e
            if r.get(c) is not None and rv is None and c not in miss:
                miss[c] = "reference has none" if ref is not None else "reference not run"
        errs = [r[f"{c}_error"] for c in columns]
        r["max_error"] = None if any(e is None for e in errs) else max(errs)
        if len(miss) == len(columns) and len(set(miss.values())) == 1:
            r["missing"] = "every quantity: " + next(iter(miss.values()))
        else:
            r["missing"] = "; ".join(f"{c}: {why}" for c, why in miss.items())
    vary_cols = list(a["vary"])
    header = ["setting"] + vary_cols + ["group", "reference", "status", "wall_time", "cpu_time", "points"]
    for c in columns:
        header += [c, f"{c}_error"]
    header += ["max_error", "missing", "run", "message"]
    csv = ctx.sink.table("convergence.csv", header)
    for r in records:
        csv.write({k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in r.items()})
    csv.close()
    budget = a["budget"]
    recommendation = recommend(records, columns, budget, a["cost"]) if budget is not None else None
    ref_label = labels[iref]
    table = [f"convergence of the {btype} analysis; reference {ref_label}; wall time of each run after one "
             f"untimed warm-up run (numba compilation excluded)" if a["warmup"] else
             f"convergence of the {btype} analysis; reference {ref_label}; wall time of each run (no warm-up)"]
    table += [f"  {c}: {d}" for c, d in items]
    table += format_table(records, items, kinds)
    if recommendation:
        table.append(recommendation["message"])
    # the errors are measured against the reference: a reference that fell short is a shortfall of the
    # study; a coarse setting that fell short is one of its findings (its row says why)
    short = [f"the reference setting {ref_label} ended {ref['status']}: {ref.get('message') or ''}".rstrip(": ")] \
        if ref is not None and ref["status"] not in ("complete", "interrupted") else []
    part = {
        "base": btype,
        "vary": vary_cols,
        "combine": a["combine"],
        "reference": ref_label,
        "quantities": [{"column": c, "description": d, "error": kinds[c]} for c, d in items],
        "timing": "wall time of each whole run (time.perf_counter), after one untimed warm-up run of the first "
                  "setting so that numba compilation is not counted" if a["warmup"] else
                  "wall time of each whole run (time.perf_counter), no warm-up",
        "settings": [{k: v for k, v in r.items()} for r in records],
        "table": table,
        "recommendation": recommendation,
        "columns": columns,
        "cost": a["cost"],
        "shortfalls": short,
    }
    return analysis.outcome(ctx, part, shortfalls=short,
                            draw=lambda: _plot(ctx, records, items, kinds, budget, btype, ref_label, a["cost"]))


def _describe(text: str, names=(), symbols=None) -> str:
    """A quantity's description with its parameter, dof and measure names as symbols and words."""
    out = []
    for word in text.split(" "):
        core = word.rstrip(",;:)")
        tail = word[len(core):]
        if core in names:
            core = math_text(core, symbols)
        elif re.fullmatch(r"(amp|max|min|rms|mean|h\d+)_\w+|max_multiplier", core):
            core = quantity(core, symbols)
        out.append(core + tail)
    return " ".join(out)


def draw_convergence(ax, records: list[dict], items: list[tuple[str, str]], kinds: dict, budget: float | None,
                     cost: str = "wall_time", names=(), symbols=None) -> None:
    """Draw the error of each quantity against the cost of each setting (log-log) into ``ax``.

    Parameters
    ----------
    ax : matplotlib Axes
    records : list of dict
        ``setting``, ``group`` (the values of the settings but the last: one
        line each), ``reference``, ``wall_time``, ``cpu_time`` and
        ``<column>_error`` per setting (reference and zero errors are left out).
    items : list of (str, str)
        Quantity columns and descriptions (the legend shows the descriptions).
    kinds : dict
        Column -> ``relative`` or ``absolute``.
    budget : float or None
        Drawn as a horizontal line.
    cost : str
        ``wall_time`` or ``cpu_time``: the horizontal axis.
    names : collection of str
        Parameter and dof names, written as symbols in the descriptions.
    symbols : dict, optional
    """
    markers = "osD^v<>ph*"
    labelled: set = set()
    notes: list = []  # (text, time, error) of each setting's label, placed once the axes are final
    groups = list(dict.fromkeys(r.get("group", "") for r in records))
    styles = ["-", "--", ":", "-."]
    for k, (c, d) in enumerate(items):
        for g, group in enumerate(groups):
            pts = [(r[cost], r[f"{c}_error"], r["setting"]) for r in records
                   if r.get("group", "") == group and not r["reference"] and r.get(cost) is not None
                   and r.get(f"{c}_error") not in (None, 0.0) and math.isfinite(r[f"{c}_error"])]
            if not pts:
                continue
            t, e, lab = zip(*pts)
            name = f"{_describe(d, names, symbols)} ({kinds[c]} error)" + (f", {group}" if group else "")
            ax.loglog(t, e, marker=markers[(k + g) % len(markers)], ls=styles[g % len(styles)], label=name)
            for ti, ei, li in zip(t, e, lab):
                if li not in labelled:  # the quantities of a setting share its time: one label per setting
                    labelled.add(li)
                    short = li[len(group) + 2:] if group and li.startswith(group + ", ") else li
                    notes.append((short, ti, ei))
    if budget is not None:
        ax.axhline(budget, color="0.5", ls=":", lw=1, label=f"error budget {budget:g}")
    ax.set_xlabel(("wall" if cost == "wall_time" else "CPU") + " time per run [s]")
    lo, hi = ax.get_xlim()
    if hi < 10 * lo:  # less than a decade: plain numbers on the time axis
        ax.xaxis.set_major_formatter(matplotlib.ticker.FormatStrFormatter("%g"))
        ax.xaxis.set_minor_formatter(matplotlib.ticker.FormatStrFormatter("%g"))
        ax.tick_params(axis="x", which="minor", labelsize=7)
    ax.set_ylabel("error against the reference setting")
    ax.grid(True, which="both", alpha=0.3)
    _place_labels(ax, notes)


#: where a setting's label may sit beside its point (offset points, horizontal alignment), in order
_LABEL_SPOTS = (((4, 3), "left"), ((4, -10), "left"), ((-4, 3), "right"), ((-4, -10), "right"))


def _place_labels(ax, notes) -> None:
    """Each setting's label at the first spot beside its point where it overlaps no label placed before; a label
    with no free spot is left out (its point keeps its marker, the legend and the table name it)."""
    renderer = laid_out_renderer(ax.figure)
    placed = []
    for text, t, e in notes:
        for offset, ha in _LABEL_SPOTS:
            ann = ax.annotate(text, (t, e), textcoords="offset points", xytext=offset, fontsize=7, ha=ha)
            box = ann.get_window_extent(renderer)
            if not any(box.overlaps(p) for p in placed):
                placed.append(box)
                break
            ann.remove()


def plot_convergence(path: Path, records: list[dict], items: list[tuple[str, str]], kinds: dict,
                     budget: float | None, cost: str, title: str, *, formats=("png",), dpi: float | None = None,
                     style: str | None = "contin", names=(), symbols=None) -> list[str]:
    """Draw :func:`draw_convergence` into a new figure, its legend below the axes, and save it.

    Parameters
    ----------
    path : Path
        The file name; its suffix is replaced by each of ``formats``.
    title : str
    formats, dpi, style
        ``output.formats``, ``output.dpi``, ``output.style``.

    The other parameters are those of :func:`draw_convergence`.

    Returns
    -------
    list of str
        The file names written.
    """
    with figure_style(style):
        fig = new_figure((7.5, 5.8))
        ax = fig.add_subplot()
        draw_convergence(ax, records, items, kinds, budget, cost, names, symbols)
        ax.set_title(title)
        legend_below(fig, ax)
        return save_figure(fig, path, formats, dpi)


def replot(outdir: Path, budget: float | None = None) -> Path:
    """Draw ``convergence.<format>`` of a finished convergence run again.

    Parameters
    ----------
    outdir : Path
        The run's result directory.
    budget : float, optional
        Drawn as a line; by default the run's own budget, if it had one.

    Returns
    -------
    Path
        The first figure written (one per ``output.formats`` of the run).
    """
    outdir = Path(outdir)
    summary = json.loads((outdir / "summary.json").read_text())
    a = summary["analysis"]
    items = [(q["column"], q["description"]) for q in a["quantities"]]
    kinds = {q["column"]: q["error"] for q in a["quantities"]}
    records = read_records(outdir / "convergence.csv", a["columns"])
    if budget is None and a.get("recommendation"):
        budget = a["recommendation"]["budget"]
    title = (summary["scene"].get("output") or {}).get("title") or \
        f"{summary['model']['name']}: {a['base']} accuracy against cost (reference {a['reference']})"
    out = summary["scene"].get("output") or {}
    files = plot_convergence(outdir / "convergence", records, items, kinds, budget, a.get("cost", "wall_time"), title,
                             formats=out.get("formats") or ("png",), dpi=out.get("dpi"), style=out.get("style"),
                             names=_names(summary))
    return outdir / files[0]


def _names(summary: dict) -> set:
    """Parameter and dof names of a finished run, from its summary (written as symbols on the plot)."""
    scene_model = summary["scene"].get("model") or {}
    base = (summary["scene"].get("analysis") or {}).get("base") or {}
    names = set((summary.get("model") or {}).get("dofs") or ()) | set(scene_model.get("parameters") or ())
    return names | ({base["parameter"]} if isinstance(base.get("parameter"), str) else set())


def _plot(ctx, records, items, kinds, budget, btype, ref_label, cost):
    title = ctx.scene.output["title"] or f"{ctx.model.name}: {btype} accuracy against cost (reference {ref_label})"
    out, model = ctx.scene.output, ctx.model
    return plot_convergence(ctx.sink.path("convergence"), records, items, kinds, budget, cost, title,
                            formats=out["formats"], dpi=out["dpi"], style=out["style"],
                            names=set(model.parameters) | set(model.dof_names), symbols=getattr(model, "symbols", None))
