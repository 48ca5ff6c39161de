"""Damped Mathieu-Duffing oscillator (parametric excitation).

    x'' + c x' + (delta + eps cos(w t)) x + g x^3 = 0

With ``c = g = 0`` the trivial solution's stability boundaries in ``delta``
are the Mathieu characteristic curves ``delta = a_r(q)/4`` (and ``b_r(q)/4``)
with ``q = 2 eps`` for ``w = 1`` (Abramowitz & Stegun 20.1; scipy.special.mathieu_a/b); for any
``w > 0`` the time ``s = w t / 2`` turns the equation into Mathieu's ``x'' + (a - 2 q cos 2s) x = 0``
with ``a = 4 delta / w^2`` and ``|q| = 2 eps / w^2``, so the curves are ``delta = w^2 a_r(q)/4``.

A ``frequency_response`` run in ``delta`` (or ``eps``) also writes
``stability_chart.<format>`` (the hook ``extra_figures``): the Ince-Strutt chart
in the plane (``delta``, ``eps``) with the unstable tongues shaded, and the
run's line ``eps = const`` with the intervals contin found stable and unstable
along it. With damping (``c != 0``) the closed-form curves do not hold and only
the run's intervals are drawn.
"""

from __future__ import annotations

import numpy as np

from contin.model.catalog import ModelSpec, register_model
from contin.models.polynomial import polynomial_model
from contin.output.labels import axis_label, math
from contin.output.model_figures import STABILITY_CHANGES, FigureHook, stability_segments

__all__ = ["mathieu", "transition_curves", "draw_stability_chart"]

#: marker and colour of a stability change on the chart, by kind (those of the bifurcation diagram)
_CHANGE_MARKERS = {"pd": ("s", "tab:purple"), "bp": ("^", "tab:orange"), "fold": ("o", "tab:red"),
                   "ns": ("D", "tab:green"), "stability": ("x", "k")}


def transition_curves(eps, w: float = 1.0, orders: int = 4):
    """The Mathieu transition curves of the undamped model, ``delta`` against ``eps``.

    Parameters
    ----------
    eps : array_like, shape (E,)
        Parametric amplitudes (the curves depend on ``|eps|``).
    w : float
        Excitation frequency (> 0).
    orders : int
        Tongues ``r = 1 .. orders - 1`` besides ``r = 0``.

    Returns
    -------
    a : ndarray, shape (orders, E)
        ``delta = w^2 a_r(q)/4`` with ``q = 2 |eps| / w^2``: the left boundary of
        the stable set ``r = 0`` and the right sides of the tongues.
    b : ndarray, shape (orders, E)
        ``delta = w^2 b_r(q)/4`` (row 0 is NaN): the left sides of the tongues.
        The trivial solution is unstable for ``delta < a_0`` and for
        ``b_r < delta < a_r``, ``r >= 1`` (the tongue ``r`` starts at
        ``delta = (r w / 2)^2``: a response at ``r w / 2``).
    """
    from scipy.special import mathieu_a, mathieu_b

    q = 2.0 * np.abs(np.asarray(eps, float)) / w**2
    a = np.array([w**2 * mathieu_a(r, q) / 4.0 for r in range(orders)])
    b = np.array([np.full(q.shape, np.nan)] + [w**2 * mathieu_b(r, q) / 4.0 for r in range(1, orders)])
    return a, b


def _trivial(branch) -> bool:
    return branch["nu"] == 1 and all(abs(r.get("amp_x") or 0.0) < 1e-9 for r in branch["rows"])


