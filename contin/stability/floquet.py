"""Floquet multipliers, stability verdicts, and the stability monitor and events.

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
Springer 2010, sec. 7.4.)

Location accuracy
-----------------
The events locate where a count changes, i.e. where ``|mu| = 1 + tolerance``.
For a transversal crossing that is ``tolerance / |d|mu|/dlambda|`` away from
the bifurcation (about 1e-8 in delta for the damped Mathieu tests, but it
grows where the multiplier moves slowly with the parameter); for the
tangential crossings of conservative systems it is ``O(tolerance^2)``. With
Hill's method alone the margin can be lowered to about 1e-9 for dissipative
systems; the RK4 monodromy needs a margin above its drift
``~ (w_eff h)^4 T / 120``. The engine's own branch-point test (sign of the
bordered determinant) is exact and is preferred by
:func:`contin.bifurcation.switching.follow` when both report the same point.

Verdicts are those of the harmonic-balance orbit: with too few harmonics the
HB orbit and its stability can both be wrong. Method BOTH exposes this where
Hill's verdict changes (the monodromy integrates the exact variational
equations along the orbit, not the truncated Hill problem).
"""

from __future__ import annotations

import dataclasses
import enum
import math
import warnings
from typing import Any, Mapping

import numpy as np

from contin.engine.branch import SpecialKind
from contin.engine.events import OVERSHOOT, Event, FunctionEvent, Location, PointInfo, locate, narrow, predicted_zero
from contin.util.naming import is_real, suggest
from contin.stability.hill import hill_spectrum
from contin.engine.newton import NUMERICAL_ERRORS
from contin.stability.monodromy import monodromy_orbit_ivp, monodromy_reference, monodromy_rk4, switching_events
from contin.stability.rk4 import RK4StepError
from contin.stability.saltation import _frequency, _switching_elements

__all__ = [
    "StabilityMethod",
    "StabilityOptions",
    "FloquetResult",
    "classify_multipliers",
    "floquet_multipliers",
    "monodromy_result",
    "StabilityMonitor",
    "MultiplierCrossingEvent",
    "StabilityChangeEvent",
    "stability_events",
    "describe_crossing",
    "multiplier_distance",
    "multiplier_step_limit",
    "unevaluated_data",
]


class StabilityMethod(str, enum.Enum):
    """How Floquet multipliers are computed.

    HILL
        Hill's method in coefficient space (:mod:`contin.stability.hill`).
    FLOQUET
        Monodromy matrix by time integration (:mod:`contin.stability.monodromy`).
    BOTH
        Hill everywhere; the monodromy confirms every point where Hill's
        verdict changes from the previous point, the first point, and every
        point where Hill's selection is ambiguous. On disagreement the
        monodromy verdict is used and the result is flagged. Where the orbit
        crosses a switching surface at which the force law jumps (an impact
        with contact damping), Hill's matrices, built from the sampled
        Jacobian, miss the jump (the saltation), so the monodromy's
        multipliers are reported there.
    NONE
        No stability computation.
    """

    HILL = "hill"
    FLOQUET = "floquet"
    BOTH = "both"
    NONE = "none"

    def __str__(self) -> str:
        return self.value


_METHOD_ALIASES = {"monodromy": "floquet", "shooting": "floquet", "off": "none"}
_INTEGRATORS = ("rk4", "dop853")


