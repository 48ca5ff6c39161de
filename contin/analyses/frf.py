"""``frf``: the frequency response of a linear model from its impedance matrix.

For ``M x'' + C x' + K x = Re(F e^{i w t})`` the steady response is
``x = Re(X e^{i w t})`` with ``X = Z(w)^-1 F`` and ``Z(w) = K - w^2 M + i w C``
(seed 002, sec. 4.2; :func:`contin.modal.modes.frf`), solved for every grid
frequency at once. The force is

- the model's own excitation (``force`` omitted): its component at the
  forcing frequency, ``F = a_1 - i b_1`` from the Fourier coefficients of
  ``f_ext`` (constant loads only shift the equilibrium of a linear model and
  are left out); it may depend on ``w`` (an unbalance ``e w^2``);
- a unit force on one dof (``force: x2``), on each of several dofs in turn
  (``force: [x1, x2]``, one case each: columns of the receptance matrix), or
  given amplitudes (``force: {x1: 1.0, x2: 0.5}``).

Matrices that depend on the frequency parameter (gyroscopic terms
``w G``) are evaluated at each frequency. Nonlinear forces are refused: the
``frequency_response`` analysis follows those.

Result files: ``frf.csv`` (one row per case and frequency: ``case``, the
frequency, ``amp_<dof>``, ``phase_<dof>`` in degrees (negative: lagging the
force), ``re_<dof>``, ``im_<dof>``), the figure ``frf.<format>`` (amplitude, on a
log scale unless ``scale: linear``, and the unwrapped phase, with the undamped
natural frequencies marked). ``summary.json`` lists
the undamped natural frequencies and, for a damped model, every interior
amplitude maximum, located to machine precision by a bounded scalar search.

``normalise: static`` draws the amplitudes divided by the static deflection
``delta_st``, the largest ``|x|`` of ``K x = F`` under the same force at
``w = 0`` (for an absorber on a main system ``m1, k1`` forced on ``m1``:
``delta_st = F/k1``); the file keeps the amplitudes themselves.

Fixed points (``fixed_points``, on by default): where a force acts on one
dof of a damped model, the frequencies at which that dof's amplitude does
not depend on the damping are located as the crossings of its response
with the damping matrix scaled to zero and to infinity (the dampers locked:
the motion restricted to the null space of ``C``), each refined by a
root search. For Den Hartog's damped absorber these are the points P and Q
(:mod:`contin.modal.absorber`); they are listed in ``summary.json`` and marked
on the figure with both limiting curves.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import matplotlib.ticker
import numpy as np
from scipy.optimize import brentq, minimize_scalar

from contin.analyses.base import Analysis
from contin.hb.factory import harmonic_balance
from contin.hb.problem import HBOptions
from contin.modal.modes import SingularImpedance, frf, natural_modes
from contin.output.figures import figure_style, legend_below, new_figure, save_figure
from contin.output.labels import axis_label, math
from contin.scene.budget import frf_demands
from contin.scene.parse import model_frequency
from contin.scene.registry import check_output
from contin.scene.schema import Key, SceneError, flag, int_range, is_number, string
from contin.util.naming import suggest

__all__ = ["FRF", "Frf", "FrfPlan", "ForceResponse", "force_cases", "result_columns", "fixed_points", "draw_frf"]


def _force_ok(v) -> bool:
    if v is None or (isinstance(v, str) and v != ""):
        return True
    if isinstance(v, list):
        return len(v) > 0 and all(isinstance(x, str) for x in v) and len(set(v)) == len(v)
    if isinstance(v, dict):
        return len(v) > 0 and all(isinstance(k, str) and is_number(x) for k, x in v.items())
    return False


#: scene schema of ``analysis`` for ``type: frf``
FRF = {
    "type": Key("a string", lambda v: isinstance(v, str) and v != "", None, True),
    "range": Key("a list of two numbers [start, end] with 0 <= start < end",
                 lambda v: isinstance(v, list) and len(v) == 2 and all(is_number(x) for x in v)
                 and 0 <= v[0] < v[1], None, True),
    "points": int_range(400, 2, 10**6),
    "spacing": string("linear", ("linear", "log")),
    "frequency": Key("a string", lambda v: isinstance(v, str) and v != ""),
    "force": Key("null (the model's own excitation), a dof name, a list of dof names, "
                 "or a mapping dof: amplitude", _force_ok, None),
    "peaks": flag(True),
    "scale": string("log", ("log", "linear")),
    "normalise": Key("'none' or 'static' (the figure divides the amplitudes by the static deflection delta_st, "
                     "the largest |x| of K x = F)", lambda v: v in ("none", "static"), "none"),
    "fixed_points": Key("true or false (locate and mark the fixed points: the frequencies where the forced dof's "
                        "amplitude does not depend on the damping)", lambda v: isinstance(v, bool), True),
}


def force_cases(spec, dofs):
    """``[(label, F)]`` with ``F`` of shape (n,) for a ``force`` spec; None for the model's own excitation."""
    if spec is None:
        return None
    n = len(dofs)

    def unit(d):
        F = np.zeros(n, dtype=complex)
        F[dofs.index(d)] = 1.0
        return F

    names = [spec] if isinstance(spec, str) else list(spec)
    for d in names:
        if d not in dofs:
            raise SceneError("analysis.force", f"dof names among {dofs}", d, hint=suggest(d, dofs))
    if isinstance(spec, dict):
        F = np.zeros(n, dtype=complex)
        for d, v in spec.items():
            F[dofs.index(d)] = float(v)
        return [("+".join(f"{v:g}*{d}" for d, v in spec.items()), F)]
    return [(d, unit(d)) for d in names]


