"""The grid of a parameter sweep: ``--grid`` axes, their values, and the points of their outer product.

:func:`parse_grid` reads a ``--grid dotted.key=SPEC`` option (a list of
values or a range) into a :class:`GridAxis`; :func:`grid_points` gives the
points of the outer product of the axes, each with its directory name and
its ``--set`` overrides (:class:`GridPoint`).
"""

from __future__ import annotations

import itertools
import math
import re
from dataclasses import dataclass, field

import numpy as np
import yaml

from contin.scene.schema import SceneError

__all__ = ["GridAxis", "GridPoint", "parse_grid", "grid_points", "RANGE_DIGITS", "MAX_GRID_POINTS"]

#: significant digits of the values of a range ``start:stop:count`` (``0:0.6:13`` gives 0.05 exactly as typed)
RANGE_DIGITS = 12
#: most points of a sweep, of one axis and of the outer product of all (each point is a whole run with its own
#: directory; the grid itself is made in memory before the first point runs)
MAX_GRID_POINTS = 100_000

_NAME_CHARS = re.compile(r"[^A-Za-z0-9._+=-]")


def _scalar(text: str, where: str):
    """A grid value from its text: an int, a float, true/false, or else the YAML scalar (a string)."""
    t = text.strip()
    if not t:
        raise SceneError(where, "a value between the commas", text)
    try:
        return int(t)
    except ValueError:
        pass
    try:
        v = float(t)
    except ValueError:
        pass
    else:
        if not math.isfinite(v):
            raise SceneError(where, "finite numbers", t)
        return v
    try:
        v = yaml.safe_load(t)
    except yaml.YAMLError:
        v = t
    if isinstance(v, (list, dict)) or v is None:
        raise SceneError(where, "scalar values (numbers, true/false or words) separated by commas", t)
    return v


