"""The options of shooting on the integrated flow (:class:`ShootingOptions`)."""

from __future__ import annotations

import dataclasses
from typing import Mapping

import numpy as np

from contin.util.options import from_mapping

__all__ = ["JACOBIANS", "ShootingOptions"]

JACOBIANS = ("variational", "differences")


@dataclasses.dataclass(frozen=True)
class ShootingOptions:
    """Options of shooting (:class:`ShootingProblem`, :func:`contin.timedomain.shooting.periodic_orbit`).

    Attributes
    ----------
    steps_per_period : int
        RK4 steps per forcing period ``2 pi / w`` (the rotor paper: 4096).
    tol : float
        Newton of :func:`~contin.timedomain.shooting.periodic_orbit` ends when
        ``max |phi_T(z) - z| <= tol * max(1, max |z|)``.
    max_iter : int
        Newton iterations at most.
    fd_step : float
        Step of the central differences (of the flow map in the state for
        ``jacobian="differences"``, in the parameter always), relative to
        ``max(1, max |z|)`` and ``max(1, |lam|)``.
    subharmonic : int
        ``nu``: the orbit's period is ``nu`` forcing periods.
    segments : int
        ``M``, shooting segments of the period; ``steps_per_period * subharmonic``
        must be a multiple of it (segment ends on the step grid).
    jacobian : str
        ``"variational"`` (the variational equations with the flow) or
        ``"differences"`` (central differences of the flow map, the reference).
    start_step : int
        The step of the orbit's grid (``steps_per_period * subharmonic`` steps a period) at which its state
        is the first unknown: the section ``t0 = start_step T / (steps_per_period * subharmonic)``
        (0: forcing phase zero). The orbits are the same whatever it is; the branch through them is
        parametrised by the states at other times (:mod:`contin.timedomain.shooting_section`).
    """

    steps_per_period: int = 4096
    tol: float = 1e-10
    max_iter: int = 20
    fd_step: float = 1e-6
    subharmonic: int = 1
    segments: int = 1
    jacobian: str = "variational"
    #: not a scene key: chosen where a branch starts (metadata ``scene``: False)
    start_step: int = dataclasses.field(default=0, metadata={"scene": False})

    def __post_init__(self):
        for name in ("steps_per_period", "max_iter", "subharmonic", "segments"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
                raise ValueError(f"ShootingOptions.{name} must be a positive integer, got {v!r}")
        for name, hi in (("tol", 1e-2), ("fd_step", 1e-2)):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not (0.0 < v <= hi):
                raise ValueError(f"ShootingOptions.{name} must be a number in (0, {hi:g}], got {v!r}")
        steps = self.steps_per_period * self.subharmonic
        if steps % self.segments:
            raise ValueError(f"ShootingOptions.segments must divide steps_per_period * subharmonic = {steps} "
                             f"(segment ends on the step grid), got {self.segments}")
        v = self.start_step
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not 0 <= v < steps:
            raise ValueError(f"ShootingOptions.start_step must be an integer in [0, {steps}) (a step of the orbit's "
                             f"grid of steps_per_period * subharmonic steps), got {v!r}")
        if self.jacobian not in JACOBIANS:
            raise ValueError(f"ShootingOptions.jacobian must be one of {list(JACOBIANS)}, got {self.jacobian!r}")

    @classmethod
    def from_dict(cls, d: Mapping) -> "ShootingOptions":
        """From a mapping (:func:`contin.util.options.from_mapping`); an unknown key raises ``ValueError``
        naming it, the nearest valid one and all of them."""
        return from_mapping(cls, d)
