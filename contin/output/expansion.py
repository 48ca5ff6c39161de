"""Full coefficients of the unknowns a checkpoint stores.

A branch whose problem was condensed (:mod:`contin.hb.condensation`) stores
in ``state.jsonl`` what the continuation engine followed: the coefficients of
its kept dofs (half the bytes or less of the full vector, which the resume
state does not need). Its branch record lists them (``"dofs"``, with ``"nu"``
and ``"H"``) and says so (``"unknowns": "engine"``); the coefficients of the
other dofs follow from them by the linear solve of
:meth:`~contin.hb.condensation.CondensedHarmonicBalance.expand` at the point's
parameter. A branch record without ``"unknowns"`` was written by an earlier
contin, which stored the full coefficients.
"""

from __future__ import annotations

import numpy as np

from contin.hb.factory import harmonic_balance

__all__ = ["ENGINE_UNKNOWNS", "StoredExpansion", "stores_kept"]

#: the branch record's ``"unknowns"`` when its points hold the engine's unknowns (the kept dofs' coefficients)
ENGINE_UNKNOWNS = "engine"


def _full_of(problem):
    """The problem in every dof behind ``problem`` (:attr:`contin.model.periodic.PeriodicProblem.full`); None stays None."""
    return None if problem is None else problem.full


def stores_kept(header: dict | None) -> bool:
    """Whether the points of the branch ``header`` describes hold only its kept dofs' coefficients."""
    return bool(header) and header.get("unknowns") == ENGINE_UNKNOWNS and header.get("dofs") is not None


class StoredExpansion:
    """Full coefficients of a checkpoint's stored unknowns, from the problems that computed them.

    Parameters
    ----------
    full : HarmonicBalance, optional
        The full problem of the run (any ``nu`` and ``H``): a branch of
        another order or truncation is expanded by its
        ``with_options(subharmonic=nu, harmonics=H)``, condensed to the
        branch record's dofs. Without it only the ``known`` problems expand.
    known : dict, optional
        Branch id -> the problem the branch was computed with (used as it is
        when it has ``expand``), e.g. those of the running analysis.
    make : callable, optional
        ``make() -> full``, called once when ``full`` is first needed (a
        result directory's problem is built only if a row needs expanding).
    """

    def __init__(self, full=None, known: dict | None = None, make=None):
        self._full = _full_of(full)
        self._make = make
        self.known = known if known is not None else {}
        self._made: dict = {}

    @property
    def full(self):
        """The run's full problem (made on first use when given as ``make``)."""
        if self._full is None and self._make is not None:
            made, self._make = self._make(), None
            self._full = _full_of(made)
        return self._full

    @full.setter
    def full(self, problem) -> None:
        self._full = _full_of(problem)

    def problem(self, header: dict):
        """The condensed problem of the branch ``header`` describes (None when none can be made)."""
        known = self.known.get(header.get("branch"))
        if known is not None and known.condensed:
            return known
        if self.full is None:
            return None
        key = (int(header.get("nu") or 1), int(header["H"]), tuple(int(d) for d in header["dofs"]))
        if key not in self._made:
            nu, H, dofs = key
            base = self.full
            if (base.nu, base.H) != (nu, H):
                base = base.with_options(subharmonic=nu, harmonics=H)
            self._made[key] = harmonic_balance(base.model, base.parameter, base.options, base.parameters(),
                                               base.frequency, condense=dofs)
        return self._made[key]

    def __call__(self, header: dict | None, u, lam: float) -> np.ndarray | None:
        """The full coefficients of the stored ``u`` at ``lam`` (``u`` itself when it holds all of them).

        Returns None when ``u`` holds only the kept dofs and no problem to expand it is at hand.
        """
        if not stores_kept(header):
            return np.asarray(u, dtype=float)
        problem = self.problem(header)
        return None if problem is None else problem.expand(np.asarray(u, dtype=float), float(lam))