class ForceResponse:
    """``X(w)`` of one force case, with the matrices and force re-evaluated where they depend on ``w``."""

    def __init__(self, model, kw, p0, F):
        self.model, self.kw, self.p0, self.F = model, kw, p0, F
        mats = (model.mass, model.damping, model.stiffness)
        self.varying = any(t[0].depends_on(kw) for m in mats for t in m.terms)
        self.MCK = None if self.varying else model.linear(p0)

    def matrices(self, w):
        if not self.varying:
            return self.MCK
        Ms, Cs, Ks = [], [], []
        for wi in np.atleast_1d(w):
            p = self.p0.copy()
            p[self.kw] = wi
            M, C, K = self.model.linear(p)
            Ms.append(M), Cs.append(C), Ks.append(K)
        return np.array(Ms), np.array(Cs), np.array(Ks)

    def __call__(self, w):
        w = np.atleast_1d(np.asarray(w, dtype=float))
        F = self.F(w) if callable(self.F) else self.F
        return frf(*self.matrices(w), w, F)


def _own_force(model, wname: str):
    """The model's excitation at the forcing frequency ``wname``, ``F(w) = a_1 - i b_1``, shape (nw, n)."""
    try:
        hb = harmonic_balance(model, wname, HBOptions(harmonics=1), frequency=wname)
    except ValueError as exc:
        raise SceneError("analysis.force", "a force at the forcing frequency: the model's excitation has other "
                         "harmonics; give analysis.force", None, hint=f" ({exc})") from None
    if not model.excitations:
        raise SceneError("analysis.force", "a dof name, a list of them or a mapping dof: amplitude (the model has "
                         "no excitation)", None)
    n = model.n_dof
    depends = any(el.depends_on(hb.kw) for el in model.excitations)

    def at(w):
        out = np.empty((w.size, n), dtype=complex)
        for i, wi in enumerate(w if depends else w[:1]):
            f, _ = hb.excitation(hb.params_at(wi))
            f = f.reshape(3, n)
            out[i] = f[1] - 1j * f[2]
        if not depends:
            out[:] = out[0]
        return out

    return at


def result_columns(wname: str, dofs) -> list[str]:
    """The columns of ``frf.csv``."""
    return ["case", wname] + [f"{q}_{d}" for d in dofs for q in ("amp", "phase", "re", "im")]


#: further names the plot's axes look up in ``output.labels`` and ``output.units``
AXIS_NAMES = ("amplitude |X|",)


def _static_deflection(model, kw: int, p0, F) -> float:
    """``max |x|`` of ``K x = F(0)`` (K at ``w = 0``); NaN where ``K`` is singular."""
    p = np.array(p0, dtype=float)
    p[kw] = 0.0
    F0 = np.asarray(F(np.zeros(1))[0] if callable(F) else F)
    try:
        return float(np.max(np.abs(np.linalg.solve(model.linear(p)[2], F0))))
    except np.linalg.LinAlgError:
        return float("nan")


