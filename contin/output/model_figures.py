"""Figures a model adds to a run: the hook ``Model.extra_figures``.

A model may carry ``extra_figures``, a tuple of :class:`FigureHook`. After a
one-parameter run (``frequency_response``) draws its own figures, each hook
gets the run's branches (:class:`RunData`) and draws into a new axes; a hook
that has nothing to say about the run (another parameter, another analysis)
returns False and no file is written. The built-in Mathieu model draws its
stability chart this way (:mod:`contin.models.mathieu`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Mapping

import numpy as np

__all__ = ["FigureHook", "RunData", "STABILITY_CHANGES", "stability_segments", "model_figures"]

#: kinds of special points at which a branch's stability changes
STABILITY_CHANGES = ("fold", "pd", "ns", "bp", "stability")


@dataclass(frozen=True)
class FigureHook:
    """One figure a model adds to the runs made with it.

    Parameters
    ----------
    stem : str
        File name without its suffix (``stability_chart``).
    draw : callable
        ``draw(ax, data) -> bool`` with ``data`` a :class:`RunData`: draws into
        the axes and returns True, or returns False when the figure does not
        apply to the run (then no file is written).
    figsize : (float, float), optional
        Inches; the style's size if omitted.
    """

    stem: str
    draw: Callable
    figsize: tuple | None = None


@dataclass(frozen=True)
class RunData:
    """What a one-parameter run found, for a model's own figures.

    Attributes
    ----------
    analysis : str
        ``analysis.type`` of the run.
    parameter : str
        The continued parameter.
    parameters : dict
        The model's parameter values (the continued one at its scene value).
    effects : tuple of str
        The effects the model was built with.
    branches : tuple of dict
        ``id``, ``nu``, ``x`` (P,) the parameter, ``stable`` (P,) of True,
        False or None, ``rows`` (P,) of dicts of the measures of
        ``branches.csv``.
    special : tuple of dict
        ``branch``, ``kind``, ``x`` (the located parameter).
    units, labels, symbols : dict
        ``output.units``, ``output.labels`` and the model's symbols.
    """

    analysis: str
    parameter: str
    parameters: dict
    effects: tuple = ()
    branches: tuple = ()
    special: tuple = ()
    units: Mapping = field(default_factory=dict)
    labels: Mapping = field(default_factory=dict)
    symbols: Mapping | None = None


def stability_segments(x, stable, changes=()) -> list[tuple[float, float, bool | None]]:
    """The parameter intervals of one branch with one stability verdict each.

    Parameters
    ----------
    x : array_like, shape (P,)
        The parameter along the branch.
    stable : sequence, length P
        True, False or None (no verdict) per point.
    changes : sequence of float
        Located stability changes of the branch; a change between two points
        of different verdicts ends the one interval and starts the next there
        (else they meet half-way).

    Returns
    -------
    list of (float, float, bool or None)
        ``(lo, hi, verdict)`` in the order of the branch, ``lo <= hi``.
    """
    x = np.asarray(x, float)
    if x.size == 0:
        return []
    changes = np.asarray(sorted(changes), float)
    out = []
    start = x[0]
    for i in range(x.size - 1):
        if stable[i] == stable[i + 1]:
            continue
        a, b = sorted((x[i], x[i + 1]))
        inside = changes[(changes >= a - 1e-12 * (1 + abs(a))) & (changes <= b + 1e-12 * (1 + abs(b)))]
        edge = float(inside[np.argmin(np.abs(inside - 0.5 * (a + b)))]) if inside.size else 0.5 * (a + b)
        out.append((min(start, edge), max(start, edge), stable[i]))
        start = edge
    out.append((min(start, x[-1]), max(start, x[-1]), stable[-1]))
    return [(float(lo), float(hi), None if v is None else bool(v)) for lo, hi, v in out]


def model_figures(model, analysis: str, parameter: str, branches, special, outdir, output) -> list[str]:
    """Draw and save every figure of ``model.extra_figures`` that applies to the run.

    Parameters
    ----------
    model : Model
        Its ``extra_figures`` (absent: no figures), ``parameters``, ``effects``
        and ``symbols`` are read.
    analysis, parameter : str
        ``analysis.type`` and the continued parameter.
    branches : dict
        Branch id -> ``{"nu", "x", "stable", "rows"}`` (as the run records them).
    special : sequence of dict
        Special points with ``branch``, ``kind`` and the parameter under its name.
    outdir : Path
    output : dict
        The scene's ``output`` section (``formats``, ``dpi``, ``style``, ``units``, ``labels``).

    Returns
    -------
    list of str
        The file names written.
    """
    hooks = tuple(getattr(model, "extra_figures", None) or ())
    if not hooks:
        return []
    # matplotlib (0.4 s) waits for a figure: the built-in models import this module when the catalogue loads
    from contin.output.figures import figure_style, new_figure, save_figure  # deferred: matplotlib, see above

    data = RunData(
        analysis=analysis, parameter=parameter, parameters=dict(model.parameters), effects=tuple(model.effects),
        branches=tuple({"id": bid, "nu": c.get("nu", 1), "x": np.asarray(c["x"], float), "stable": list(c["stable"]),
                        "rows": list(c.get("rows", ()))} for bid, c in dict(branches).items()),
        special=tuple({"branch": s["branch"], "kind": s["kind"], "x": float(s[parameter])} for s in special),
        units=output.get("units") or {}, labels=output.get("labels") or {},
        symbols=getattr(model, "symbols", None))
    files = []
    with figure_style(output.get("style")):
        for hook in hooks:
            fig = new_figure(hook.figsize)
            if hook.draw(fig.add_subplot(), data):
                files += save_figure(fig, outdir / hook.stem, output.get("formats") or ("png",), output.get("dpi"))
    return files
