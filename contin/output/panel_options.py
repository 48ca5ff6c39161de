"""The panels and the zoom window of a bifurcation diagram: ``output.panels`` and ``output.zoom``.

Kept apart from the drawing (:mod:`contin.output.panels`) so that checking a
scene imports no matplotlib. ``output.panels`` lists the measures drawn as
stacked panels over one parameter axis; ``output.zoom`` is a window of the
parameter (and optionally of some measures) drawn beside the whole range.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

__all__ = ["MAX_PANELS", "PANELS_EXPECTED", "ZOOM_EXPECTED", "PanelError", "ZoomWindow", "is_panel_list"]

#: the most measures one figure stacks (more would leave each panel too low to read)
MAX_PANELS = 6
#: what ``output.panels`` takes, in the scene's words
PANELS_EXPECTED = (f"a list of 1 to {MAX_PANELS} distinct measures (columns of branches.csv), drawn as panels "
                   "from top to bottom")
#: what ``output.zoom`` takes, in the scene's words
ZOOM_EXPECTED = ("a mapping with range: [lo, hi] (the parameter's window) and optionally "
                 "measure_range: {measure: [lo, hi]}")
_WINDOW = "two increasing finite numbers [lo, hi]"


class PanelError(ValueError):
    """A field of the panels' options that is not as expected; ``field`` names it (``range``,
    ``measure_range.amp_x``)."""

    def __init__(self, field: str, expected: str, found=None):
        self.field, self.expected, self.found = field, expected, found
        super().__init__(f"{field}: expected {expected}" + ("" if found is None else f", found {found!r}"))


def is_panel_list(v) -> bool:
    """Whether ``v`` is what ``output.panels`` takes (:data:`PANELS_EXPECTED`)."""
    return (isinstance(v, list) and 1 <= len(v) <= MAX_PANELS and all(isinstance(x, str) and x for x in v)
            and len(set(v)) == len(v))


def _window(v):
    """``(lo, hi)`` as floats when ``v`` is two finite numbers with lo < hi, else None."""
    if not isinstance(v, (list, tuple)) or len(v) != 2:
        return None
    if not all(isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) for x in v):
        return None
    lo, hi = float(v[0]), float(v[1])
    return (lo, hi) if lo < hi else None


@dataclass(frozen=True)
class ZoomWindow:
    """A window of the diagram drawn beside its whole range (``output.zoom``).

    Parameters
    ----------
    range : (float, float)
        The parameter's window ``(lo, hi)``, lo < hi: the x-limits of the zoom.
    measure_range : mapping or tuple of pairs, optional
        ``{measure: (lo, hi)}``: the y-limits of the zoom of those measures;
        the others are fitted to the curves inside the window. Stored as a
        tuple of ``(measure, (lo, hi))`` pairs (the dataclass is frozen).

    Raises
    ------
    PanelError
        A ValueError naming the field (``range``, ``measure_range.NAME``) and the form expected.
    """

    range: tuple
    measure_range: tuple = ()

    def __post_init__(self):
        window = _window(self.range)
        if window is None:
            raise PanelError("range", _WINDOW + " (the parameter's window)", self.range)
        object.__setattr__(self, "range", window)
        given = self.measure_range
        if isinstance(given, Mapping):
            given = tuple(given.items())
        if not isinstance(given, tuple) or not all(isinstance(p, tuple) and len(p) == 2 for p in given):
            raise PanelError("measure_range", "a mapping {measure: [lo, hi]}", self.measure_range)
        pairs = []
        for name, v in given:
            if not isinstance(name, str) or not name:
                raise PanelError("measure_range", "measures (names of columns) as its keys", name)
            w = _window(v)
            if w is None:
                raise PanelError(f"measure_range.{name}", _WINDOW + " (the measure's window)", v)
            pairs.append((name, w))
        object.__setattr__(self, "measure_range", tuple(pairs))

    @classmethod
    def from_dict(cls, d) -> ZoomWindow:
        """From the scene's mapping ``{range: [lo, hi], measure_range: {measure: [lo, hi]}}``."""
        if not isinstance(d, Mapping):
            raise PanelError("zoom", ZOOM_EXPECTED, d)
        for key in d:
            if key not in ("range", "measure_range"):
                raise PanelError(str(key), "one of the keys range, measure_range")
        if d.get("range") is None:
            raise PanelError("range", _WINDOW + " (the parameter's window; required)")
        ranges = d.get("measure_range")
        if ranges is not None and not isinstance(ranges, Mapping):
            raise PanelError("measure_range", "a mapping {measure: [lo, hi]}", ranges)
        return cls(d["range"], dict(ranges or {}))

    def limits(self, measure: str):
        """The y-limits ``(lo, hi)`` given for ``measure``, or None (fitted to the curves)."""
        return dict(self.measure_range).get(measure)