def _limit_responses(resp, w, F):
    """``X`` of the undamped model and of the model with its dampers locked, shape (nw, n) each.

    Locked dampers (``C`` scaled to infinity) allow only motions ``N y`` in
    the null space ``N`` of ``C``: ``X = N (N^T Z_0 N)^-1 N^T F``, ``Z_0 = K - w^2 M``.
    A singular impedance (an undamped resonance on the grid) gives NaN.
    """
    M, C, K = resp.MCK
    _, sv, vt = np.linalg.svd(C)
    N = vt[sv <= 1e-12 * sv.max()].T if sv.size else np.eye(M.shape[0])
    out0 = np.full((w.size, M.shape[0]), np.nan, dtype=complex)
    out1 = np.full_like(out0, np.nan)
    for i, wi in enumerate(w):
        Z0 = K - wi**2 * M
        with np.errstate(all="ignore"):
            if np.linalg.cond(Z0) < 1e14:
                out0[i] = np.linalg.solve(Z0, F[i])
            Zr = N.T @ Z0 @ N
            if N.shape[1] and np.linalg.cond(Zr) < 1e14:
                out1[i] = N @ np.linalg.solve(Zr, N.T @ F[i])
    return out0, out1


def fixed_points(resp, w, k: int) -> list[tuple[float, float]]:
    """Frequencies where ``|X_k|`` does not depend on the damping, and the amplitude there.

    They are the crossings of ``|X_k|`` of the undamped model with ``|X_k|``
    of the model with locked dampers (:func:`_limit_responses`): sign
    changes of their difference on the grid ``w``, refined by Brent's
    method; a sign change at a resonance of either (a jump, not a crossing) is
    left out.

    Parameters
    ----------
    resp : ForceResponse
        A force case of a model whose matrices do not depend on ``w``.
    w : ndarray, shape (nw,)
    k : int
        The dof.

    Returns
    -------
    list of (float, float)
        ``(w, |X_k|)`` in increasing ``w``.
    """
    def force(ws):
        F = resp.F(ws) if callable(resp.F) else np.broadcast_to(resp.F, (ws.size, resp.F.size))
        return np.asarray(F)

    def gap(ws):
        x0, x1 = _limit_responses(resp, ws, force(ws))
        return np.abs(x0[:, k]) - np.abs(x1[:, k]), np.abs(x0[:, k])

    g, _ = gap(w)
    out = []
    for i in np.flatnonzero(np.isfinite(g[:-1]) & np.isfinite(g[1:]) & (np.sign(g[:-1]) * np.sign(g[1:]) < 0)):
        root = brentq(lambda x: gap(np.array([x]))[0][0], w[i], w[i + 1], xtol=1e-14 * abs(w[i + 1]), rtol=1e-13)
        d, a = gap(np.array([root]))
        if np.isfinite(d[0]) and abs(d[0]) <= 1e-7 * a[0]:
            out.append((float(root), float(a[0])))
    return out


@dataclass(frozen=True, eq=False)  # arrays: compared by identity
class FrfPlan:
    """The checked choices of an ``frf`` scene.

    Attributes
    ----------
    frequency : str
        The frequency parameter.
    index : int
        Its index in the model's parameter vector.
    parameters : ndarray
        The model's parameter vector.
    grid : ndarray
        The frequencies.
    cases : tuple of (str, ndarray or callable)
        The force cases (:func:`force_cases`; the model's own excitation as ``F(w)``).
    static : tuple of float or None
        The static deflection of each case (``normalise: static``).
    """

    frequency: str
    index: int
    parameters: np.ndarray
    grid: np.ndarray
    cases: tuple
    static: tuple | None


