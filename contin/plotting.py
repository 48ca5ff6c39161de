"""Figures: the bifurcation diagram (stable solid, unstable dashed, special points labelled)."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

__all__ = ["bifurcation_diagram", "axis_label"]

MARKERS = {"fold": ("o", "tab:red"), "pd": ("s", "tab:purple"), "ns": ("D", "tab:green"), "kink": ("v", "tab:gray"),
           "bp": ("^", "tab:orange"), "stability": ("x", "k")}


def axis_label(name: str, units: dict | None = None, labels: dict | None = None) -> str:
    """``label [unit]`` for a parameter or measure, from the scene's ``output.labels``/``units``."""
    text = (labels or {}).get(name, name)
    unit = (units or {}).get(name)
    return f"{text} [{unit}]" if unit else text


def _segments(x, y, stable):
    """Split a curve where the stability flag changes; each segment shares its end point."""
    if stable is None or len(x) < 2:
        return [(x, y, True)]
    segs, start = [], 0
    for i in range(1, len(x)):
        if stable[i] != stable[start]:
            segs.append((x[start:i + 1], y[start:i + 1], bool(stable[start])))
            start = i
    segs.append((x[start:], y[start:], bool(stable[start])))
    return segs


def bifurcation_diagram(branches, special, parameter: str, measure: str, path: Path, *,
                        units=None, labels=None, title: str | None = None, extra=None):
    """Draw and save a bifurcation diagram.

    Parameters
    ----------
    branches : list of dict
        Each with ``x`` (P,), ``y`` (P,), ``stable`` ((P,) bool or None), ``label``.
    special : list of dict
        Each with ``x``, ``y``, ``kind``.
    parameter, measure : str
        Axis names.
    path : Path
        Output file (format from the suffix).
    extra : callable, optional
        ``extra(ax)`` to draw more on the axes.
    """
    fig, ax = plt.subplots(figsize=(7.0, 4.6), constrained_layout=True)
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for i, br in enumerate(branches):
        c = colors[i % len(colors)]
        first = True
        for xs, ys, st in _segments(np.asarray(br["x"]), np.asarray(br["y"]), br.get("stable")):
            ax.plot(xs, ys, "-" if st else "--", color=c, lw=1.6 if st else 1.1,
                    label=br.get("label") if first else None)
            first = False
    seen = set()
    for sp in special:
        kind = sp["kind"]
        if kind not in MARKERS:
            continue
        m, c = MARKERS[kind]
        ax.plot(sp["x"], sp["y"], m, color=c, ms=6, mfc="none" if kind != "stability" else c,
                label=kind if kind not in seen else None, zorder=5)
        ax.annotate(kind, (sp["x"], sp["y"]), textcoords="offset points", xytext=(4, 4), fontsize=7, color=c)
        seen.add(kind)
    if extra is not None:
        extra(ax)
    ax.set_xlabel(axis_label(parameter, units, labels))
    ax.set_ylabel(axis_label(measure, units, labels))
    if title:
        ax.set_title(title)
    ax.grid(True, alpha=0.3)
    if any(br.get("stable") is not None for br in branches):
        ax.plot([], [], "k-", label="stable")
        ax.plot([], [], "k--", label="unstable")
    ax.legend(fontsize=8, loc="best")
    fig.savefig(path, dpi=130)
    plt.close(fig)
    return path
