"""The names a scene's ``output`` section takes: figure formats, export formats and styles.

Kept apart from the modules that draw and write (:mod:`contin.output.figures`,
:mod:`contin.output.exports`) so that checking a scene imports neither
matplotlib nor the continuation engine.
"""

from __future__ import annotations

__all__ = ["CONTIN_STYLES", "EXPORT_FORMATS", "FIGURE_FORMATS", "is_style", "style_names"]

#: file formats a run can write its figures in (``output.formats``)
FIGURE_FORMATS = ("png", "pdf", "svg")
#: data files a run can write beside its tables (``output.exports``)
EXPORT_FORMATS = ("npz", "mat")
#: contin's own styles (``output.style``; their rcParams are :data:`contin.output.figures.STYLES`)
CONTIN_STYLES = ("contin", "paper", "presentation")


def style_names() -> tuple:
    """Every value ``output.style`` accepts: contin's styles, then matplotlib's own."""
    import matplotlib.style  # deferred: matplotlib (0.1 s), only for a style that is not contin's

    return CONTIN_STYLES + tuple(sorted(s for s in matplotlib.style.available if not s.startswith("_")))


def is_style(v) -> bool:
    """Whether ``v`` names a style (matplotlib is asked only for a name that is not contin's)."""
    return isinstance(v, str) and (v in CONTIN_STYLES or v in style_names())