class Frf(Analysis):
    """``frf``: the frequency response of a linear model from its impedance matrix (module docstring)."""

    name = "frf"
    summary = "Frequency response of a linear model from its impedance matrix."
    required = "range"
    schema = FRF

    def demands(self, scene, model) -> list:
        return frf_demands(scene, model)

    def plan(self, scene, model) -> FrfPlan:
        """Every check of an ``frf`` scene with its model (a linear model, the frequency, the grid, the force)."""
        a = scene.analysis
        dofs = list(model.dof_names)
        wname = model_frequency(scene.model, a)
        if wname not in model.parameters:
            raise scene.error("analysis.frequency", f"a parameter of the model {list(model.parameters)}", wname,
                              hint=suggest(wname, model.parameters))
        if model.forces:
            raise SceneError("model", "a linear model for analysis.type frf (no nonlinear forces)", None,
                             hint="; found " + "; ".join(el.describe(model.dof_names, model.param_names)
                                                         for el in model.forces)
                                  + f" (effects on: {', '.join(model.effects)}). Switch the nonlinear effects off, "
                                    "or use analysis.type frequency_response")
        kw = model.parameter_index(wname)
        p0 = model.parameter_vector()
        lo, hi = float(a["range"][0]), float(a["range"][1])
        if a["spacing"] == "log":
            if lo <= 0:
                raise scene.error("analysis.range", "a start above 0 for spacing: log", a["range"])
            w = np.geomspace(lo, hi, a["points"])
        else:
            w = np.linspace(lo, hi, a["points"])
        cases = force_cases(a["force"], dofs)
        if cases is None:
            cases = [("excitation", _own_force(model, wname))]
        check_output(scene, result_columns(wname, dofs)[1:], AXIS_NAMES)
        static = [_static_deflection(model, kw, p0, F) for _, F in cases] if a["normalise"] == "static" else None
        if static is not None and not all(np.isfinite(d) and d > 0 for d in static):
            raise scene.error("analysis.normalise", "a model with a static deflection under the force for 'static' "
                              "(a stiffness matrix it can invert and a force that does not vanish at w = 0), or "
                              "'none'", a["normalise"])
        return FrfPlan(frequency=wname, index=kw, parameters=p0, grid=w, cases=tuple(cases),
                       static=None if static is None else tuple(static))

    def describe(self, plan: FrfPlan, scene, model) -> list[str]:
        a = scene.analysis
        return [f"  impedance-matrix FRF over {a['range']} ({a['points']} points, {a['spacing']}), force: "
                + ("the model's excitation" if a["force"] is None else str(a["force"]))]

    def run(self, plan: FrfPlan, ctx):
        """``X(w)`` of every force case on the grid, its peaks and fixed points; the table and summary."""
        scene, model = ctx.scene, ctx.model
        a = scene.analysis
        dofs = list(model.dof_names)
        wname, kw, p0, w = plan.frequency, plan.index, plan.parameters, plan.grid
        static = None if plan.static is None else list(plan.static)
        t0 = time.perf_counter()
        results, skipped = [], []
        for label, F in plan.cases:
            resp = ForceResponse(model, kw, p0, F)
            keep = np.ones(w.size, bool)
            while True:
                try:
                    X = resp(w[keep])
                    break
                except SingularImpedance as exc:  # an undamped resonance exactly on the grid: leave it out
                    idx = np.flatnonzero(keep)[exc.indices]
                    keep[idx] = False
                    skipped += [float(w[i]) for i in idx]
                    if not keep.any():
                        raise SceneError("analysis.range", "frequencies where Z(w) can be solved",
                                         a["range"]) from None
            results.append((label, resp, w[keep], X))
        ctx.timings["frf"] = time.perf_counter() - t0
        out = ctx.sink.table("frf.csv", result_columns(wname, dofs))
        try:
            for label, _, ws, X in results:
                for i in range(ws.size):
                    row = {"case": label, wname: float(ws[i])}
                    for k, d in enumerate(dofs):
                        z = X[i, k]
                        row.update({f"amp_{d}": float(abs(z)), f"phase_{d}": float(np.degrees(np.angle(z))),
                                    f"re_{d}": float(z.real), f"im_{d}": float(z.imag)})
                    out.write(row)
        finally:
            out.close()
        M, C, K = model.linear(p0)
        try:
            nm = natural_modes(M, K)
            omega = [float(x) for x in nm.omega[~nm.divergent]]
        except (ValueError, np.linalg.LinAlgError):
            omega = []
        peaks = _peaks(results, dofs) if a["peaks"] else []
        fixed = _fixed_points(results, dofs, static) if a["fixed_points"] else []
        part = {
            "frequency": wname,
            "points": int(w.size),
            "cases": [c[0] for c in results],
            "natural_frequencies": omega,
            "peaks": peaks,
            "static_deflection": static,
            "fixed_points": [{k: v for k, v in f.items() if k != "_resp"} for f in fixed],
            "skipped_singular": skipped,
        }
        draw = (lambda: _plot(ctx, wname, dofs, results, omega, peaks, fixed, static)) if ctx.sink.writes else None
        return self.outcome(ctx, part, draw=draw)


