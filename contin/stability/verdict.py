"""The Floquet multipliers of one periodic solution and its stability verdict.

A periodic solution of period ``T = 2 pi nu / w`` is asymptotically stable
when every Floquet multiplier lies inside the unit circle. Numerically, a
multiplier counts as *unstable* when ``|mu| > 1 + tolerance``. The margin is
needed because multipliers of conservative or lightly damped systems sit on
the unit circle: for the undamped Mathieu equation ``mu1 mu2 = det Phi = 1``
(Liouville), so in the stable regions both multipliers have ``|mu| = 1`` up to
rounding (and up to the ``O(h^4)`` drift of the non-symplectic RK4). Near a
tongue boundary ``|mu| - 1`` grows like ``sqrt(distance)``, so a margin
``tol`` shifts the detected boundary by only ``O(tol^2)`` in the parameter.

Unstable multipliers are counted by where they leave the circle:
``n_plus`` (real positive, within ``real_angle_tol`` of the positive real axis),
``n_minus`` (real negative) and ``n_complex`` (the rest, in conjugate pairs).
Their sum is ``n_unstable``. A change of one count between two points of a
branch is a bifurcation of the corresponding type:

======================  =========================  ===========================
count that changes      multiplier crosses at      special point
======================  =========================  ===========================
``n_plus``              +1                         ``fold`` if the parameter
                                                   component of the tangent
                                                   changes sign, else ``bp``
``n_minus``             -1                         ``pd`` (period doubling)
``n_complex``           a complex pair             ``ns`` (Neimark-Sacker)
======================  =========================  ===========================

(Kuznetsov, *Elements of Applied Bifurcation Theory*, 3rd ed., Springer 2004,
ch. 9; Seydel, *Practical Bifurcation and Stability Analysis*, 3rd ed.,
Springer 2010, sec. 7.4.) The events that locate such changes are in
:mod:`contin.stability.events`.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from contin.stability.options import StabilityMethod, StabilityOptions

__all__ = ["FloquetResult", "classify_multipliers", "floquet_result", "log_exponents", "monodromy_result",
           "unevaluated_data"]


@dataclasses.dataclass(frozen=True, eq=False)
class FloquetResult:
    """Floquet multipliers of one periodic solution and the stability verdict.

    Attributes
    ----------
    multipliers : ndarray, shape (2n,) complex
        Sorted by decreasing modulus (then by argument).
    exponents : ndarray, shape (2n,) complex
        Floquet exponents ``s`` with ``multipliers = exp(s T)`` (Hill: the
        selected eigenvalues; monodromy: ``log(mu) / T``, principal branch).
    stable : bool
    n_unstable : int
        Multipliers with ``|mu| > 1 + tolerance``.
    n_plus, n_minus, n_complex : int
        Unstable ones that are real positive, real negative, complex.
    max_multiplier : float
        ``max |mu|``.
    method : StabilityMethod
        Method whose multipliers are reported (HILL or FLOQUET).
    period : float
    ambiguous : bool
        Hill's selection was unclear (quality below the threshold).
    quality : float
        Hill's selection quality in ``[0, 1]`` (NaN without Hill).
    confirmed : bool
        The monodromy was computed to check Hill (method BOTH).
    disagreement : bool
        Hill and the monodromy gave different counts; the monodromy's are
        reported.
    marginal : bool
        The disagreement is explained by a multiplier lying on the stability
        threshold within the two methods' discrepancy, itself small
        (``<= 1e-3``): expected right at a bifurcation. False for a
        disagreement that is not.
    fallback : bool
        Hill's multipliers, close to ``+1`` or ``-1``, differed from the
        monodromy's by more than ``StabilityOptions.agreement`` (whatever
        the counts); the monodromy's are reported.
    gap : float
        The multiplier distance between the two methods when both were
        computed (NaN otherwise).
    hill_multipliers, monodromy_multipliers : ndarray (2n,) complex or None
        Each method's multipliers when computed.
    eigenvectors : ndarray, shape (m, 2n) complex, or None
        Hill's coefficient-space eigenvectors, ordered like ``multipliers``
        (only when Hill's multipliers are reported).
    tolerance, real_angle_tol : float
        The margins used for the verdict and the classification.
    """

    multipliers: np.ndarray
    exponents: np.ndarray
    stable: bool
    n_unstable: int
    n_plus: int
    n_minus: int
    n_complex: int
    max_multiplier: float
    method: StabilityMethod
    period: float
    ambiguous: bool = False
    quality: float = float("nan")
    confirmed: bool = False
    disagreement: bool = False
    marginal: bool = False
    fallback: bool = False
    gap: float = float("nan")
    hill_multipliers: np.ndarray | None = None
    monodromy_multipliers: np.ndarray | None = None
    eigenvectors: np.ndarray | None = None
    tolerance: float = 1e-6
    real_angle_tol: float = 1e-4

    @property
    def counts(self) -> tuple[int, int, int]:
        """``(n_plus, n_minus, n_complex)``."""
        return (self.n_plus, self.n_minus, self.n_complex)

    def critical(self, crossing: str | None = None) -> int:
        """Index of the multiplier closest to the unit circle (``|log|mu||``).

        Parameters
        ----------
        crossing : {'+1', '-1', 'complex'}, optional
            Restrict to real positive, real negative, or complex multipliers
            (with ``Im mu >= 0``); falls back to all if none qualifies.
        """
        mu = self.multipliers
        ang = np.abs(np.angle(mu))
        tol = self.real_angle_tol
        if crossing == "+1":
            mask = ang <= tol
        elif crossing == "-1":
            mask = ang >= np.pi - tol
        elif crossing == "complex":
            mask = (ang > tol) & (ang < np.pi - tol) & (mu.imag >= 0)
        else:
            mask = np.ones(mu.shape, dtype=bool)
        if not mask.any():
            mask = np.ones(mu.shape, dtype=bool)
        dist = np.abs(np.log(np.maximum(np.abs(mu), 1e-300)))
        dist = np.where(mask, dist, np.inf)
        return int(np.argmin(dist))

    def monitor_data(self) -> dict:
        """Values stored per branch point by :class:`~contin.stability.monitor.StabilityMonitor` (``evaluated`` True).

        A point where no verdict can be made gets :func:`unevaluated_data` instead.
        """
        return {
            "evaluated": True,
            "stable": bool(self.stable),
            "n_unstable": int(self.n_unstable),
            "n_plus": int(self.n_plus),
            "n_minus": int(self.n_minus),
            "n_complex": int(self.n_complex),
            "max_multiplier": float(self.max_multiplier),
            "multipliers": np.asarray(self.multipliers, dtype=complex),
            "ambiguous": bool(self.ambiguous),
            "hill_quality": float(self.quality) if np.isfinite(self.quality) else -1.0,
            "confirmed": bool(self.confirmed),
            "disagreement": bool(self.disagreement and not self.marginal),
            "marginal_disagreement": bool(self.disagreement and self.marginal),
            "hill_fallback": bool(self.fallback),
        }


def unevaluated_data(size: int) -> dict:
    """The monitored values of a point without a stability verdict: the keys of :meth:`FloquetResult.monitor_data`.

    Every value is finite (a branch stores no others): ``evaluated`` and
    ``stable`` False, the counts ``n_unstable``, ``n_plus``, ``n_minus``,
    ``n_complex`` -1, ``max_multiplier`` 0, ``multipliers`` zeros (``size``
    of them, as at the other points), ``hill_quality`` -1 (as without
    Hill) and the flags False.
    """
    return {
        "evaluated": False,
        "stable": False,
        "n_unstable": -1,
        "n_plus": -1,
        "n_minus": -1,
        "n_complex": -1,
        "max_multiplier": 0.0,
        "multipliers": np.zeros(int(size), dtype=complex),
        "ambiguous": False,
        "hill_quality": -1.0,
        "confirmed": False,
        "disagreement": False,
        "marginal_disagreement": False,
        "hill_fallback": False,
    }


def classify_multipliers(multipliers: np.ndarray, tolerance: float = 1e-6, real_angle_tol: float = 1e-4):
    """Count the unstable multipliers by type.

    Parameters
    ----------
    multipliers : ndarray, shape (2n,) complex
    tolerance : float
        ``|mu| > 1 + tolerance`` is unstable.
    real_angle_tol : float
        Angle (radians) from the real axis within which ``mu`` counts as real.

    Returns
    -------
    n_plus, n_minus, n_complex : int
    """
    mu = np.asarray(multipliers, dtype=complex)
    out = np.abs(mu) > 1.0 + tolerance
    ang = np.abs(np.angle(mu))
    plus = out & (ang <= real_angle_tol)
    minus = out & (ang >= np.pi - real_angle_tol)
    cplx = out & ~plus & ~minus
    return int(plus.sum()), int(minus.sum()), int(cplx.sum())


def _sort_order(mu: np.ndarray) -> np.ndarray:
    # decreasing modulus; ties by argument, so that conjugates are adjacent
    return np.lexsort((np.angle(mu), -np.round(np.abs(mu), 12)))


def floquet_result(mu, ex, method, period, options, **extra) -> FloquetResult:
    order = _sort_order(mu)
    mu = mu[order]
    ex = ex[order]
    vecs = extra.pop("eigenvectors", None)
    if vecs is not None:
        vecs = vecs[:, order]
    counts = classify_multipliers(mu, options.tolerance, options.real_angle_tol)
    n_unstable = sum(counts)
    res = FloquetResult(
        multipliers=mu,
        exponents=ex,
        stable=n_unstable == 0,
        n_unstable=n_unstable,
        n_plus=counts[0],
        n_minus=counts[1],
        n_complex=counts[2],
        max_multiplier=float(np.abs(mu).max()) if mu.size else 0.0,
        method=method,
        period=period,
        eigenvectors=vecs,
        tolerance=options.tolerance,
        real_angle_tol=options.real_angle_tol,
        **extra,
    )
    return res


def monodromy_result(mu: np.ndarray, period: float, options: StabilityOptions | None = None) -> FloquetResult:
    """The verdict from a monodromy's multipliers computed elsewhere (e.g. of an integrated flow).

    Parameters
    ----------
    mu : ndarray, shape (2n,) complex
        Eigenvalues of the monodromy matrix.
    period : float
        The orbit's period (for the exponents ``log(mu) / period``).
    options : StabilityOptions, optional
        Supplies ``tolerance`` and ``real_angle_tol``.
    """
    options = StabilityOptions() if options is None else options
    mu = np.asarray(mu, dtype=complex)
    return floquet_result(mu, log_exponents(mu, period), StabilityMethod.FLOQUET, period, options,
                   monodromy_multipliers=mu.copy())


def log_exponents(mu: np.ndarray, period: float) -> np.ndarray:
    """Principal-branch exponents ``log(mu) / T`` (a zero multiplier gives ``-inf``)."""
    with np.errstate(divide="ignore"):
        lg = np.log(mu.astype(complex))
    out = np.empty_like(lg)
    out.real, out.imag = lg.real / period, lg.imag / period  # parts apart: -inf / T in complex division is nan
    return out