@dataclasses.dataclass(frozen=True)
class StabilityOptions:
    """Options of the stability analysis (validated on construction).

    Attributes
    ----------
    method : StabilityMethod or str
        ``"hill"``, ``"floquet"`` (alias ``"monodromy"``), ``"both"`` or ``"none"``.
    steps_per_period : int
        RK4 steps per period for the monodromy (``>= 8``; at least ``H+1``
        is enforced when used). Smooth forces: error ``O((w_max T/S)^4)``;
        piecewise-linear forces: ``O(1/S)``. Where the step is beyond RK4's
        stability limit for the stiffest mode along the orbit (a stiff
        contact), the monodromy takes more steps (``max_steps_per_period``).
    tolerance : float
        Relative unit-circle margin: ``|mu| > 1 + tolerance`` is unstable.
        In ``(0, 0.1]``.
    real_angle_tol : float
        A multiplier within this angle (radians) of the real axis counts as
        real (for the ``+1`` / ``-1`` classification). In ``(0, 0.1]``.
    ambiguity_threshold : float
        Hill selections with a quality below this are ``ambiguous``. In ``[0, 1]``.
    shift_tol : float
        Relative tolerance (units of ``Omega``) for recognising two Hill
        eigenvalues as shifts ``s + i k Omega`` of each other. In ``(0, 0.1]``.
    integrator : str
        Monodromy integrator: ``"rk4"`` (compiled, fixed step) or ``"dop853"``
        (scipy reference, slow).
    rtol : float
        Relative tolerance of the ``"dop853"`` integrator.
    eigenvectors : bool
        Keep Hill's coefficient-space eigenvectors in the results (and, with
        method ``floquet``, compute Hill's critical eigenvector at located
        stability changes; the other methods always do).
    unit_check : float
        Method BOTH: when a Hill multiplier lies within this distance of
        ``+1`` or ``-1`` (where a fold, branch point or period doubling is
        near, and where Hill's selection of the physical exponents among
        their shifts is hardest), the monodromy is computed too and the two
        multiplier sets are compared. In ``[0, 2]``; 0 disables the check.
    agreement : float
        Largest multiplier distance (:func:`multiplier_distance`) between
        Hill and the monodromy accepted by that check; beyond it the
        monodromy's multipliers are used (``fallback``). In ``(0, 1]``.
    max_steps_per_period : int
        Most RK4 steps per period the monodromy takes of itself (``>= 8``).
        Where ``steps_per_period`` is too large a step for the stiffest
        eigenvalue of ``A`` along the orbit, it integrates again with the
        steps that eigenvalue needs (measured at every node of the orbit,
        with a 5% margin, rounded up to a fast FFT length), as long as they
        are at most this (or ``steps_per_period`` if larger); beyond it the
        adaptive integration of the variational equations
        (:func:`contin.stability.monodromy_orbit_ivp`, DOP853 at ``rtol``)
        is used if its estimated cost is within :data:`IVP_FALLBACK_EVALUATIONS`
        right-hand sides, else the point gets no verdict (see
        :class:`StabilityMonitor`). The refined steps make RK4 stable on the
        stiffest mode, not accurate there (it damps it artificially): for
        accurate multipliers choose ``steps_per_period`` with
        ``|eigenvalue| T / steps_per_period`` about 1 or less.
    """

    method: StabilityMethod = StabilityMethod.BOTH
    steps_per_period: int = 512
    tolerance: float = 1e-6
    real_angle_tol: float = 1e-4
    ambiguity_threshold: float = 0.25
    shift_tol: float = 1e-4
    integrator: str = "rk4"
    rtol: float = 1e-11
    eigenvectors: bool = False
    unit_check: float = 0.1
    agreement: float = 1e-2
    max_steps_per_period: int = 32768

    def __post_init__(self):
        def bad(name, requirement, value):
            raise ValueError(f"StabilityOptions.{name} must be {requirement}, got {value!r}")

        m = self.method
        if isinstance(m, str) and not isinstance(m, StabilityMethod):
            key = _METHOD_ALIASES.get(m.lower(), m.lower())
            valid = [e.value for e in StabilityMethod]
            if key not in valid:
                raise ValueError(
                    f"StabilityOptions.method: unknown method {m!r}{suggest(m.lower(), valid + list(_METHOD_ALIASES))}; "
                    f"expected one of {valid}"
                )
            m = StabilityMethod(key)
        if not isinstance(m, StabilityMethod):
            bad("method", "a StabilityMethod or one of 'hill', 'floquet', 'both', 'none'", m)
        object.__setattr__(self, "method", m)
        for name in ("steps_per_period", "max_steps_per_period"):
            s = getattr(self, name)
            if isinstance(s, (bool, np.bool_)) or not isinstance(s, (int, np.integer)) or s < 8:
                bad(name, "an integer >= 8", s)
            object.__setattr__(self, name, int(s))
        for name, lo, hi, lo_open in (
            ("tolerance", 0.0, 0.1, True),
            ("real_angle_tol", 0.0, 0.1, True),
            ("ambiguity_threshold", 0.0, 1.0, False),
            ("shift_tol", 0.0, 0.1, True),
            ("rtol", 0.0, 1e-3, True),
            ("unit_check", 0.0, 2.0, False),
            ("agreement", 0.0, 1.0, True),
        ):
            v = getattr(self, name)
            ok = is_real(v) and math.isfinite(v) and (v > lo if lo_open else v >= lo) and v <= hi
            if not ok:
                bad(name, f"a number in {'(' if lo_open else '['}{lo:g}, {hi:g}]", v)
            object.__setattr__(self, name, float(v))
        if self.integrator not in _INTEGRATORS:
            raise ValueError(
                f"StabilityOptions.integrator: unknown integrator {self.integrator!r}"
                f"{suggest(str(self.integrator), _INTEGRATORS)}; expected one of {list(_INTEGRATORS)}"
            )
        if not isinstance(self.eigenvectors, (bool, np.bool_)):
            bad("eigenvectors", "a bool", self.eigenvectors)
        object.__setattr__(self, "eigenvectors", bool(self.eigenvectors))

    @classmethod
    def field_names(cls) -> list[str]:
        return [f.name for f in dataclasses.fields(cls)]

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> "StabilityOptions":
        """Build from a mapping; unknown keys raise ``ValueError`` with a suggestion."""
        names = cls.field_names()
        for key in d:
            if key not in names:
                raise ValueError(f"StabilityOptions: unknown option {key!r}{suggest(str(key), names)}; expected one of {names}")
        return cls(**dict(d))

    def replace(self, **changes) -> "StabilityOptions":
        """Copy with changed fields (validated; unknown names rejected)."""
        names = self.field_names()
        for key in changes:
            if key not in names:
                raise ValueError(f"StabilityOptions: unknown option {key!r}{suggest(str(key), names)}; expected one of {names}")
        return dataclasses.replace(self, **changes)

    def to_dict(self) -> dict:
        d = dataclasses.asdict(self)
        d["method"] = self.method.value
        return d


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
        """Values stored per branch point by :class:`StabilityMonitor` (``evaluated`` True).

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


def _result(mu, ex, method, period, options, **extra) -> FloquetResult:
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
    return _result(mu, _log_exponents(mu, period), StabilityMethod.FLOQUET, period, options,
                   monodromy_multipliers=mu.copy())


def _log_exponents(mu: np.ndarray, period: float) -> np.ndarray:
    """Principal-branch exponents ``log(mu) / T`` (a zero multiplier gives ``-inf``)."""
    with np.errstate(divide="ignore"):
        return np.log(mu.astype(complex)) / period


#: Largest estimated cost, in right-hand sides, of the adaptive integration used where RK4 would need
#: more than ``max_steps_per_period`` steps (about a second or two of the Python right-hand side)
IVP_FALLBACK_EVALUATIONS = 20000
#: Right-hand sides DOP853 takes per radian of the stiffest mode (``int |eigenvalue| dt`` over the
#: period) at tolerances near 1e-10: measured 25 for a light mass on a stiff spring
_IVP_EVALUATIONS_PER_RADIAN = 30.0


def _monodromy(hb, u, lam, options):
    """The monodromy of ``options``: RK4 with its steps refined up to the cap, else the adaptive fallback.

    Raises
    ------
    ArithmeticError
        Neither can be made at this point (the message says why).
    """
    if options.integrator == "dop853":
        return monodromy_reference(hb, u, lam, rtol=options.rtol, atol=options.rtol * 0.1)
    steps = max(options.steps_per_period, hb.H + 1)
    try:
        return monodromy_rk4(hb, u, lam, steps, max_steps=max(options.max_steps_per_period, steps))
    except RK4StepError as exc:
        return _adaptive_monodromy(hb, u, lam, options, steps, exc)


def _adaptive_monodromy(hb, u, lam, options, steps, exc):
    """:func:`monodromy_orbit_ivp` where RK4 needs more steps than allowed, if affordable."""
    phase = exc.phase if math.isfinite(exc.phase) else exc.rate * 2.0 * np.pi / _frequency(hb, lam)
    cost = _IVP_EVALUATIONS_PER_RADIAN * phase
    if not cost <= IVP_FALLBACK_EVALUATIONS:
        raise ArithmeticError(f"{exc} (the adaptive integration would take about {cost:.2g} right-hand sides, "
                              f"more than {IVP_FALLBACK_EVALUATIONS})") from None
    try:
        return monodromy_orbit_ivp(hb, u, lam, rtol=options.rtol, atol=options.rtol * 0.1, samples=2 * steps)
    except ArithmeticError as exc2:
        raise ArithmeticError(f"{exc}; the adaptive integration failed as well ({exc2})") from None


def _force_jumps(hb, u, lam, options) -> bool:
    """Whether the HB orbit crosses a switching surface where the force law jumps.

    Hill's matrices come from the Jacobian sampled on the orbit, which cannot
    hold the contribution of a jump (a delta function at the surface, which the
    saltation matrix carries in the monodromy): at such orbits Hill's
    multipliers are wrong whatever ``H`` (e.g. 0.27 off for a clipped
    clearance oscillator, ``tests/stability/test_saltation.py``).
    """
    if not _switching_elements(hb.model):
        return False
    try:
        events = switching_events(hb, u, lam, 2 * max(options.steps_per_period, hb.H + 1))
    except ArithmeticError:
        return True  # a grazing switch with a jump
    return any(np.abs(e.saltation - np.eye(e.saltation.shape[0])).max() > 0.0 for e in events)


def floquet_multipliers(hb, u: np.ndarray, lam: float, options: StabilityOptions | None = None, *, previous=None) -> FloquetResult:
    """Floquet multipliers and stability of an HB solution.

    Method BOTH computes Hill's multipliers and confirms them with the
    monodromy when Hill's selection is ambiguous, when ``previous`` is None
    (first point of a branch) or when Hill's counts differ from
    ``previous``. If the two verdicts (counts ``(n_plus, n_minus,
    n_complex)``) differ, the monodromy's multipliers are reported with
    ``disagreement=True`` (``marginal=True`` when a multiplier lies on the
    threshold within the methods' small discrepancy, as happens right at a
    bifurcation).

    The monodromy needs an invertible mass matrix; Hill's method accepts a
    singular one (massless dofs) and then returns ``2 rank(M)`` multipliers.

    Where the orbit crosses a switching surface at which the force jumps,
    Hill's multipliers miss the saltation: method BOTH then reports the
    monodromy's (``disagreement`` when the counts differ), and method HILL
    flags the result ``ambiguous`` with a ``RuntimeWarning``.

    Parameters
    ----------
    hb : HarmonicBalance
    u : ndarray, shape (hb.size,)
        A converged solution.
    lam : float
    options : StabilityOptions, optional
    previous : tuple of int or FloquetResult, optional
        Counts ``(n_plus, n_minus, n_complex)`` of the previous point of a
        branch (method BOTH: a change triggers the monodromy check; ``None``
        also triggers it).

    Returns
    -------
    FloquetResult
    """
    options = StabilityOptions() if options is None else options
    method = options.method
    if method is StabilityMethod.NONE:
        raise ValueError("StabilityOptions.method is 'none': no stability computation requested")
    u = np.asarray(u, dtype=float)
    if method is StabilityMethod.FLOQUET:
        mono = _monodromy(hb, u, lam, options)
        mu = np.linalg.eigvals(mono.matrix)
        ex = _log_exponents(mu, mono.period)
        return _result(mu, ex, StabilityMethod.FLOQUET, mono.period, options, monodromy_multipliers=mu.copy())
    spec = hill_spectrum(hb, u, lam, vectors=options.eigenvectors, shift_tol=options.shift_tol)
    ambiguous = spec.quality < options.ambiguity_threshold
    hill = _result(
        spec.multipliers.copy(), spec.exponents.copy(), StabilityMethod.HILL, spec.period, options,
        ambiguous=ambiguous, quality=spec.quality, hill_multipliers=spec.multipliers.copy(),
        eigenvectors=spec.vectors,
    )
    jumps = _force_jumps(hb, u, lam, options)
    if method is StabilityMethod.HILL:
        if jumps:
            warnings.warn(
                f"at {hb.parameter}={lam:.10g} the orbit crosses a contact surface where the force jumps: Hill's "
                "multipliers miss the saltation there (use stability 'both' or 'floquet')", RuntimeWarning,
                stacklevel=2)
            return dataclasses.replace(hill, ambiguous=True)
        return hill
    prev = previous.counts if isinstance(previous, FloquetResult) else previous
    near_unit = bool(spec.multipliers.size) and options.unit_check > 0 and float(
        np.min(np.minimum(np.abs(spec.multipliers - 1.0), np.abs(spec.multipliers + 1.0)))) <= options.unit_check
    if not (jumps or ambiguous or near_unit or prev is None or tuple(prev) != hill.counts):
        return hill
    mono = _monodromy(hb, u, lam, options)
    mu = np.linalg.eigvals(mono.matrix)
    counts = classify_multipliers(mu, options.tolerance, options.real_angle_tol)
    gap = multiplier_distance(spec.multipliers, mu)
    # near +-1 the multipliers themselves are compared, not only the counts: a wrong
    # selection among Hill's shifted exponents can keep the counts and still be wrong
    fallback = bool(near_unit and not jumps and gap > options.agreement)
    if counts == hill.counts and not jumps and not fallback:
        return dataclasses.replace(hill, confirmed=True, monodromy_multipliers=mu.copy(), gap=gap)
    # Hill and the monodromy disagree, or Hill misses a force jump: the time integration is trusted
    near = np.abs(np.abs(np.concatenate([spec.multipliers, mu])) - 1.0 - options.tolerance)
    ex = _log_exponents(mu, mono.period)
    return _result(
        mu, ex, StabilityMethod.FLOQUET, mono.period, options, ambiguous=ambiguous, quality=spec.quality,
        confirmed=True, disagreement=counts != hill.counts, fallback=fallback, gap=gap,
        marginal=bool(counts != hill.counts and gap <= _MARGINAL_GAP and near.min() <= 2.0 * gap + options.tolerance),
        hill_multipliers=spec.multipliers.copy(), monodromy_multipliers=mu.copy(),
    )


#: Largest multiplier discrepancy between Hill and the monodromy that still
#: counts as agreement in accuracy: at a boundary where multipliers are double
#: (undamped Mathieu), an error e of either method moves them by ~sqrt(e).
_MARGINAL_GAP = 1e-3


def multiplier_distance(a: np.ndarray, b: np.ndarray) -> float:
    """Largest distance between two multiplier sets after optimal pairing.

    Parameters
    ----------
    a, b : ndarray, shape (k,) complex

    Returns
    -------
    float
        ``max_i |a_i - b_pi(i)|`` for the pairing ``pi`` minimising the sum
        of distances (``inf`` if the sizes differ).
    """
    from scipy.optimize import linear_sum_assignment

    a = np.asarray(a, dtype=complex)
    b = np.asarray(b, dtype=complex)
    if a.shape != b.shape:
        return float("inf")
    if a.size == 0:
        return 0.0
    D = np.abs(a[:, None] - b[None, :])
    r, c = linear_sum_assignment(D)
    return float(D[r, c].max())


class StabilityMonitor:
    """Monitor for :func:`contin.engine.continuation.continuation`: stability at each point.

    Called as ``monitor(u, lam, Ju, Jlam)``, it returns (see
    :meth:`FloquetResult.monitor_data`) ``evaluated`` (True), ``stable``,
    ``n_unstable``, ``n_plus``, ``n_minus``, ``n_complex``,
    ``max_multiplier``, ``multipliers`` (2n complex), ``ambiguous``,
    ``hill_quality`` (-1 when Hill was not used), ``confirmed``,
    ``disagreement`` (Hill and monodromy verdicts differ, not explained by
    a multiplier on the threshold), ``marginal_disagreement`` and
    ``hill_fallback``. With method BOTH it remembers the verdict of the
    previously evaluated point, so that each change of Hill's verdict is
    checked by the monodromy.

    Where no verdict can be made (a numerical failure: an ``ArithmeticError``
    or ``LinAlgError``, e.g. a monodromy that would need more steps than
    ``StabilityOptions.max_steps_per_period`` allow), it does not raise,
    which would end the branch: it returns :func:`unevaluated_data`
    (``evaluated`` False, finite placeholders) and records the parameter
    and the reason in :attr:`unevaluated` (the first one also raises a
    ``RuntimeWarning``). The stability events take such a point as giving
    no information (:func:`stability_events`).

    Parameters
    ----------
    hb : HarmonicBalance
    options : StabilityOptions, optional

    Attributes
    ----------
    evaluations, confirmations : int
    disagreements : list of float
        Parameter values where Hill and the monodromy disagreed beyond the
        threshold margin (the monodromy's verdict was used). The first one
        also raises a ``RuntimeWarning``.
    marginal_disagreements : list of float
        Parameter values where they disagreed with a multiplier on the
        threshold (at a bifurcation, within the methods' accuracy).
    ambiguous_points : list of float
        Parameter values where Hill's selection was ambiguous.
    fallbacks : list of float
        Parameter values where Hill's multipliers, near ``+1`` or ``-1``,
        differed from the monodromy's beyond ``StabilityOptions.agreement``
        and the monodromy's were used (the first one raises a
        ``RuntimeWarning``).
    largest_gap : float
        Largest Hill-monodromy multiplier distance met where both were computed.
    unevaluated : list of (float, str)
        Parameter values where no verdict could be made, with the reason.
    last : FloquetResult or None
    """

    def __init__(self, hb, options: StabilityOptions | None = None):
        self.hb = hb
        self.options = StabilityOptions() if options is None else options
        if self.options.method is StabilityMethod.NONE:
            raise ValueError("StabilityMonitor needs a stability method other than 'none'")
        self.evaluations = 0
        self.confirmations = 0
        self.disagreements: list[float] = []
        self.marginal_disagreements: list[float] = []
        self.ambiguous_points: list[float] = []
        self.fallbacks: list[float] = []
        self.unevaluated: list[tuple[float, str]] = []
        self.largest_gap = 0.0
        self.last: FloquetResult | None = None
        self._last_key = None
        self._size: int | None = None  # multipliers per point, as last returned
        self._restored_counts = None  # the last verdict's counts given back by restore()

    def analyze(self, u: np.ndarray, lam: float) -> FloquetResult:
        """:func:`floquet_multipliers` at ``(u, lam)``, updating the remembered verdict."""
        key = (np.asarray(u, dtype=float).tobytes(), float(lam))
        if key == self._last_key and self.last is not None:
            return self.last
        # a condensed problem (contin.hb.condensation): Hill and the monodromy on the full problem and coefficients
        hb = getattr(self.hb, "full", self.hb)
        uf = self.hb.expand(u, lam) if hb is not self.hb else u
        previous = self._restored_counts if self.last is None else self.last.counts
        res = floquet_multipliers(hb, uf, lam, self.options, previous=previous)
        self.evaluations += 1
        self.confirmations += int(res.confirmed)
        if res.disagreement:
            (self.marginal_disagreements if res.marginal else self.disagreements).append(float(lam))
            if not res.marginal and len(self.disagreements) == 1:
                warnings.warn(
                    f"Hill's method and the monodromy disagree on the stability at {self.hb.parameter}={lam:.10g} "
                    f"(Hill |mu|max={np.abs(res.hill_multipliers).max():.6g}, monodromy "
                    f"|mu|max={np.abs(res.monodromy_multipliers).max():.6g}); the monodromy verdict is used. "
                    "Check the harmonics H and steps_per_period (further disagreements are listed in "
                    "StabilityMonitor.disagreements without warning).",
                    RuntimeWarning,
                    stacklevel=2,
                )
        if math.isfinite(res.gap):
            self.largest_gap = max(self.largest_gap, float(res.gap))
        if res.fallback:
            self.fallbacks.append(float(lam))
            if len(self.fallbacks) == 1:
                warnings.warn(
                    f"Hill's multipliers near +-1 differ from the monodromy's by {res.gap:.2g} "
                    f"(> agreement {self.options.agreement:g}) at {self.hb.parameter}={lam:.10g}: the monodromy's are "
                    "used there and wherever this recurs (StabilityMonitor.fallbacks). Check the harmonics H.",
                    RuntimeWarning,
                    stacklevel=2,
                )
        if res.ambiguous:
            self.ambiguous_points.append(float(lam))
        self.last = res
        self._last_key = key
        return res

    def __call__(self, u, lam, Ju=None, Jlam=None) -> dict:
        try:
            data = self.analyze(u, lam).monitor_data()
        except NUMERICAL_ERRORS as exc:
            return self._unevaluated(float(lam), f"{type(exc).__name__}: {exc}")
        self._size = int(np.size(data["multipliers"]))
        return data

    def _unevaluated(self, lam: float, reason: str) -> dict:
        """Record a point without a verdict; its placeholder data."""
        self.unevaluated.append((lam, reason))
        if len(self.unevaluated) == 1:
            warnings.warn(
                f"no stability verdict at {getattr(self.hb, 'parameter', 'lambda')}={lam:.10g} ({reason}); the point "
                "is kept without one "
                "(evaluated False; further ones are listed in StabilityMonitor.unevaluated without warning)",
                RuntimeWarning,
                stacklevel=3,
            )
        return unevaluated_data(self._multiplier_count(lam))

    def _multiplier_count(self, lam: float) -> int:
        """How many multipliers the points have: those of the last verdict, else ``2 rank(M)`` (Hill's count)."""
        if self._size is not None:
            return self._size
        hb = getattr(self.hb, "full", self.hb)
        if hb is None:
            return 0
        return 2 * int(np.linalg.matrix_rank(hb.model.linear(hb.params_at(lam))[0]))

    def state(self) -> dict:
        """What the monitor remembers, JSON-able: its statistics and the last verdict's counts (see :meth:`restore`)."""
        return {"evaluations": self.evaluations, "confirmations": self.confirmations,
                "disagreements": list(self.disagreements), "marginal_disagreements": list(self.marginal_disagreements),
                "ambiguous_points": list(self.ambiguous_points), "fallbacks": list(self.fallbacks),
                "unevaluated": [[lam, reason] for lam, reason in self.unevaluated],
                "largest_gap": float(self.largest_gap), "size": self._size,
                "counts": None if self.last is None else [int(c) for c in self.last.counts]}

    def restore(self, state: Mapping[str, Any]) -> None:
        """Take up a :meth:`state` (a resumed run goes on as the interrupted one would have)."""
        self.evaluations, self.confirmations = int(state["evaluations"]), int(state["confirmations"])
        for name in ("disagreements", "marginal_disagreements", "ambiguous_points", "fallbacks"):
            setattr(self, name, [float(v) for v in state[name]])
        self.unevaluated = [(float(lam), str(reason)) for lam, reason in state["unevaluated"]]
        self.largest_gap = float(state["largest_gap"])
        self._size = None if state["size"] is None else int(state["size"])
        self.last, self._last_key = None, None
        self._restored_counts = None if state["counts"] is None else tuple(int(c) for c in state["counts"])

    def reset(self) -> None:
        """Forget the remembered verdict (before tracing a new branch)."""
        self._restored_counts = None
        self.last = None
        self._last_key = None

    def statistics(self) -> dict:
        return {
            "evaluations": self.evaluations,
            "confirmations": self.confirmations,
            "disagreements": list(self.disagreements),
            "marginal_disagreements": list(self.marginal_disagreements),
            "ambiguous_points": list(self.ambiguous_points),
            "fallbacks": list(self.fallbacks),
            "unevaluated": [[lam, reason] for lam, reason in self.unevaluated],
            "largest_hill_monodromy_gap": float(self.largest_gap),
            "method": self.options.method.value,
        }


_CROSSING_COUNT = {"+1": "n_plus", "-1": "n_minus", "complex": "n_complex"}


_VERDICT_KEYS = ("n_plus", "n_minus", "n_complex", "n_unstable", "multipliers")


def _counts_of(point: PointInfo, monitor: StabilityMonitor) -> dict | None:
    """The stability data of ``point`` (its monitored data, else the monitor's verdict), or None without a verdict.

    A point without one (``evaluated`` False, or the monitor failing there)
    gives no information: None, never its placeholders.
    """
    d = point.data
    if not all(k in d for k in _VERDICT_KEYS):
        try:
            d = monitor.analyze(point.u, point.lam).monitor_data()
        except NUMERICAL_ERRORS:
            return None
    return d if bool(d.get("evaluated", True)) else None


def _multipliers_of(point: PointInfo, monitor: StabilityMonitor) -> np.ndarray | None:
    """The multipliers of ``point``, or None without a verdict (see :func:`_counts_of`)."""
    d = _counts_of(point, monitor)
    return None if d is None else np.asarray(d["multipliers"], dtype=complex)


class _Held:
    """The verdict of the last evaluated stored point, for the stored points without one.

    The engine tests each stored point once, in order along the branch (a new
    branch from its start, at arclength 0). A point without a verdict takes
    that of the last evaluated point before it: no change is detected into
    or out of it, and a change across it is taken between the evaluated
    points around it (located between it and the next one, where the
    engine solves).
    """

    def __init__(self):
        self.latest = None  # the stored point tested last
        self.current = None  # _standing() of the last evaluated stored point up to it
        self.before = None  # the same up to the stored point before it

    def see(self, point: PointInfo, own: dict | None) -> None:
        """Record a stored point as the engine tests it (``own``: its data, None without a verdict)."""
        if point is self.latest:
            return
        if point.s == 0.0:
            self.current = None  # the start of a branch
        self.before = self.current
        if own is not None:
            self.current = _standing(point, own)
        self.latest = point

    def at(self, point: PointInfo, own: dict | None):
        """:func:`_standing` for ``point``: its own where it has a verdict, else the held one (or None)."""
        if own is not None:
            return _standing(point, own)
        return self.current if point is self.latest else self.before


def _standing(point: PointInfo, own: dict) -> tuple:
    """``(s, data, lam, dlam)`` of an evaluated point: arclength, verdict, parameter, parameter component
    of the tangent (what the events read of the point standing for one without a verdict)."""
    return float(point.s), own, float(point.lam), float(point.tangent[-1])


def _mark_before(loc, a: PointInfo, held, monitor):
    """Say where a change lies that the location could not put beyond a point without a verdict.

    Where ``a`` has no verdict, the change lies between the evaluated point
    standing for it (``held``) and the far end of the final bracket.
    Bisection onto ``a`` itself (every solved point on the far side) puts it
    between ``held`` and ``a``, or just after ``a``: not resolved where
    nothing could be evaluated, so it is not located either.
    """
    if held is None or _counts_of(a, monitor) is not None:
        return loc
    if loc.located and loc.bracket[0] == a.lam:
        loc.located = False
    if not loc.located:
        loc.message = (f"the change lies between {held[2]:.10g} and {loc.bracket[1]:.10g} (no stability verdict at "
                       f"{a.lam:.10g}); {loc.message}")
    return loc


def _evaluated_only(point_at, monitor):
    """``point_at`` of the engine, with a solved point without a stability verdict counted as a failed solve.

    Such a point cannot tell on which side of a change it lies: the location
    ends there (unlocated, with the reason) rather than taking it for one side.
    """
    def wrapped(sigma):
        info, why = point_at(sigma)
        if info is None:
            return info, why
        try:
            own = _counts_of(info, monitor)
        except NUMERICAL_ERRORS as exc:
            return None, f"no stability verdict ({type(exc).__name__}: {exc})"
        if own is None:
            reasons = getattr(monitor, "unevaluated", None)
            reason = f": {reasons[-1][1]}" if reasons else ""
            return None, f"no stability verdict at {info.lam:.10g}{reason}"
        return info, why

    return wrapped


def _turns(fa: float, fb: float) -> bool:
    """Whether the parameter components ``fa``, ``fb`` of two tangents say that the branch turned between."""
    return bool((fa < 0 <= fb) or (fa > 0 >= fb))


def _pairing(mu_a: np.ndarray, mu_b: np.ndarray) -> np.ndarray:
    """Index into ``mu_b`` of the partner of each multiplier of ``mu_a`` (closest overall pairing)."""
    from scipy.optimize import linear_sum_assignment

    if mu_a.shape != mu_b.shape:
        return np.full(mu_a.shape, -1)
    D = np.abs(mu_a[:, None] - mu_b[None, :])
    r, c = linear_sum_assignment(D)
    out = np.empty(mu_a.size, dtype=int)
    out[r] = c
    return out


def _kind_mask(mu: np.ndarray, crossing: str, real_angle_tol: float) -> np.ndarray:
    ang = np.abs(np.angle(mu))
    if crossing == "+1":
        return ang <= real_angle_tol
    if crossing == "-1":
        return ang >= np.pi - real_angle_tol
    return (ang > real_angle_tol) & (ang < np.pi - real_angle_tol)


class MultiplierCrossingEvent(Event):
    """A multiplier crossing the unit circle at ``+1``, at ``-1`` or as a complex pair.

    The counts of unstable multipliers (``|mu| > 1 + tolerance``) by type,
    ``n_plus`` (real positive), ``n_minus`` (real negative) and ``n_complex``,
    decide whether a crossing happened between two points, by what each
    crossing changes and what it does not:

    - a real multiplier crossing ``+1`` (``-1``) flips the parity of
      ``n_plus`` (``n_minus``);
    - a complex pair crossing changes ``n_unstable`` by 2 and neither parity;
    - two complex multipliers colliding on the real axis (or two real ones
      leaving it) outside the circle change ``n_complex`` by 2 and
      ``n_minus`` (``n_plus``) by 2: no parity and not ``n_unstable``. Such a
      collision is not a bifurcation and is never reported.

    So ``pd`` is reported where the parity of ``n_minus`` changes (a real
    multiplier crossing -1), ``ns`` where ``n_unstable`` changes by more
    than the real crossings account for, and the ``+1`` kinds where the
    parity of ``n_plus`` changes.

    Location: the counts keep the bracket (bisection); the modulus of the
    crossing multiplier, followed from one end of the bracket to the other
    (the pairing of the two ends' multipliers that moves them least, then at
    each solved point the multiplier nearest to where it is expected),
    minus ``1 + tolerance``, is the continuous test that the Illinois
    iteration of :func:`contin.engine.events.narrow` solves, so a point costs a few
    solves instead of the bisection's dozens. :meth:`step_limit` extrapolates
    each multiplier's distance to the circle from the last two points: the
    engine keeps the next step near where the closest one is predicted to
    cross, so that two crossings close together (a narrow stable window) are
    not taken in one step.

    A point without a verdict (``evaluated`` False) stands for the last
    evaluated one before it (see :func:`stability_events`): the counts, the
    multipliers that start the continuous test, and the tangent that tells
    ``fold`` from ``bp``.

    Parameters
    ----------
    monitor : StabilityMonitor
        Supplies the counts when they are not in the point data, and Hill's
        eigenvectors for :meth:`describe`.
    crossing : {'+1', '-1', 'complex'}
    kind : SpecialKind or str, optional
        Default ``bp`` for ``+1``, ``pd`` for ``-1``, ``ns`` for ``complex``.
        For ``+1`` with kind ``fold`` the event fires only where the
        parameter component of the tangent changes sign; with kind ``bp``
        only where it does not (the engine's own fold event covers folds).
    """

    integer_valued = True

    def __init__(self, monitor: StabilityMonitor, crossing: str, kind: SpecialKind | str | None = None):
        if crossing not in _CROSSING_COUNT:
            raise ValueError(f"crossing must be one of {list(_CROSSING_COUNT)}, got {crossing!r}")
        default = {"+1": SpecialKind.BP, "-1": SpecialKind.PD, "complex": SpecialKind.NS}[crossing]
        self.kind = SpecialKind(kind) if kind is not None else default
        if crossing != "+1" and self.kind in (SpecialKind.FOLD, SpecialKind.BP):
            raise ValueError(f"kind {self.kind.value!r} needs crossing '+1'")
        self.monitor = monitor
        self.crossing = crossing
        self.key = _CROSSING_COUNT[crossing]
        self.name = f"stability {crossing} ({self.kind.value})"
        #: whether this event gives the monitor's step limit (one of a set of events on one monitor does)
        self.predicts = True
        self._held = _Held()

    # -- counts -----------------------------------------------------------
    def _count(self, d: dict | None) -> float:
        if d is None:
            return math.nan  # no verdict yet on this branch: no change into or out of it
        return float(d["n_unstable"] if self.crossing == "complex" else d[self.key])

    def _data(self, point: PointInfo):
        """:func:`_standing` for a stored point (see :class:`_Held`), or None."""
        return self._held.at(point, _counts_of(point, self.monitor))

    def test(self, point: PointInfo) -> float:
        own = _counts_of(point, self.monitor)
        self._held.see(point, own)
        held = self._held.at(point, own)
        return self._count(None if held is None else held[1])

    def _crossed(self, da: dict, db: dict) -> bool:
        flip_plus = (int(da["n_plus"]) - int(db["n_plus"])) % 2
        flip_minus = (int(da["n_minus"]) - int(db["n_minus"])) % 2
        if self.crossing == "+1":
            return bool(flip_plus)
        if self.crossing == "-1":
            return bool(flip_minus)
        return abs(int(db["n_unstable"]) - int(da["n_unstable"])) - flip_plus - flip_minus >= 2

    def triggered(self, ga, gb, a, b):
        da, db = self._data(a), self._data(b)
        crossed = da is not None and db is not None and self._crossed(da[1], db[1])
        if crossed and self.crossing == "+1":
            # a turn anywhere since the evaluated point standing for a (a fold where nothing was evaluated)
            turned = _turns(da[3], db[3])
            crossed = turned if self.kind is SpecialKind.FOLD else not turned
        return np.full(np.shape(ga), crossed)

    # -- location ---------------------------------------------------------
    def _threshold(self) -> float:
        return 1.0 + self.monitor.options.tolerance

    def _product(self, mu: np.ndarray) -> float:
        """``prod (c -+ mu_i)``, ``c = 1 + tolerance``: the real crossings' continuous test.

        Its sign flips exactly where a real multiplier crosses ``+c`` (``-c``),
        that is where the parity of ``n_plus`` (``n_minus``) flips; conjugate
        pairs contribute ``|c -+ mu|^2 > 0``, so a collision on the real axis
        leaves it alone. It is smooth in the parameter even where the
        multipliers sit on the circle until they meet at ``+-1`` (a
        conservative system), where a modulus stays flat. (The determinant
        tests ``det(Phi -+ I)`` of AUTO; Doedel et al., AUTO-07p manual.)
        """
        c = self._threshold()
        terms = c - mu if self.crossing == "+1" else c + mu
        mag = np.abs(terms)
        if np.any(mag == 0.0):
            return 0.0
        sign = np.prod(terms / mag)  # unit complex; real up to rounding for a conjugate-closed set
        return float(np.sign(sign.real) * math.exp(min(float(np.sum(np.log(mag))), 700.0)))

    def _tracked(self, mu_a: np.ndarray, mu_b: np.ndarray):
        """``(mu_a, mu_b)`` of the multiplier that crosses between two points with these multipliers, or None."""
        pair = _pairing(mu_a, mu_b)
        if (pair < 0).any():
            return None
        tol, thr = self.monitor.options.real_angle_tol, self._threshold()
        best = None
        for i, j in enumerate(pair):
            ma, mb = mu_a[i], mu_b[j]
            if (abs(ma) > thr) == (abs(mb) > thr):
                continue
            if not (_kind_mask(np.array([ma]), "complex", tol)[0] and _kind_mask(np.array([mb]), "complex", tol)[0]):
                continue
            if ma.imag < 0:
                ma, mb = ma.conjugate(), mb.conjugate()
            size = abs(mb - ma)
            if best is None or size < best[2]:
                best = (complex(ma), complex(mb), size)
        return None if best is None else best[:2]

    def locate(self, component, point_at, h, a, b, ga, gb, *, tol=1e-10, max_iter=60):
        held_a, held_b = self._data(a), self._data(b)
        if held_a is None or held_b is None:
            return [Location(h, b, float(gb), False, 0, "no stability verdict at an end", (a.lam, b.lam))]
        # an end without a verdict is represented by the held one (of the last evaluated point before it):
        # its counts give the side, and its multipliers start the continuous test on the right sign
        da = held_a[1]
        mu_a = np.asarray(da["multipliers"], dtype=complex)
        mu_b = np.asarray(held_b[1]["multipliers"], dtype=complex)
        point_at = _evaluated_only(point_at, self.monitor)
        thr = self._threshold()
        if self.crossing == "complex":
            tracked = self._tracked(mu_a, mu_b)
            span = b.s - a.s if math.isfinite(b.s - a.s) and b.s != a.s else h

            def value(info):
                # the modulus of the crossing multiplier, found near where it is expected
                if tracked is None:
                    return math.nan
                q = (info.s - a.s) / span if math.isfinite(info.s) else 0.5
                target = tracked[0] + q * (tracked[1] - tracked[0])
                mu = _multipliers_of(info, self.monitor)
                if mu is None:
                    return math.nan
                mu = np.concatenate([mu, mu.conjugate()])
                return abs(mu[int(np.argmin(np.abs(mu - target)))]) - thr

            v_a, v_b = (abs(tracked[0]) - thr, abs(tracked[1]) - thr) if tracked is not None else (math.nan, math.nan)
        else:
            def value(info):
                mu = _multipliers_of(info, self.monitor)
                return math.nan if mu is None else self._product(mu)

            v_a, v_b = self._product(mu_a), self._product(mu_b)

        def side(info, v):
            d = _counts_of(info, self.monitor)
            if d is None:
                raise ArithmeticError(f"no stability verdict at {info.lam:.10g}")
            return not self._crossed(da, d)

        loc = narrow(point_at, 0.0, h, a, b, v_a, v_b, h, side=side, value=value, tol=tol, max_iter=max_iter)
        end = self._data(loc.point)
        loc.value = self._count(None if end is None else end[1])
        return [_mark_before(loc, a, held_a, self.monitor)]

    def step_limit(self, a: PointInfo, b: PointInfo, h: float) -> float:
        """The step limit of :func:`multiplier_step_limit`, from evaluated points only.

        Where ``a`` has no verdict the last evaluated point before it stands
        in (``h`` measured from it); none where ``b`` has none.
        """
        if not self.predicts:
            return math.inf
        mu_b = _multipliers_of(b, self.monitor)
        if mu_b is None:
            return math.inf
        mu_a = _multipliers_of(a, self.monitor)
        if mu_a is None:
            held = self._data(a)
            if held is None or not (math.isfinite(held[0]) and math.isfinite(b.s) and b.s > held[0]):
                return math.inf
            h, mu_a = float(b.s) - held[0], np.asarray(held[1]["multipliers"], dtype=complex)
        return multiplier_step_limit(mu_a, mu_b, h, self._threshold())

    def describe(self, point: PointInfo) -> dict:
        return describe_crossing(self.monitor, point, self.crossing, self.kind)


class StabilityChangeEvent(Event):
    """Integer-valued event on ``n_unstable`` (kind ``stability``), unclassified.

    The located point's data holds the classification (``"classification"``:
    ``fold``/``bp``/``pd``/``ns``) made from the multiplier closest to the
    unit circle; ``fold`` versus ``bp`` is decided by whether the parameter
    component of the tangent changed sign between the two evaluated points
    that bracket the change (recorded by :meth:`triggered`, which the engine
    calls just before locating). Points without a verdict are taken as in
    :func:`stability_events`.
    """

    integer_valued = True
    kind = SpecialKind.STABILITY
    name = "stability change"

    def __init__(self, monitor: StabilityMonitor):
        self.monitor = monitor
        self._turned = False
        self._held = _Held()

    def test(self, point: PointInfo) -> float:
        own = _counts_of(point, self.monitor)
        self._held.see(point, own)
        held = self._held.at(point, own)  # a point without a verdict holds the last one (see _Held)
        return math.nan if held is None else float(held[1]["n_unstable"])

    def triggered(self, ga, gb, a, b):
        da, db = self._held.at(a, _counts_of(a, self.monitor)), self._held.at(b, _counts_of(b, self.monitor))
        self._turned = _turns(a.tangent[-1] if da is None else da[3], b.tangent[-1] if db is None else db[3])
        return ga != gb

    def locate(self, component, point_at, h, a, b, ga, gb, *, tol=1e-10, max_iter=60):
        """Bisection on ``n_unstable`` (:func:`contin.engine.events.locate`); a point without a verdict ends it."""
        def count(info):
            d = _counts_of(info, self.monitor)
            if d is None:
                raise ArithmeticError(f"no stability verdict at {info.lam:.10g}")
            return float(d["n_unstable"])

        counter = FunctionEvent(count, name=self.name, kind=self.kind, integer_valued=True)
        locs = locate(counter, component, _evaluated_only(point_at, self.monitor), h, a, b, ga, gb, tol=tol,
                      max_iter=max_iter)
        held = self._held.at(a, _counts_of(a, self.monitor))
        return [_mark_before(loc, a, held, self.monitor) for loc in locs]

    def describe(self, point: PointInfo) -> dict:
        mu = _multipliers_of(point, self.monitor)
        if mu is None:
            return {"evaluated": False}
        i = int(np.argmin(np.abs(np.log(np.maximum(np.abs(mu), 1e-300)))))
        ang = abs(np.angle(mu[i]))
        tol = self.monitor.options.real_angle_tol
        crossing = "+1" if ang <= tol else "-1" if ang >= np.pi - tol else "complex"
        kind = {"-1": SpecialKind.PD, "complex": SpecialKind.NS}.get(
            crossing, SpecialKind.FOLD if self._turned else SpecialKind.BP
        )
        return describe_crossing(self.monitor, point, crossing, kind)


def describe_crossing(monitor: StabilityMonitor, point: PointInfo, crossing: str, kind: SpecialKind) -> dict:
    """Data of a located stability change: the critical multiplier and Hill eigenvector.

    The multipliers are those of the point's monitored data (the verdict the
    engine used) when present.

    Returns
    -------
    dict
        ``classification`` (str), ``crossing`` (str), ``multiplier``
        (complex), ``multiplier_abs``, ``multiplier_arg`` (float),
        ``exponent`` (complex), ``eigenvector`` (ndarray (m,) complex,
        coefficient space, unit 2-norm; Hill's, even when the monodromy's
        multipliers are reported; absent for a monitor without a
        harmonic-balance problem, ``monitor.hb`` None, and for method
        ``floquet`` unless ``StabilityOptions.eigenvectors``), ``n_unstable``,
        ``disagreement``.
    """
    opts = monitor.options
    d = _counts_of(point, monitor)
    if d is None:
        return {"classification": kind.value, "crossing": crossing, "evaluated": False}
    mu_all = np.asarray(d["multipliers"], dtype=complex)
    n_unstable = int(d["n_unstable"])
    disagreement = bool(d.get("disagreement", False))
    probe = FloquetResult(
        multipliers=mu_all, exponents=mu_all, stable=True, n_unstable=0, n_plus=0, n_minus=0, n_complex=0,
        max_multiplier=0.0, method=StabilityMethod.HILL, period=0.0, real_angle_tol=opts.real_angle_tol,
    )
    mu = complex(mu_all[probe.critical(crossing)])
    data: dict[str, Any] = {
        "classification": kind.value,
        "crossing": crossing,
        "multiplier": mu,
        "multiplier_abs": abs(mu),
        "multiplier_arg": float(np.angle(mu)),
        "n_unstable": n_unstable,
        "disagreement": disagreement,
    }
    if kind is SpecialKind.BP or kind is SpecialKind.FOLD:
        data["turns"] = kind is SpecialKind.FOLD
    if getattr(monitor, "hb", None) is None or (opts.method is StabilityMethod.FLOQUET and not opts.eigenvectors):
        return data  # Hill's eigenproblem costs more than the monodromy at high H: only when asked for
    try:
        spec = hill_spectrum(monitor.hb, point.u, point.lam, vectors=True, shift_tol=opts.shift_tol)
        j = int(np.argmin(np.abs(spec.multipliers - mu)))
        data["exponent"] = complex(spec.exponents[j])
        data["eigenvector"] = spec.vectors[:, j].copy()
        data["hill_multiplier"] = complex(spec.multipliers[j])
    except (np.linalg.LinAlgError, ValueError) as exc:
        data["eigenvector_error"] = f"{type(exc).__name__}: {exc}"
    return data


def stability_events(monitor: StabilityMonitor, *, folds: bool = False, branch_points: bool = True,
                     period_doubling: bool = True, neimark_sacker: bool = True) -> list[Event]:
    """The classified stability events for the engine.

    Parameters
    ----------
    monitor : StabilityMonitor
        Must also be passed to the engine in ``monitors`` (the events read
        its values from the point data).
    folds : bool
        Add a ``+1`` event of kind ``fold`` (only useful when the engine's
        own fold detection is off).
    branch_points, period_doubling, neimark_sacker : bool

    Returns
    -------
    list of MultiplierCrossingEvent

    Notes
    -----
    A point without a verdict (``evaluated`` False, see
    :class:`StabilityMonitor`) gives no information: it holds the test value
    of the last evaluated point before it, so no change is detected into or
    out of it, and a change across it triggers at the next evaluated point
    and is located between the two (a change that the location puts at the
    point without a verdict, or where a solved point on the way has none,
    is recorded unlocated, with its bracket). Step limits come from
    evaluated points only.
    """
    evs: list[Event] = []
    if folds:
        evs.append(MultiplierCrossingEvent(monitor, "+1", SpecialKind.FOLD))
    if branch_points:
        evs.append(MultiplierCrossingEvent(monitor, "+1", SpecialKind.BP))
    if period_doubling:
        evs.append(MultiplierCrossingEvent(monitor, "-1", SpecialKind.PD))
    if neimark_sacker:
        evs.append(MultiplierCrossingEvent(monitor, "complex", SpecialKind.NS))
    for ev in evs[1:]:
        ev.predicts = False  # the multipliers' prediction is made once
    return evs


#: Multipliers this close to the unit circle (in modulus) can be pushed across it by a collision.
COLLISION_NEAR = 0.05
#: Steps across a predicted collision of multipliers near the circle (scaled arclength): the
#: narrowest window of instability after one that the steps resolve.
COLLISION_STEP = 1e-3


def multiplier_step_limit(mu_a: np.ndarray, mu_b: np.ndarray, h: float, threshold: float = 1.0) -> float:
    """Predicted arclength beyond ``b`` to the next change of stability.

    Two ways a multiplier crosses the unit circle between two points:

    - it moves across it: each multiplier's distance to the circle,
      ``|mu| - threshold``, is extrapolated linearly from the two points;
    - two multipliers near the circle collide (a complex pair on the real
      axis, two pairs meeting on the circle) and split off it, one outwards:
      a period-doubling or Neimark-Sacker window that can be narrower than
      the step, with the multipliers inside the circle at both ends. The
      distance between any two multipliers within ``COLLISION_NEAR`` of the
      circle is extrapolated the same way.

    Multipliers are paired between the two points by the assignment that
    moves them least.

    Parameters
    ----------
    mu_a, mu_b : ndarray, shape (k,) complex
        Multipliers at the two points, ``h`` apart.
    h : float
    threshold : float
        ``1 + tolerance``.

    Returns
    -------
    float
        The longest next step: ``OVERSHOOT`` times the nearest predicted
        crossing (it then falls inside the step); half the way to the
        nearest predicted collision, but at least ``COLLISION_STEP``; ``inf``
        when nothing approaches.
    """
    pair = _pairing(mu_b, mu_a)
    if (pair < 0).any():
        return math.inf
    mu_a = mu_a[pair]  # aligned with mu_b
    limit = OVERSHOOT * min((predicted_zero(abs(p) - threshold, abs(q) - threshold, h) for p, q in zip(mu_a, mu_b)),
                            default=math.inf)
    near = np.flatnonzero(np.abs(np.abs(mu_b) - 1.0) < COLLISION_NEAR)
    meet = math.inf
    for k, i in enumerate(near):
        for j in near[k + 1:]:
            meet = min(meet, predicted_zero(abs(mu_a[i] - mu_a[j]), abs(mu_b[i] - mu_b[j]), h))
    # the window a collision opens can be narrower than any overshoot: approach the meeting
    # point halving the way each step, then pass it in steps of COLLISION_STEP
    if math.isfinite(meet):
        limit = min(limit, max(0.5 * meet, COLLISION_STEP))
    return limit
