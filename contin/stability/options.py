"""Options of the stability analysis: how the Floquet multipliers are computed and judged.

:class:`StabilityMethod` names the method (Hill's, the monodromy, both, or
none); :class:`StabilityOptions` holds the method with its margins, step
counts and integrator, validated on construction, and builds from and to the
mappings of a scene.
"""

from __future__ import annotations

import dataclasses
import enum
import math
from typing import Any, Mapping

import numpy as np

from contin.util.naming import is_real, suggest
from contin.util.options import from_mapping

__all__ = ["StabilityMethod", "StabilityOptions"]


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
        Largest multiplier distance (:func:`~contin.stability.multiplier_pairing.multiplier_distance`) between
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
        is used if its estimated cost is within :data:`~contin.stability.floquet.IVP_FALLBACK_EVALUATIONS`
        right-hand sides, else the point gets no verdict (see
        :class:`~contin.stability.monitor.StabilityMonitor`). The refined steps make RK4 stable on the
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
        """Build from a mapping (:func:`contin.util.options.from_mapping`); an unknown key raises
        ``ValueError`` naming it and the nearest valid one."""
        return from_mapping(cls, d)

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
