"""Options of the continuation engine: :class:`ContinuationOptions` (validated on construction) and
:class:`Scaling`.

A frozen dataclass: :meth:`ContinuationOptions.replace` (or :func:`dataclasses.replace`) makes a
changed copy, :meth:`ContinuationOptions.from_dict` reads a configuration mapping and names the
closest valid option for a misspelt key.
"""

from __future__ import annotations

import dataclasses
import enum
import math
import numbers
from typing import Any, Mapping

import numpy as np

from contin.util.naming import is_real
from contin.util.options import check_keys, from_mapping

__all__ = ["DEFAULT_MAX_POINTS", "ContinuationOptions", "Scaling", "as_options"]

#: The cap on stored points when ``ContinuationOptions.max_points`` is not set; a branch stopped by
#: it did not do what it was asked (it ends with ``BranchStatus.DEFAULT_MAX_POINTS``, a shortfall).
DEFAULT_MAX_POINTS = 2000


class Scaling(str, enum.Enum):
    """Scaling of the variables.

    AUTO
        ``sl = hi - lo`` for a finite non-empty range, else ``max(|lam0|, 1)``;
        ``su = problem.unknown_scale()`` if available, else the single scalar
        ``||u_start||_inf`` (1 if the start is exactly zero, at least 1e-12)
        for all components.
    NONE
        ``su = 1``, ``sl = 1``.

    Explicit ``parameter_scale`` / ``unknown_scale`` options override both.
    """

    AUTO = "auto"
    NONE = "none"

    def __str__(self) -> str:
        return self.value


def _is_int(v) -> bool:
    """An integer, not a bool."""
    return isinstance(v, numbers.Integral) and not isinstance(v, bool)