def _yaml_text(value) -> str:
    """``value`` spelled so that ``yaml.safe_load`` gives it back exactly (for a ``--set`` override)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    text = yaml.safe_dump([value], default_flow_style=True).strip()
    text = text[1:-1].strip()  # drop the list brackets: the scalar in YAML flow style
    if yaml.safe_load(text) != value:  # pragma: no cover  (a guard: every scalar above round-trips)
        raise ValueError(f"cannot spell {value!r} in YAML")
    return text


def _plain(v):
    """numpy scalars as Python ones (so that they spell as YAML)."""
    if isinstance(v, np.bool_):
        return bool(v)
    if isinstance(v, np.integer):
        return int(v)
    if isinstance(v, np.floating):
        return float(v)
    return v


@dataclass(frozen=True)
class GridAxis:
    """One ``--grid`` axis: a dotted scene key and the values it takes.

    Attributes
    ----------
    key : str
        Dotted scene key, as for ``--set`` (``model.parameters.F``).
    values : tuple
        Distinct scalar values (numbers, booleans or strings), in order.
    """

    key: str
    values: tuple
    #: the ``SPEC`` the axis was read from (``0:1:11``), if any; not part of its identity
    text: str | None = field(default=None, compare=False, repr=False)

    def __post_init__(self):
        where = f"--grid {self.key}"
        if not isinstance(self.key, str) or not self.key or any(not p.strip() for p in self.key.split(".")) \
                or self.key != self.key.strip() or "=" in self.key:
            raise SceneError("--grid", "dotted.key=SPEC with a dotted scene key such as model.parameters.F", self.key)
        if not isinstance(self.values, tuple) or not self.values:
            raise SceneError(where, "at least one value", self.values)
        if len(self.values) > MAX_GRID_POINTS:
            raise SceneError(where, f"at most {MAX_GRID_POINTS} values", f"{len(self.values)} values")
        object.__setattr__(self, "values", tuple(_plain(v) for v in self.values))
        for v in self.values:
            if not isinstance(v, (int, float, str, bool)) or (isinstance(v, float) and not math.isfinite(v)):
                raise SceneError(where, "finite numbers, true/false or words", v)
        seen = set()
        for v in self.values:
            token = (type(v) is bool, v)
            if token in seen:
                raise SceneError(where, "distinct values (each point is run once)", v)
            seen.add(token)

    def override(self, value) -> str:
        """The ``--set`` assignment of ``value`` on this axis."""
        return f"{self.key}={_yaml_text(value)}"

    def option(self) -> str:
        """The ``--grid`` argument that gives this axis back: ``key=SPEC`` as typed, else the list of values."""
        if self.text is not None:
            return f"{self.key}={self.text}"
        return f"{self.key}=" + ",".join(_yaml_text(v) for v in self.values)


def parse_grid(text: str) -> GridAxis:
    """Parse a ``--grid`` option ``dotted.key=SPEC``.

    SPEC is either a list ``v1,v2,...`` (numbers, ``true``/``false`` or words,
    each value at most once) or a range ``start:stop:count`` of ``count >= 2``
    equally spaced numbers from ``start`` to ``stop`` inclusive (rounded to
    12 significant digits, so ``0:0.6:13`` gives 0, 0.05, ..., 0.6 as typed).
    A single value is a list of one. An axis has at most :data:`MAX_GRID_POINTS`
    values.

    Raises
    ------
    SceneError
        Naming ``--grid`` (and the key), what was expected and what was found.
    """
    if not isinstance(text, str) or "=" not in text:
        raise SceneError("--grid", "dotted.key=SPEC, for example model.parameters.F=0.1,0.2,0.5 "
                         "or model.parameters.F=0:0.6:13", text)
    key, _, spec = text.partition("=")
    key = key.strip()
    if not key or any(not p.strip() for p in key.split(".")):
        raise SceneError("--grid", "dotted.key=SPEC with a dotted scene key such as model.parameters.F", text)
    where = f"--grid {key}"
    spec = spec.strip()
    if not spec:
        raise SceneError(where, "a list v1,v2,... or a range start:stop:count after '='", spec)
    if ":" in spec:
        parts = spec.split(":")
        if len(parts) != 3 or "," in spec:
            raise SceneError(where, "a range start:stop:count (three numbers separated by colons)", spec)
        try:
            start, stop = float(parts[0]), float(parts[1])
        except ValueError:
            raise SceneError(where, "a range start:stop:count whose start and stop are numbers", spec) from None
        try:
            count = int(parts[2])
        except ValueError:
            raise SceneError(where, "a range start:stop:count whose count is an integer", spec) from None
        if not (math.isfinite(start) and math.isfinite(stop)):
            raise SceneError(where, "a range with finite start and stop", spec)
        if count < 2:
            raise SceneError(where, "a range start:stop:count with a count of at least 2", spec)
        if count > MAX_GRID_POINTS:  # refused before its values are made
            raise SceneError(where, f"a range start:stop:count with a count of at most {MAX_GRID_POINTS}",
                             f"{count} values")
        if start == stop:
            raise SceneError(where, "a range start:stop:count with start different from stop", spec)
        values = tuple(float(f"{start + (stop - start) * i / (count - 1):.{RANGE_DIGITS}g}") for i in range(count))
        values = values[:-1] + (stop,)
        if len(set(values)) != len(values):
            raise SceneError(where, f"a range whose {count} values differ in {RANGE_DIGITS} significant digits", spec)
        return GridAxis(key, values, spec)
    if spec.count(",") >= MAX_GRID_POINTS:
        raise SceneError(where, f"a list of at most {MAX_GRID_POINTS} values", f"{spec.count(',') + 1} values")
    return GridAxis(key, tuple(_scalar(t, where) for t in spec.split(",")), spec)


def _label(value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return f"{value:.12g}"
    return str(value)


@dataclass(frozen=True)
class GridPoint:
    """A point of the grid: its position, values, directory name and ``--set`` overrides."""

    index: int
    values: tuple  # ((key, value), ...) in axis order
    name: str
    overrides: tuple

    @property
    def label(self) -> str:
        return " ".join(f"{k.rsplit('.', 1)[-1]}={_label(v)}" for k, v in self.values)


def grid_points(axes) -> list[GridPoint]:
    """The outer product of the axes, first axis slowest.

    Directory names spell the values (``F=0.3__c=0.1``, with the last part of
    each key, or the full key where two axes share it), so extending a grid
    keeps the names of the points already computed; if two points would share
    a name, or a name would be unreasonably long, the points are named
    ``p0000``, ``p0001``, ... instead.

    Raises
    ------
    SceneError
        For more than :data:`MAX_GRID_POINTS` points.
    """
    axes = tuple(axes)
    sizes = [len(a.values) for a in axes]
    if math.prod(sizes) > MAX_GRID_POINTS:  # counted before a point is made
        raise SceneError("--grid", f"a grid of at most {MAX_GRID_POINTS} points (the outer product of the axes)",
                         f"{math.prod(sizes)} points ({' x '.join(map(str, sizes))})")
    short = [a.key.rsplit(".", 1)[-1] for a in axes]
    names = [s if short.count(s) == 1 else a.key for s, a in zip(short, axes)]
    points = []
    for i, combo in enumerate(itertools.product(*(a.values for a in axes))):
        name = "__".join(_NAME_CHARS.sub("~", f"{n}={_label(v)}") for n, v in zip(names, combo))
        points.append(GridPoint(i, tuple((a.key, v) for a, v in zip(axes, combo)), name,
                                tuple(a.override(v) for a, v in zip(axes, combo))))
    taken = [p.name for p in points]
    if len(set(taken)) != len(taken) or max(map(len, taken)) > 160 or any(n.startswith(".") for n in taken):
        width = max(4, len(str(len(points) - 1)))
        points = [GridPoint(p.index, p.values, f"p{p.index:0{width}d}", p.overrides) for p in points]
    return points