def _fixed_points(results, dofs, static) -> list[dict]:
    """The fixed points of every force case on one dof of a damped model (see :func:`fixed_points`)."""
    out = []
    for j, (label, resp, ws, _) in enumerate(results):
        if resp.varying or not np.any(resp.MCK[1]):
            continue
        F = np.abs(resp.F(ws[:1])[0] if callable(resp.F) else resp.F)
        if np.count_nonzero(F) != 1:
            continue
        k = int(np.flatnonzero(F)[0])
        for i, (wf, amp) in enumerate(fixed_points(resp, ws, k)):
            name = "PQRSTUVW"[i] if i < 8 else f"F{i + 1}"
            out.append({"case": label, "dof": dofs[k], "name": name, "frequency": wf, "amplitude": amp,
                        "ratio": None if static is None else amp / static[j], "_resp": resp})
    return out


def _peaks(results, dofs):
    """Interior maxima of every ``|X_dof|`` on the grid, refined by a bounded scalar search."""
    out = []
    for label, resp, ws, X in results:
        if not resp.varying and not np.any(resp.MCK[1]):
            continue  # undamped: the amplitude is unbounded at the natural frequencies, no finite peak
        A = np.abs(X)
        for k, d in enumerate(dofs):
            y = A[:, k]
            for i in range(1, ws.size - 1):
                if not (y[i] > y[i - 1] and y[i] >= y[i + 1]):
                    continue

                def neg(wi, k=k):
                    try:
                        return -abs(resp(np.array([wi]))[0, k])
                    except SingularImpedance:
                        return -np.inf

                r = minimize_scalar(neg, bounds=(ws[i - 1], ws[i + 1]), method="bounded",
                                    options={"xatol": 1e-13 * max(abs(ws[i]), 1e-300)})
                wp, ap = (float(r.x), float(-r.fun)) if np.isfinite(r.fun) and -r.fun >= y[i] else (float(ws[i]),
                                                                                                    float(y[i]))
                if np.isfinite(ap):
                    out.append({"case": label, "dof": d, "frequency": wp, "amplitude": ap})
    return out