def draw_stability_chart(ax, data) -> bool:
    """The Ince-Strutt chart with a run's stable and unstable intervals of the trivial solution ``x = 0``.

    Horizontal ``delta``, vertical ``eps``; the regions where ``x = 0`` is
    unstable are shaded between the transition curves of
    :func:`transition_curves` (undamped: ``c = 0``). The run's line (``eps =
    const`` for a run in ``delta``, ``delta = const`` for one in ``eps``)
    carries the intervals contin found stable (solid) and unstable (red,
    thick), and its located stability changes. With ``c != 0`` only the run's
    intervals are drawn, with a note.

    Parameters
    ----------
    ax : matplotlib Axes
    data : contin.output.model_figures.RunData

    Returns
    -------
    bool
        False (nothing drawn) for other analyses or parameters, without the
        parametric effect, or without a trivial branch.
    """
    if data.analysis != "frequency_response" or data.parameter not in ("delta", "eps") \
            or "parametric" not in data.effects:
        return False
    branches = [b for b in data.branches if _trivial(b) and b["x"].size]
    if not branches:
        return False
    p, sym = data.parameters, data.symbols
    w = float(p["w"])
    c = float(p["c"]) if "damping" in data.effects else 0.0
    closed = c == 0.0 and w > 0
    along_delta = data.parameter == "delta"
    fixed = float(p["eps"] if along_delta else p["delta"])
    run = np.concatenate([b["x"] for b in branches])
    lo, hi = float(run.min()), float(run.max())
    if closed:
        xlim = (min(lo, -0.5), max(hi, 1.5)) if along_delta else (min(fixed, -0.5), max(fixed, 1.5))
        xlim = (xlim[0] - 0.03 * (xlim[1] - xlim[0]), xlim[1] + 0.03 * (xlim[1] - xlim[0]))
        top = max(1.0, 1.6 * abs(fixed)) if along_delta else max(1.0, 1.1 * max(abs(lo), abs(hi)))
        ylim = (min(0.0, lo) if not along_delta else 0.0, top)
        eps = np.linspace(ylim[0], ylim[1], 401)
        orders = int(np.ceil(2.0 * np.sqrt(max(xlim[1], 0.0) + 1.0) / w)) + 1
        a, b = transition_curves(eps, w, orders)
        shade = dict(color="tab:red", alpha=0.13, lw=0)
        ax.fill_betweenx(eps, xlim[0], np.maximum(a[0], xlim[0]), **shade)
        for r in range(1, orders):
            ax.fill_betweenx(eps, b[r], a[r], **shade)
        for r in range(orders):
            ax.plot(a[r], eps, "-", color="0.25", lw=0.9)
            if r:
                ax.plot(b[r], eps, "--", color="0.25", lw=0.9)
        ax.fill_between([], [], [], label="unstable (closed form)", **shade)
        ws = math("w", sym).strip("$")
        qtext = r"2\varepsilon" if w == 1.0 else rf"2\varepsilon/{ws}^2"
        scale = "" if w == 1.0 else f"{ws}^2"
        ax.plot([], [], "-", color="0.25", lw=0.9, label=rf"$\delta = {scale}a_r(q)/4$, $q = {qtext}$")
        ax.plot([], [], "--", color="0.25", lw=0.9, label=rf"$\delta = {scale}b_r(q)/4$")
        ax.set_xlim(*xlim)
        ax.set_ylim(*ylim)
    else:
        ax.text(0.02, 0.97, f"$c$ = {c:g} (damped): the closed-form transition curves hold for $c = 0$ only;\n"
                "the intervals found by the run are drawn alone", transform=ax.transAxes, va="top", fontsize=8,
                bbox=dict(boxstyle="round", fc="w", ec="0.7"))
        if along_delta:  # the line where it would be on the chart
            ax.set_ylim(min(0.0, fixed), max(1.0, 1.6 * abs(fixed)))
        else:
            ax.set_xlim(min(fixed, -0.5), max(fixed, 1.5))
    line = dict(color="0.5", lw=0.8, ls=":")
    (ax.axhline if along_delta else ax.axvline)(fixed, **line)

    def pts(u0, u1):  # a stretch of the run's line in (delta, eps)
        return ([u0, u1], [fixed, fixed]) if along_delta else ([fixed, fixed], [u0, u1])

    seen = set()
    for br in branches:
        changes = [s for s in data.special if s["branch"] == br["id"] and s["kind"] in STABILITY_CHANGES]
        for u0, u1, st in stability_segments(br["x"], br["stable"], [s["x"] for s in changes]):
            style = {True: ("tab:blue", 2.5, "stable (this run)"), False: ("tab:red", 5.0, "unstable (this run)"),
                     None: ("0.5", 1.5, "no stability verdict")}[st]
            ax.plot(*pts(u0, u1), "-", color=style[0], lw=style[1], solid_capstyle="butt", zorder=4,
                    label=style[2] if style[2] not in seen else None)
            seen.add(style[2])
        for s in changes:
            m, col = _CHANGE_MARKERS.get(s["kind"], ("x", "k"))
            key = f"stability change: {s['kind']}"
            ax.plot(*pts(s["x"], s["x"]), m, color=col, mfc="w", ms=7, mew=1.4, zorder=5,
                    label=key if key not in seen else None)
            seen.add(key)
    words = {"delta": "stiffness " + math("delta", sym), "eps": "parametric amplitude " + math("eps", sym)}
    words.update(data.labels or {})
    ax.set_xlabel(axis_label("delta", data.units, words, sym))
    ax.set_ylabel(axis_label("eps", data.units, words, sym))
    run_text = f"{math('eps' if along_delta else 'delta', sym)} = {fixed:g}"
    ax.set_title(f"stability of $x = 0$: {'Ince-Strutt chart and ' if closed else ''}the run at {run_text}")
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)
    return True


#: the figures the model adds to a run (contin.output.model_figures)
EXTRA_FIGURES = (FigureHook("stability_chart", draw_stability_chart, (9.0, 5.2)),)


def _build(params: dict, effects: tuple):
    nonlinear = []
    terms = ["x'' + delta*x (frequency domain)"]
    if "parametric" in effects:
        nonlinear.append({"dof": "x", "coef": "eps", "x": {"x": 1}, "order": 1})
    if "cubic" in effects:
        nonlinear.append({"dof": "x", "coef": "g", "x": {"x": 3}})
    if "damping" in effects:
        terms.append("c*x' (frequency domain)")
    model = polynomial_model(
        ["x"],
        params,
        mass=[[1.0]],
        damping=[["c"]] if "damping" in effects else None,
        stiffness=[["delta"]],
        nonlinear=nonlinear,
        name="mathieu",
        effects=effects,
        terms=terms,
    )
    model.symbols = {"w": r"\Omega", "eps": r"\varepsilon"}  # as figures write them
    model.extra_figures = EXTRA_FIGURES
    return model


mathieu = register_model(
    ModelSpec(
        name="mathieu",
        summary="damped Mathieu-Duffing oscillator x'' + c x' + (delta + eps cos(w t)) x + g x^3 = 0",
        parameters={"delta": 0.25, "eps": 0.2, "c": 0.0, "g": 0.0, "w": 1.0},
        effects={
            "damping": "viscous damping c x'",
            "parametric": "parametric stiffness eps cos(w t) x",
            "cubic": "cubic stiffness g x^3",
        },
        default_effects=("damping", "parametric", "cubic"),
        builder=_build,
        # delta < 0 (the inverted pendulum) and g < 0 are meaningful; eps's sign is a phase
        constraints={"c": ("nonnegative", "a viscous damping"), "w": ("nonnegative", "the excitation frequency")},
    )
)
