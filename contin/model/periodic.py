"""The one protocol of a periodic problem: what analyses, stability, events and outputs ask of it.

A branch of forced vibrations is computed by one of several discretisations:
harmonic balance (:class:`contin.hb.problem.HarmonicBalance`), harmonic
balance condensed onto the dofs that carry nonlinear forces
(:class:`contin.hb.condensation.CondensedHarmonicBalance`), the torus problem
of quasi-periodic solutions (:class:`contin.hb.torus.QuasiPeriodicBalance`)
and shooting on the integrated flow
(:class:`contin.timedomain.shooting.ShootingProblem`). Each gives the
continuation engine ``R(u, lambda)``; what the code around the engine needs
to know about the vibration is asked through the members of
:class:`PeriodicProblem`, never by testing which class it holds.

Two members tell a problem's relation to the model's dofs: ``full`` is the
problem in every dof behind a condensed one (the problem itself otherwise)
and ``condensed`` says whether the unknowns hold only some dofs (then the
problem also has ``expand(u, lam)`` and ``restrict(u_full)``). Hill's method,
the monodromy and the grazing test work on ``full``; a stored point is
expanded when ``condensed``.

The protocol lives in the model layer, below every layer that holds or asks
a periodic problem, so that each of them may name it.
"""

from __future__ import annotations

import sys
from typing import Protocol, Sequence, runtime_checkable

import numpy as np

__all__ = ["AllDofs", "CIRCLE_MODULE", "PeriodicProblem", "SHOOTING_MODULE", "is_circle", "is_shooting"]


@runtime_checkable
class PeriodicProblem(Protocol):
    """What every periodic problem of contin offers (``isinstance(problem, PeriodicProblem)`` checks the names).

    Attributes
    ----------
    parameter : str
        The continuation parameter ``lambda``.
    frequency : str
        The excitation-frequency parameter ``w`` (``tau = w t``).
    nu : int
        The subharmonic order: the solution's period is ``nu`` forcing periods.
    n : int
        The dofs the unknowns describe (the kept dofs of a condensed problem).
    size : int
        The number of unknowns ``u`` the engine follows.
    """

    parameter: str
    frequency: str
    nu: int
    n: int
    size: int

    @property
    def dof_names(self) -> Sequence[str]:
        """The names of the ``n`` dofs the unknowns describe, in their order."""

    @property
    def full(self) -> "PeriodicProblem":
        """The problem in every dof of the model: the one behind a condensed problem, the problem itself otherwise."""

    @property
    def condensed(self) -> bool:
        """Whether the unknowns hold only some dofs (``expand`` and ``restrict`` convert them to ``full``'s)."""

    def params_at(self, lam: float):
        """The model's parameters with the continuation parameter at ``lam`` (the vector of
        ``model.parameter_vector`` for the harmonic-balance problems, the overrides by name for shooting)."""

    def frequency_at(self, lam: float) -> float:
        """The excitation frequency ``w`` at ``lam`` (the parameter itself, or fixed by the others)."""

    def period_at(self, lam: float) -> float:
        """The solution's period ``2 pi nu / w`` at ``lam``."""

    def orbit(self, u: np.ndarray, lam: float, t) -> tuple[np.ndarray, np.ndarray]:
        """Displacements and velocities of the solution ``u`` at times ``t``.

        Parameters
        ----------
        u : ndarray, shape (size,)
        lam : float
        t : array_like, shape (K,)
            Times from the solution's phase origin (``tau = w t``).

        Returns
        -------
        x, xd : ndarray, shape (full.n, K)
            Every dof of the model, a condensed problem's included.
        """


class AllDofs:
    """The protocol's members of a problem whose unknowns describe every dof of its ``model``.

    ``condensed`` False, ``full`` the problem itself, ``dof_names`` the model's.
    """

    condensed = False

    @property
    def full(self):
        """The problem in every dof: the problem itself."""
        return self

    @property
    def dof_names(self) -> list:
        """The model's dof names, in the order of the unknowns."""
        return list(self.model.dof_names)


#: the module that defines shooting problems: until it is imported no problem can be one
SHOOTING_MODULE = "contin.timedomain.multiple_shooting"


def is_shooting(problem) -> bool:
    """Whether ``problem`` is a shooting problem (its unknowns are states of the integrated flow, not coefficients).

    Answered without importing the time-domain modules (the integrators, scipy.optimize and .interpolate), so
    that a run of harmonic-balance branches never loads them.
    """
    module = sys.modules.get(SHOOTING_MODULE)
    return module is not None and isinstance(problem, module.ShootingProblem)


CIRCLE_MODULE = "contin.timedomain.invariant_circle"


def is_circle(problem) -> bool:
    """Whether ``problem`` is a torus as an invariant circle of the stroboscopic map (its unknowns are the
    circle's points and its rotation number); answered as :func:`is_shooting`, without importing the time domain."""
    module = sys.modules.get(CIRCLE_MODULE)
    return module is not None and isinstance(problem, module.InvariantCircleProblem)
