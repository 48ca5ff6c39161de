"""``modes``: natural frequencies and mode shapes about the static equilibrium, optionally versus a parameter.

For any model: the static equilibrium ``K x + f_nl(x, 0) = f_0`` (the period
mean of the excitation) is found by Newton from rest or ``guess``
(:mod:`contin.modal.equilibrium`), then the small motions about it,
``M y'' + C_t y' + K_t y = 0`` with the tangent stiffness ``K_t`` and tangent
damping ``C_t``, are analysed by :mod:`contin.modal.modes` (seed 002, sec. 2-3):

- undamped natural frequencies ``w_i`` and mass-normalised modes (``eigh(K_t, M)``),
  with the mode-shape ratios ``r_i = u_j / u_ref`` (seed 002: ``r_i = u_2/u_1``);
- the principal-coordinate damping ``Phi^T C_t Phi`` (its diagonal as modal
  damping ratios; whether it is diagonal);
- the ``2n`` damped eigenvalues ``lambda_i`` of ``det(lambda^2 M + lambda C_t + K_t) = 0``
  and their modes ``B_i`` scaled to ``B_ref = 1``.

With ``parameter`` and ``values`` (or ``range`` and ``points``) the
equilibrium is continued from value to value (a failed step is subdivided).

Result files: ``modes.csv`` (one row per value and mode: ``omega2``,
``omega``, ``frequency_hz``, ``divergent``, ``modal_damping_ratio``,
``shape_<dof>``, ``ratio_<dof>``, ``static_<dof>``), ``damped_modes.csv`` (one
row per value and eigenvalue: ``re``, ``im``, ``natural_frequency``,
``damped_frequency``, ``damping_ratio``, ``re_<dof>``, ``im_<dof>``); figures
``mode_shapes.<format>`` and, for several values, ``natural_frequencies.<format>``
(:func:`draw_mode_shapes`, :func:`draw_natural_frequencies` draw them into any axes).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from contin.analyses.base import Analysis, RunError
from contin.modal.equilibrium import EquilibriumFailed, static_problem
from contin.modal.modes import check_mass, damped_modes, natural_modes, principal_coordinates
from contin.modal.static_path import equilibrium_path
from contin.output.figures import figure_style, legend_below, new_figure, save_figure
from contin.output.labels import axis_label, math, symbol
from contin.scene.budget import modes_demands
from contin.scene.parse import check_parameter_values
from contin.scene.registry import check_output
from contin.scene.schema import Key, SceneError, flag, int_range, is_number
from contin.util.naming import suggest

__all__ = ["MODES", "Modes", "ModesPlan", "draw_mode_shapes", "draw_natural_frequencies"]


def _numbers(v) -> bool:
    return isinstance(v, list) and len(v) > 0 and all(is_number(x) for x in v)


#: scene schema of ``analysis`` for ``type: modes``
MODES = {
    "type": Key("a string", lambda v: isinstance(v, str) and v != "", None, True),
    "parameter": Key("a string", lambda v: isinstance(v, str) and v != ""),
    "values": Key("a non-empty list of finite numbers", _numbers),
    "range": Key("a list of two different numbers [start, end]",
                 lambda v: isinstance(v, list) and len(v) == 2 and all(is_number(x) for x in v) and v[0] != v[1]),
    "points": int_range(21, 2, 100000),
    "reference": Key("a dof name (mode-shape ratios refer to it)", lambda v: isinstance(v, str) and v != ""),
    "guess": Key("a list of numbers (one static displacement per dof) or null",
                 lambda v: v is None or _numbers(v), None),
    "tolerance": Key("a positive number below 1 (relative Newton tolerance)",
                     lambda v: is_number(v) and 0 < v < 1, 1e-10),
    "max_iterations": int_range(30, 1, 1000),
    "damped": flag(True),
    "plot_modes": int_range(6, 1, 100),
}


def _values(scene, model):
    a = scene.analysis
    param = a["parameter"]
    if a["values"] is not None and a["range"] is not None:
        raise scene.error("analysis.values", "either values or range (with points), not both", a["values"])
    if param is None:
        for k in ("values", "range"):
            if a[k] is not None:
                raise scene.error("analysis.parameter", f"the parameter that analysis.{k} varies", None)
        return None, [None]
    if param not in model.parameters:
        raise scene.error("analysis.parameter", f"a parameter of the model {list(model.parameters)}", param)
    if a["values"] is not None:
        return param, [float(v) for v in a["values"]]
    if a["range"] is not None:
        return param, [float(v) for v in np.linspace(a["range"][0], a["range"][1], a["points"])]
    return param, [float(model.parameters[param])]


def _columns(param, dofs):
    head = ["index"] + ([param] if param else [])
    modes = head + ["mode", "omega2", "omega", "frequency_hz", "divergent", "modal_damping_ratio"]
    modes += [f"shape_{d}" for d in dofs] + [f"ratio_{d}" for d in dofs] + [f"static_{d}" for d in dofs]
    damped = head + ["root", "re", "im", "natural_frequency", "damped_frequency", "damping_ratio"]
    damped += [f"re_{d}" for d in dofs] + [f"im_{d}" for d in dofs]
    return modes, damped


def _finite(v):
    """A CSV value: None for undefined ratios (a node at the reference dof)."""
    return float(v) if np.isfinite(v) else None


@dataclass(frozen=True)
class ModesPlan:
    """The checked choices of a ``modes`` scene.

    Attributes
    ----------
    parameter : str or None
        The varied parameter (None: the model's parameters only).
    values : tuple of float
        Its values (``(None,)`` without a parameter).
    reference : str
        The dof the mode-shape ratios refer to.
    reference_index : int
        Its index.
    problem : HarmonicBalance
        The static problem (``H = 0``) whose equilibria the modes are about.
    """

    parameter: str | None
    values: tuple
    reference: str
    reference_index: int
    problem: object


class Modes(Analysis):
    """``modes``: natural frequencies and mode shapes about the static equilibrium (module docstring)."""

    name = "modes"
    summary = "Natural frequencies and mode shapes about the static equilibrium."
    required = "none required"
    schema = MODES

    def validate(self, data, model, analysis, lines) -> None:
        """Refuse parameter values that make no physical sense (a negative frequency, mass, ...)."""
        check_parameter_values(model, analysis, analysis["parameter"],
                               [(f"analysis.{k}", analysis[k]) for k in ("values", "range")
                                if analysis[k] is not None], lines)

    def demands(self, scene, model) -> list:
        return modes_demands(scene, model)

    def plan(self, scene, model) -> ModesPlan:
        """Every check of a ``modes`` scene with its model.

        The mass matrix must be symmetric positive definite at every value of
        the parameter (it may depend on it).
        """
        a = scene.analysis
        dofs = list(model.dof_names)
        param, values = _values(scene, model)
        ref_name = a["reference"] or dofs[0]
        if ref_name not in dofs:
            raise scene.error("analysis.reference", f"one of the dofs {dofs}", ref_name, hint=suggest(ref_name, dofs))
        if a["guess"] is not None and len(a["guess"]) != len(dofs):
            raise scene.error("analysis.guess", f"{len(dofs)} numbers (one per dof {dofs})",
                              f"{len(a['guess'])} numbers")
        try:
            hb = static_problem(model, param)
        except ValueError as exc:
            raise SceneError("model", "a model with a static equilibrium for analysis.type modes", None,
                             hint=f": {exc}") from None
        for v in values:
            p = model.parameter_vector({param: v} if param else None)
            try:
                check_mass(model.mass.value(p))
            except ValueError as exc:
                where = f" at {param} = {v:g}" if param else ""
                raise SceneError("model.mass", f"a symmetric positive definite mass matrix{where} for analysis.type "
                                 "modes", None, hint=f": {exc}") from None
        mcols, dcols = _columns(param, dofs)
        check_output(scene, mcols[1:] + (dcols[1:] if a["damped"] else []))
        return ModesPlan(parameter=param, values=tuple(values), reference=ref_name,
                         reference_index=dofs.index(ref_name), problem=hb)

    def describe(self, plan: ModesPlan, scene, model) -> list[str]:
        a = scene.analysis
        what = f"versus {a['parameter']}" if a["parameter"] else "at the model's parameters"
        return [f"  natural frequencies and modes about the static equilibrium {what}"
                + ("; damped eigenvalues" if a["damped"] else "")]

    def run(self, plan: ModesPlan, ctx):
        """The equilibrium at each value and the modes about it; tables and summary."""
        scene, model = ctx.scene, ctx.model
        a = scene.analysis
        dofs = list(model.dof_names)
        param, values, ref_name, ref, hb = (plan.parameter, list(plan.values), plan.reference, plan.reference_index,
                                            plan.problem)
        mcols, dcols = _columns(param, dofs)
        out_m = ctx.sink.table("modes.csv", mcols)
        out_d = ctx.sink.table("damped_modes.csv", dcols) if a["damped"] else None
        records = []
        t0 = time.perf_counter()
        lam_values = values if param else [float(hb.p0[hb.k])]  # without a parameter: the model's own values
        try:
            path = equilibrium_path(hb, lam_values, a["guess"], a["tolerance"], a["max_iterations"])
            for i, eq in enumerate(path):
                if ctx.stop_requested:
                    ctx.interrupted = True
                    break
                ctx.progress.update(f"modes: {param}={eq.value:.6g} ({i + 1}/{len(values)})" if param
                                    else "modes", done=i, total=len(values) if param else None)
                try:
                    nm = natural_modes(eq.M, eq.K, ref)
                    pc = principal_coordinates(eq.M, eq.C, eq.K, nm)
                    dm = damped_modes(eq.M, eq.C, eq.K, ref) if a["damped"] else None
                except (ValueError, np.linalg.LinAlgError) as exc:  # the mass matrix was checked: numerics
                    raise RunError(f"modal analysis at {param} = {eq.value:g}: {exc}" if param
                                   else f"modal analysis: {exc}") from None
                head = {"index": i}
                if param:
                    head[param] = eq.value
                ratios = nm.ratios()
                zeta = pc.modal_damping_ratio
                for j in range(nm.n):
                    row = dict(head, mode=j + 1, omega2=float(nm.omega2[j]),
                               omega=None if nm.divergent[j] else float(nm.omega[j]),
                               frequency_hz=None if nm.divergent[j] else float(nm.omega[j] / (2 * np.pi)),
                               divergent=bool(nm.divergent[j]), modal_damping_ratio=float(zeta[j]))
                    for k, d in enumerate(dofs):
                        row[f"shape_{d}"] = float(nm.modes[k, j])
                        row[f"ratio_{d}"] = _finite(ratios[k, j])
                        row[f"static_{d}"] = float(eq.x[k])
                    out_m.write(row)
                if dm is not None:
                    for j, lam in enumerate(dm.eigenvalues):
                        row = dict(head, root=j + 1, re=float(lam.real), im=float(lam.imag),
                                   natural_frequency=float(dm.natural_frequency[j]),
                                   damped_frequency=float(dm.damped_frequency[j]),
                                   damping_ratio=float(dm.damping_ratio[j]))
                        for k, d in enumerate(dofs):
                            row[f"re_{d}"] = float(dm.vectors[k, j].real)
                            row[f"im_{d}"] = float(dm.vectors[k, j].imag)
                        out_d.write(row)
                records.append({
                    "value": eq.value if param else None,
                    "equilibrium": eq.x.tolist(),
                    "newton_iterations": eq.iterations,
                    "omega": [None if nm.divergent[j] else float(nm.omega[j]) for j in range(nm.n)],
                    "omega2": nm.omega2.tolist(),
                    "symmetric_stiffness": nm.symmetric,
                    "proportional_damping": pc.proportional,
                    "modal_damping": pc.modal_damping.tolist() if nm.n <= 20 else None,
                    "eigenvalues": None if dm is None else [[float(z.real), float(z.imag)] for z in dm.eigenvalues],
                    "stable": None if dm is None else dm.stable,
                    "_plot": (nm, dm),
                })
        except EquilibriumFailed as exc:
            if not records:
                raise RunError(str(exc)) from None
            ctx.interrupted = True
            failure = str(exc)
        else:
            failure = None
        finally:
            out_m.close()
            if out_d is not None:
                out_d.close()
        ctx.timings["modes"] = time.perf_counter() - t0
        first = records[0]
        part = {
            "parameter": param,
            "values": [r["value"] for r in records] if param else None,
            "completed": len(records),
            "reference": ref_name,
            "failure": failure,
            "dofs": dofs,
            "results": [{k: v for k, v in r.items() if not k.startswith("_")} for r in records],
            "natural_frequencies": first["omega"],
        }
        draw = (lambda: _plot(ctx, param, dofs, records)) if ctx.sink.writes else None
        return self.outcome(ctx, part, draw=draw)


def draw_mode_shapes(ax, nm, dofs, count: int, symbols=None) -> None:
    """Draw the first ``count`` mass-normalised mode shapes of ``nm`` (NaturalModes) against the dofs.

    Parameters
    ----------
    ax : matplotlib Axes
    nm : contin.modal.modes.NaturalModes
    dofs : list of str
        Tick labels (as symbols).
    count : int
    symbols : dict, optional
        The model's symbols.
    """
    pos = np.arange(len(dofs))
    ratios = nm.ratios()
    for j in range(min(count, nm.n)):
        text = "divergent" if nm.divergent[j] else rf"$\omega_{{{j + 1}}}$ = {nm.omega[j]:.5g}"
        if len(dofs) == 2 and np.isfinite(ratios[1, j]):  # seed 002's r_i = u2/u1
            text += rf", ${symbol(dofs[1], symbols)}/{symbol(dofs[0], symbols)}$ = {ratios[1, j]:.4g}"
        ax.plot(pos, nm.modes[:, j], "o-", lw=1.4, label=f"mode {j + 1}: {text}")
    ax.axhline(0, color="0.5", lw=0.7)
    ax.set_xticks(pos, [math(d, symbols) for d in dofs], rotation=0 if len(dofs) <= 12 else 90)
    ax.set_xlabel("degree of freedom")
    ax.set_ylabel("mass-normalised mode shape")


def draw_natural_frequencies(ax, param: str, records, *, units=None, labels=None, symbols=None) -> None:
    """Draw the undamped natural frequencies (and ``|Im lambda|`` of the damped roots) against ``param``.

    Parameters
    ----------
    ax : matplotlib Axes
    param : str
    records : list of dict
        ``value``, ``omega`` (list, None where divergent) and ``eigenvalues``
        (list of [re, im] or None) per parameter value.
    units, labels, symbols : dict, optional
    """
    v = np.array([r["value"] for r in records])
    W = np.array([[np.nan if w is None else w for w in r["omega"]] for r in records])
    for j in range(W.shape[1]):
        ax.plot(v, W[:, j], "-", lw=1.5, label=rf"$\omega_{{{j + 1}}}$ (undamped)" if j < 8 else None)
    if records[0]["eigenvalues"] is not None:
        D = [np.array(r["eigenvalues"]) for r in records]
        xs = np.concatenate([np.full(len(d), val) for d, val in zip(D, v)])
        ys = np.concatenate([np.abs(d[:, 1]) for d in D])
        sel = ys > 0
        if np.any(sel):
            ax.plot(xs[sel], ys[sel], ".", color="k", ms=3, label=r"$|\mathrm{Im}\,\lambda|$ of the damped roots")
    ax.set_xlabel(axis_label(param, units, labels, symbols))
    ax.set_ylabel(axis_label("omega", units, {"omega": r"natural angular frequency $\omega$", **(labels or {})},
                             symbols))


def _plot(ctx, param, dofs, records) -> list:
    out = ctx.scene.output
    sym = getattr(ctx.model, "symbols", None)
    title = out["title"] or ctx.model.name
    nm, _ = records[0]["_plot"]
    count = min(ctx.scene.analysis["plot_modes"], nm.n)
    files = []
    with figure_style(out["style"]):
        fig = new_figure((7.0, 4.8 + 0.18 * ((count + 1) // 2)))
        ax = fig.add_subplot()
        draw_mode_shapes(ax, nm, dofs, count, sym)
        where = f" at {math(param, sym)} = {records[0]['value']:.6g}" if param else ""
        ax.set_title(f"{title}: mode shapes{where}")
        legend_below(fig, ax, ncols=2 if count > 2 else 1)
        files += save_figure(fig, ctx.sink.path("mode_shapes"), out["formats"], out["dpi"])
        if param and len(records) > 1:
            fig = new_figure((7.0, 5.2))
            ax = fig.add_subplot()
            draw_natural_frequencies(ax, param, records, units=out["units"], labels=out["labels"], symbols=sym)
            ax.set_title(out["title"] or f"{title}: natural frequencies against {math(param, sym)}")
            legend_below(fig, ax, ncols=min(len(ax.get_legend_handles_labels()[0]), 3) or 1)
            files += save_figure(fig, ctx.sink.path("natural_frequencies"), out["formats"], out["dpi"])
    return files