def draw_frf(ax_amp, ax_phase, wname, dofs, results, omega=(), peaks=(), fixed=(), static=None, *,
             scale: str = "log", units=None, labels=None, symbols=None):
    """Draw amplitude and phase of an FRF into two axes (``ax_phase`` may be None).

    Parameters
    ----------
    ax_amp, ax_phase : matplotlib Axes
    wname : str
        The frequency parameter.
    dofs : list of str
    results : list of (label, response, w (nw,), X (nw, n))
        One per force case.
    omega : sequence of float
        Undamped natural frequencies (dotted vertical lines).
    peaks, fixed : list of dict
        As in ``summary.json``; a fixed point's ``_resp`` (its force case) draws
        the undamped and locked-damper curves of its dof.
    static : list of float, optional
        The static deflection per case: amplitudes are drawn divided by it.
    scale : {"log", "linear"}
    units, labels, symbols : dict, optional
    """
    units, labels = dict(units or {}), dict(labels or {})
    cases = {label: j for j, (label, *_) in enumerate(results)}
    norm = [1.0] * len(results) if static is None else list(static)
    top = 0.0
    for j, (label, _, ws, X) in enumerate(results):
        for k, d in enumerate(dofs):
            name = math(d, symbols) if len(results) == 1 else f"{math(d, symbols)} (force on {label})"
            y = np.abs(X[:, k]) / norm[j]
            top = max(top, float(np.nanmax(y)) if y.size else 0.0)
            ax_amp.plot(ws, y, lw=1.5, label=name)
            if ax_phase is not None:
                ax_phase.plot(ws, np.degrees(np.unwrap(np.angle(X[:, k]))), lw=1.2)
    for i, om in enumerate(omega):
        for ax in (ax_amp, ax_phase):
            if ax is not None:
                ax.axvline(om, color="0.75", lw=0.9, zorder=0, label="undamped natural frequencies"
                           if (i == 0 and ax is ax_amp) else None)
    if peaks:
        ax_amp.plot([p["frequency"] for p in peaks], [p["amplitude"] / norm[cases.get(p["case"], 0)] for p in peaks],
                    "v", color="tab:red", ms=5, label="peaks")
    drawn = set()
    for f in fixed:
        j, resp = cases.get(f["case"], 0), f.get("_resp")
        key = (f["case"], f["dof"])
        if resp is not None and key not in drawn:  # the two curves whose crossings the fixed points are
            drawn.add(key)
            ws = results[j][2]
            k = dofs.index(f["dof"])
            F = np.asarray(resp.F(ws) if callable(resp.F) else np.broadcast_to(resp.F, (ws.size, len(dofs))))
            x0, x1 = _limit_responses(resp, ws, F)
            first = len(drawn) == 1
            ax_amp.plot(ws, np.abs(x0[:, k]) / norm[j], ":", color="0.35", lw=1.0,
                        label=f"{math(f['dof'], symbols)} without damping" if first else None)
            ax_amp.plot(ws, np.abs(x1[:, k]) / norm[j], "--", color="0.35", lw=1.0,
                        label=f"{math(f['dof'], symbols)} with the dampers locked" if first else None)
        y = f["amplitude"] / norm[j]
        ax_amp.plot([f["frequency"]], [y], "o", color="k", mfc="none", ms=8, mew=1.2,
                    label="fixed points (independent of the damping)" if f is fixed[0] else None)
        ax_amp.annotate(f["name"], (f["frequency"], y), textcoords="offset points", xytext=(-4, 7), ha="right",
                        fontsize=9, fontweight="bold")
    if scale == "log":
        ax_amp.set_yscale("log")
        if fixed and top > 0:
            ax_amp.set_ylim(top=3.0 * top)
    else:
        ax_amp.set_ylim(0, 1.25 * top if (fixed and top > 0) else None)
    amp = "amplitude |X|"
    if static is None:
        labels.setdefault(amp, "amplitude $|X|$")
        ax_amp.set_ylabel(axis_label(amp, units, labels, symbols))
    else:  # a ratio: no unit
        ax_amp.set_ylabel(labels.get(amp) or r"amplitude ratio $|X|/\delta_{\mathrm{st}}$")
    ax = ax_phase if ax_phase is not None else ax_amp
    if ax_phase is not None:
        ax_phase.set_ylabel("phase [deg]")
        ax_phase.yaxis.set_major_locator(matplotlib.ticker.MultipleLocator(90))
    ax.set_xlabel(axis_label(wname, units, {wname: "forcing frequency " + math(wname, symbols), **labels}, symbols))


def _plot(ctx, wname, dofs, results, omega, peaks, fixed=(), static=None) -> list:
    out = ctx.scene.output
    with figure_style(out["style"]):
        fig = new_figure((7.2, 6.8))
        ax1, ax2 = fig.subplots(2, 1, sharex=True, height_ratios=(3, 2))
        draw_frf(ax1, ax2, wname, dofs, results, omega, peaks, fixed, static, scale=ctx.scene.analysis["scale"],
                 units=out["units"], labels=out["labels"], symbols=getattr(ctx.model, "symbols", None))
        title = out["title"] or f"{ctx.model.name}: frequency response"
        if static is not None:
            title += "\n" + ", ".join(rf"$\delta_{{\mathrm{{st}}}}$ = {d:.4g}" for d in static) + \
                (f" {out['units']['amplitude |X|']}" if (out["units"] or {}).get("amplitude |X|") else "")
        ax1.set_title(title)
        legend_below(fig, ax1, ncols=3 if len(ax1.get_legend_handles_labels()[0]) > 4 else 2)
        return save_figure(fig, ctx.sink.path("frf"), out["formats"], out["dpi"])
