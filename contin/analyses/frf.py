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
force), ``re_<dof>``, ``im_<dof>``), plot ``frf.png`` (amplitude, on a log scale
unless ``scale: linear``, and the unwrapped phase, with the undamped natural
frequencies marked). ``summary.json`` lists
the undamped natural frequencies and, for a damped model, every interior
amplitude maximum, located to machine precision by a bounded scalar search.
"""

from __future__ import annotations

import time

import numpy as np

from contin.scene.parse import model_frequency
from contin.scene.registry import register_analysis
from contin.util.naming import suggest
from contin.scene.schema import Key, SceneError, flag, int_range, is_number, string

__all__ = ["FRF", "check", "run", "force_cases", "result_columns"]


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


class _Response:
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
        from contin.modal.modes import frf

        w = np.atleast_1d(np.asarray(w, dtype=float))
        F = self.F(w) if callable(self.F) else self.F
        return frf(*self.matrices(w), w, F)


def _own_force(model, wname: str):
    """The model's excitation at the forcing frequency ``wname``, ``F(w) = a_1 - i b_1``, shape (nw, n)."""
    from contin.hb.problem import HarmonicBalance, HBOptions

    try:
        hb = HarmonicBalance(model, wname, HBOptions(harmonics=1), frequency=wname)
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


def check(scene, model) -> dict:
    """Every check of an ``frf`` scene with its model; returns its setup.

    Returns
    -------
    dict
        ``wname`` (the frequency parameter), ``kw`` (its index), ``p0``,
        ``w`` (the frequency grid) and ``cases`` (``[(label, F)]``).
    """
    from contin.scene.registry import check_output

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
    return {"wname": wname, "kw": kw, "p0": p0, "w": w, "cases": cases}


@register_analysis("frf", FRF, check=check)
def run(ctx) -> dict:
    """Run an ``frf`` scene; returns its part of ``summary.json``."""
    from contin.modal.modes import SingularImpedance, natural_modes
    from contin.output.results import CsvStream

    scene, model = ctx.scene, ctx.model
    a = scene.analysis
    dofs = list(model.dof_names)
    plan = ctx.plan  # check(), made before anything was written
    wname, kw, p0, w, cases = plan["wname"], plan["kw"], plan["p0"], plan["w"], plan["cases"]
    t0 = time.perf_counter()
    results, skipped = [], []
    for label, F in cases:
        resp = _Response(model, kw, p0, F)
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
                    raise SceneError("analysis.range", "frequencies where Z(w) can be solved", a["range"]) from None
        results.append((label, resp, w[keep], X))
    ctx.timings["frf"] = time.perf_counter() - t0
    out = CsvStream(ctx.outdir / "frf.csv", result_columns(wname, dofs))
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
    ctx.plot = lambda: _plot(ctx, wname, dofs, results, omega, peaks)
    return {
        "frequency": wname,
        "points": int(w.size),
        "cases": [c[0] for c in results],
        "natural_frequencies": omega,
        "peaks": peaks,
        "skipped_singular": skipped,
    }


def _peaks(results, dofs):
    """Interior maxima of every ``|X_dof|`` on the grid, refined by a bounded scalar search."""
    from scipy.optimize import minimize_scalar

    from contin.modal.modes import SingularImpedance

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


def _plot(ctx, wname, dofs, results, omega, peaks) -> list:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker

    from contin.output.plotting import axis_label

    out = ctx.scene.output
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(7.2, 6.4), sharex=True, constrained_layout=True)
    for label, _, ws, X in results:
        for k, d in enumerate(dofs):
            name = d if len(results) == 1 else f"{d} (force {label})"
            ax1.plot(ws, np.abs(X[:, k]), lw=1.4, label=name)
            ax2.plot(ws, np.degrees(np.unwrap(np.angle(X[:, k]))), lw=1.2, label=name)
    for om in omega:
        for ax in (ax1, ax2):
            ax.axvline(om, color="0.6", lw=0.8, ls=":")
    if peaks:
        ax1.plot([p["frequency"] for p in peaks], [p["amplitude"] for p in peaks], "rv", ms=5, label="peaks")
    if ctx.scene.analysis["scale"] == "log":
        ax1.set_yscale("log")
    else:
        ax1.set_ylim(bottom=0)
    ax1.set_ylabel(axis_label("amplitude |X|", out["units"], out["labels"]))
    ax2.set_ylabel("phase [deg]")
    ax2.yaxis.set_major_locator(matplotlib.ticker.MultipleLocator(90))
    ax2.set_xlabel(axis_label(wname, out["units"], out["labels"]))
    ax1.set_title(out["title"] or f"{ctx.model.name}: frequency response (dotted: undamped natural frequencies)")
    for ax in (ax1, ax2):
        ax.grid(True, alpha=0.3)
    ax1.legend(fontsize=8)
    path = ctx.outdir / "frf.png"
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return [path.name]
