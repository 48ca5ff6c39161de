"""Matrix coefficients that are B-splines of one parameter (speed-dependent bearing coefficients).

A :class:`contin.model.base.ParametricMatrix` sums ``coefficient(p) * A``
over its terms; a coefficient gives ``value(p)``, ``derivative(p, k)`` and
``depends_on(k)`` (the interface of :class:`contin.model.base.Monomial`).
:class:`SplineCoefficient` is ``scale * s(arg_scale * p[index])`` with ``s``
a B-spline, the form in which ROSS interpolates bearing coefficients over the
speed (``scipy.interpolate.UnivariateSpline``, or a polynomial through two or
three points): the bridge stores ROSS's own spline, so that the coefficients
are ROSS's at every speed, not only at its table's.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.interpolate import BSpline

__all__ = ["SplineCoefficient", "spline_of"]


@dataclass(frozen=True, eq=False)
class SplineCoefficient:
    """``scale * s(arg_scale * p[index])``, ``s`` the B-spline ``(knots, coeffs, degree)`` (extrapolated).

    Parameters
    ----------
    index : int
        Parameter the spline is a function of.
    knots : ndarray, shape (m + degree + 1,)
    coeffs : ndarray, shape (m,)
    degree : int
    scale : float
        Factor on the value (unit scaling).
    arg_scale : float
        Factor on the argument (the speed unit in rad/s).
    name : str
        What the coefficient is, for descriptions (``kxx of bearing 1``).
    """

    index: int
    knots: np.ndarray
    coeffs: np.ndarray
    degree: int
    scale: float = 1.0
    arg_scale: float = 1.0
    name: str = "spline"
    _spl: BSpline = field(init=False, repr=False)
    _der: BSpline | None = field(init=False, repr=False)

    def __post_init__(self):
        spl = BSpline(np.asarray(self.knots, float), np.asarray(self.coeffs, float), int(self.degree), extrapolate=True)
        object.__setattr__(self, "_spl", spl)
        object.__setattr__(self, "_der", spl.derivative() if self.degree > 0 else None)

    def value(self, p: np.ndarray) -> float:
        return float(self.scale * self._spl(self.arg_scale * p[self.index]))

    def derivative(self, p: np.ndarray, k: int) -> float:
        if k != self.index or self._der is None:
            return 0.0
        return float(self.scale * self.arg_scale * self._der(self.arg_scale * p[self.index]))

    def depends_on(self, k: int) -> bool:
        return k == self.index and self._der is not None

    def text(self, names) -> str:
        return f"{self.scale:g}*{self.name}({names[self.index]})"


def spline_of(interpolant, what: str = "coefficient"):
    """The ``(knots, coeffs, degree)`` of a ROSS coefficient interpolant.

    Parameters
    ----------
    interpolant : scipy.interpolate.UnivariateSpline or scipy.interpolate.interp1d
        ROSS builds a smoothing spline (four or more table points), a line or
        parabola through two or three points, or a constant.

    Returns
    -------
    knots, coeffs : ndarray
    degree : int

    Raises
    ------
    ValueError
        For another interpolant, naming ``what``.
    """
    from scipy.interpolate import UnivariateSpline, interp1d, make_interp_spline

    if isinstance(interpolant, UnivariateSpline):
        t, c, k = interpolant._eval_args
        m = len(t) - k - 1
        return np.array(t, float), np.array(c[:m], float), int(k)
    if isinstance(interpolant, interp1d):
        x, y = np.asarray(interpolant.x, float), np.asarray(interpolant.y, float)
        if np.all(y == y[0]):
            return np.array([x[0], x[-1]]), np.array([y[0]]), 0
        if interpolant._kind == "spline":  # an integer kind: scipy keeps the B-spline it built
            spl = interpolant._spline
        else:
            k = {"linear": 1, "quadratic": 2, "cubic": 3}.get(interpolant._kind)
            if k is None or len(x) != k + 1:
                raise ValueError(f"{what}: an interpolant of kind {interpolant._kind!r} through {len(x)} points "
                                 "is not a polynomial; expected ROSS's smoothing spline or a polynomial through 2-3 "
                                 "points")
            spl = make_interp_spline(x, y, k=k)
        return np.array(spl.t, float), np.asarray(spl.c, float).reshape(-1), int(spl.k)
    raise ValueError(f"{what}: unsupported interpolant {type(interpolant).__name__}; expected ROSS's "
                     "UnivariateSpline or interp1d")
