"""Figures without global state: a figure made outside pyplot, a style applied for one figure only,
and one file per requested format.

A run's figures are :class:`matplotlib.figure.Figure` objects drawn on their own
canvas, so writing them neither selects nor changes the user's matplotlib backend
(a notebook keeps its inline figures), and a style is applied inside
``matplotlib.rc_context`` so that the user's rcParams are the same after the call.
The drawing functions take an ``Axes``; the same function draws into a file and
into the axes a user passes to ``Result.plot``.
"""

from __future__ import annotations

import contextlib
from pathlib import Path

import matplotlib
from matplotlib.figure import Figure

from contin.output.formats import CONTIN_STYLES, FIGURE_FORMATS, style_names
from contin.util.safe_files import replace_file

__all__ = ["FIGURE_FORMATS", "STYLES", "new_figure", "save_figure", "figure_style", "style_names", "legend_below"]

#: contin's styles (``output.style``); any style shipped with matplotlib is accepted as well
STYLES = {
    "contin": {"axes.grid": True, "grid.alpha": 0.3, "legend.fontsize": 8, "legend.framealpha": 0.9,
               "axes.titlesize": 10, "savefig.dpi": 200},
    # a journal column: serif text of the body's size, thin lines, 3.5 x 2.6 in
    "paper": {"font.family": "serif", "font.size": 8, "axes.labelsize": 8, "axes.titlesize": 8,
              "legend.fontsize": 6.5, "xtick.labelsize": 7, "ytick.labelsize": 7, "lines.linewidth": 1.0,
              "lines.markersize": 4, "axes.grid": True, "grid.alpha": 0.25, "grid.linewidth": 0.4,
              "figure.figsize": (3.5, 2.6), "savefig.dpi": 300, "mathtext.fontset": "dejavuserif"},
    # slides: large text and thick lines
    "presentation": {"font.size": 14, "axes.labelsize": 14, "axes.titlesize": 14, "legend.fontsize": 11,
                     "xtick.labelsize": 12, "ytick.labelsize": 12, "lines.linewidth": 2.2, "lines.markersize": 8,
                     "axes.grid": True, "grid.alpha": 0.3, "figure.figsize": (9.0, 5.6), "savefig.dpi": 150},
}
assert tuple(STYLES) == CONTIN_STYLES  # the scene check knows them without importing this module


@contextlib.contextmanager
def figure_style(style: str | None = "contin"):
    """Apply ``style`` (a name of :func:`style_names`) for the figures made and saved inside the block.

    The rcParams are restored on leaving, so the caller's matplotlib settings are unchanged.
    """
    import matplotlib.style

    style = style or "contin"
    with matplotlib.rc_context():
        if style in STYLES:
            matplotlib.rcParams.update(STYLES[style])
        else:
            if style not in matplotlib.style.available:
                raise ValueError(f"unknown figure style {style!r}; expected one of {', '.join(style_names())}")
            matplotlib.style.use(style)
            matplotlib.rcParams.update({"axes.grid": True, "grid.alpha": 0.3})
        yield


def new_figure(figsize=None, **kwargs) -> Figure:
    """A figure on its own canvas (not registered with pyplot), laid out with ``constrained`` layout.

    ``figsize`` defaults to the style's ``figure.figsize``, so the ``paper`` style gives a column's width.
    """
    if figsize is None:
        figsize = matplotlib.rcParams["figure.figsize"]
    return Figure(figsize=figsize, layout="constrained", **kwargs)


def legend_below(fig: Figure, ax, ncols: int | None = None, **kwargs) -> None:
    """The legend of ``ax`` below the axes, outside them (it never covers a curve); nothing if it is empty.

    ``ncols`` defaults to 2 for more than three entries, else 1.
    """
    handles, texts = ax.get_legend_handles_labels()
    if handles:
        fig.legend(handles, texts, loc="outside lower center",
                   ncols=ncols or (2 if len(handles) > 3 else 1), **kwargs)


def save_figure(fig: Figure, stem: str | Path, formats=("png",), dpi: float | None = None) -> list[str]:
    """Write ``fig`` as ``stem.<format>`` for every format; return the file names written.

    Parameters
    ----------
    fig : Figure
    stem : str or Path
        The path without its suffix (``outdir / "bifurcation_diagram"``); a suffix given is replaced.
    formats : sequence of str
        Among :data:`FIGURE_FORMATS`.
    dpi : float, optional
        Resolution of raster formats; the style's ``savefig.dpi`` if omitted.
    """
    stem = Path(stem)
    if stem.suffix.lstrip(".") in FIGURE_FORMATS:
        stem = stem.with_suffix("")
    names = []
    for fmt in formats:
        if fmt not in FIGURE_FORMATS:
            raise ValueError(f"unknown figure format {fmt!r}; expected one of {', '.join(FIGURE_FORMATS)}")
        path = stem.with_name(f"{stem.name}.{fmt}")
        # fixed metadata: the same figure gives the same file, run after run
        meta = {"png": {"Software": "contin"}, "pdf": {"Creator": "contin", "CreationDate": None},
                "svg": {"Date": None}}[fmt]
        dots = dpi if dpi is not None else matplotlib.rcParams["savefig.dpi"]
        # through a temporary file renamed onto the figure: never written through a link, never half-written
        replace_file(path, lambda fh: fig.savefig(fh, format=fmt, dpi=dots, metadata=meta),  # noqa: B023
                     binary=True, sync=False)
        names.append(path.name)
    return names