@dataclasses.dataclass(frozen=True)
class ContinuationOptions:
    """Options of :func:`continuation` (validated; use :meth:`replace` or
    :func:`dataclasses.replace` for changes, :meth:`from_dict` for
    configuration files).

    Attributes
    ----------
    ds : float
        Initial step, in scaled arclength units.
    ds_min, ds_max : float
        Step bounds; the branch stops with ``STEP_TOO_SMALL`` below ``ds_min``.
    max_points : int or None
        Maximum number of stored points (including the start); a branch
        stopped there ends with ``MAX_POINTS``, as asked. None (the default):
        at most 2000 (:data:`DEFAULT_MAX_POINTS`), a cap nobody asked for: a
        branch stopped there ends with ``DEFAULT_MAX_POINTS``, a shortfall.
    newton_tol : float
        Tolerance on ``||R||_inf`` (unscaled residual).
    newton_max_iter : int
        Maximum Newton updates per corrector.
    newton_easy : int
        A step converging in at most this many updates lets ``ds`` grow.
    grow, shrink : float
        Step growth (>= 1) and shrink (in (0, 1)) factors.
    max_angle_deg : float
        Largest accepted angle between consecutive tangents (scaled
        coordinates); larger turns reject the step.
    direction : int
        +1 or -1: sign of ``dlam`` at the start (ignored if a start tangent
        is given).
    scaling : Scaling
        ``AUTO`` or ``NONE`` (strings accepted).
    parameter_scale : float or None
        Explicit ``sl``.
    unknown_scale : float, sequence of float, or None
        Explicit ``su`` (scalar or one value per unknown; stored as a tuple).
    locate_tol : float
        Relative tolerance on the parameter for event location.
    locate_max_iter : int
        Maximum solves per located event.
    detect_folds, detect_branch_points : bool
        Enable the built-in fold / branch-point events.
    corners : bool
        Accept a tangent jump that persists as the step shrinks by
        ``corner_ratio`` (a corner of a non-smooth branch) and record it as a
        ``kink`` special point; False stops the branch there instead.
    corner_ratio : float
        Step reduction (> 1) over which a turn must persist to be a corner.
    stall_points : int
        The branch stops with ``STEP_TOO_SMALL`` when this many consecutive
        stored points together advanced less than ``ds_max`` (a crawl at a
        point the steps cannot pass, for example a tangential contact).
    """

    ds: float = 0.02
    ds_min: float = 1e-8
    ds_max: float = 0.2
    max_points: int | None = None
    newton_tol: float = 1e-10
    newton_max_iter: int = 12
    newton_easy: int = 4
    grow: float = 1.5
    shrink: float = 0.5
    max_angle_deg: float = 20.0
    direction: int = 1
    scaling: Scaling = Scaling.AUTO
    parameter_scale: float | None = None
    unknown_scale: Any = None
    locate_tol: float = 1e-10
    locate_max_iter: int = 60
    detect_folds: bool = True
    detect_branch_points: bool = True
    corners: bool = True
    corner_ratio: float = 8.0
    stall_points: int = 50

    def __post_init__(self):
        def bad(field, requirement, value):
            raise ValueError(f"ContinuationOptions.{field} must be {requirement}, got {value!r}")

        def positive(field):
            v = getattr(self, field)
            if not is_real(v) or not (math.isfinite(v) and v > 0):
                bad(field, "a positive finite number", v)

        positive("ds")
        if not is_real(self.ds_min) or not (self.ds_min > 0 and self.ds_min <= self.ds):
            bad("ds_min", "positive and <= ds", self.ds_min)
        if not is_real(self.ds_max) or not (math.isfinite(self.ds_max) and self.ds_max >= self.ds):
            bad("ds_max", "finite and >= ds", self.ds_max)
        if self.max_points is not None and (not _is_int(self.max_points) or self.max_points < 1):
            bad("max_points", "None or an integer >= 1", self.max_points)
        if not _is_int(self.stall_points) or self.stall_points < 2:
            bad("stall_points", "an integer >= 2", self.stall_points)
        positive("newton_tol")
        if not _is_int(self.newton_max_iter) or self.newton_max_iter < 1:
            bad("newton_max_iter", "an integer >= 1", self.newton_max_iter)
        if not _is_int(self.newton_easy) or self.newton_easy < 0:
            bad("newton_easy", "an integer >= 0", self.newton_easy)
        if not is_real(self.grow) or not (math.isfinite(self.grow) and self.grow >= 1):
            bad("grow", "a finite number >= 1", self.grow)
        if not is_real(self.shrink) or not (0 < self.shrink < 1):
            bad("shrink", "in (0, 1)", self.shrink)
        if not is_real(self.max_angle_deg) or not (0 < self.max_angle_deg < 180):
            bad("max_angle_deg", "in (0, 180)", self.max_angle_deg)
        if not is_real(self.direction) or self.direction not in (1, -1):
            bad("direction", "+1 or -1", self.direction)
        try:
            scaling = Scaling(self.scaling.lower() if isinstance(self.scaling, str) else self.scaling)
        except ValueError:
            bad("scaling", "'auto' or 'none'", self.scaling)
        object.__setattr__(self, "scaling", scaling)
        if self.parameter_scale is not None:
            positive("parameter_scale")
            object.__setattr__(self, "parameter_scale", float(self.parameter_scale))
        if self.unknown_scale is not None:
            try:
                arr = np.asarray(self.unknown_scale, dtype=float)
            except (TypeError, ValueError):
                bad("unknown_scale", "None, a positive number or a sequence of positive numbers", self.unknown_scale)
            if arr.ndim > 1 or arr.size == 0 or not np.all(np.isfinite(arr)) or not np.all(arr > 0):
                bad("unknown_scale", "None, a positive number or a sequence of positive numbers", self.unknown_scale)
            value = float(arr) if arr.ndim == 0 else tuple(float(v) for v in arr)
            object.__setattr__(self, "unknown_scale", value)
        positive("locate_tol")
        if not _is_int(self.locate_max_iter) or self.locate_max_iter < 1:
            bad("locate_max_iter", "an integer >= 1", self.locate_max_iter)
        if not is_real(self.corner_ratio) or not (math.isfinite(self.corner_ratio) and self.corner_ratio > 1):
            bad("corner_ratio", "a finite number > 1", self.corner_ratio)
        for field in ("detect_folds", "detect_branch_points", "corners"):
            v = getattr(self, field)
            if not isinstance(v, (bool, np.bool_)):
                bad(field, "a bool", v)
            object.__setattr__(self, field, bool(v))
        for field in ("newton_max_iter", "newton_easy", "locate_max_iter", "direction", "stall_points"):
            object.__setattr__(self, field, int(getattr(self, field)))
        if self.max_points is not None:
            object.__setattr__(self, "max_points", int(self.max_points))
        for field in ("ds", "ds_min", "ds_max", "newton_tol", "grow", "shrink", "max_angle_deg", "locate_tol",
                      "corner_ratio"):
            object.__setattr__(self, field, float(getattr(self, field)))

    @classmethod
    def field_names(cls) -> list[str]:
        """The options' names, in declaration order."""
        return [f.name for f in dataclasses.fields(cls)]

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> "ContinuationOptions":
        """Build from a mapping (:func:`contin.util.options.from_mapping`); an unknown key raises
        ``ValueError`` naming it and the closest valid option."""
        return from_mapping(cls, d)

    @property
    def point_cap(self) -> int:
        """The number of stored points a branch stops at: ``max_points``, or :data:`DEFAULT_MAX_POINTS` if unset."""
        return DEFAULT_MAX_POINTS if self.max_points is None else self.max_points

    def replace(self, **changes) -> "ContinuationOptions":
        """Copy with some fields changed (validated, unknown names rejected)."""
        check_keys(type(self), changes)
        return dataclasses.replace(self, **changes)

    def to_dict(self) -> dict:
        """Plain values (``scaling`` as its string), the inverse of :meth:`from_dict`."""
        d = dataclasses.asdict(self)
        d["scaling"] = self.scaling.value
        return d


def as_options(options: ContinuationOptions | Mapping[str, Any] | None) -> ContinuationOptions:
    """The options of a run: the defaults for None, :meth:`ContinuationOptions.from_dict` for a mapping."""
    if options is None:
        return ContinuationOptions()
    if isinstance(options, Mapping):
        return ContinuationOptions.from_dict(options)
    if not isinstance(options, ContinuationOptions):
        raise TypeError(f"options must be ContinuationOptions or a mapping, got {type(options).__name__}")
    return options
