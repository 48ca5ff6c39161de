"""The periodic-problem protocol's members of the harmonic-balance problem (:mod:`contin.model.periodic`).

The frequency and the period at ``lambda`` are those the problem's methods
give at the parameter vector ``params_at(lambda)``, and the orbit at a time
is the Fourier series of :mod:`contin.hb.harmonics` at the phase
``theta = Omega t`` (``tau = w t = nu theta``).
"""

from __future__ import annotations

import numpy as np

from contin.hb.crossings import series_at
from contin.hb.harmonics import coefficient_blocks
from contin.model.periodic import AllDofs

__all__ = ["SeriesMembers"]


class SeriesMembers(AllDofs):
    """``frequency_at``, ``period_at`` and ``orbit`` of a problem in every dof's Fourier coefficients.

    The problem provides ``n``, ``params_at(lam)``, ``excitation_frequency(p)``,
    ``base_frequency(p)`` and ``period(p)``.
    """

    def frequency_at(self, lam: float) -> float:
        """The excitation frequency ``w`` at ``lam``."""
        return self.excitation_frequency(self.params_at(lam))

    def period_at(self, lam: float) -> float:
        """The solution's period ``2 pi nu / w`` at ``lam``."""
        return self.period(self.params_at(lam))

    def orbit(self, u: np.ndarray, lam: float, t):
        """Displacements and velocities of the series ``u`` at times ``t``.

        Parameters
        ----------
        u : ndarray, shape (n (2H+1),)
        lam : float
        t : float or array_like, shape (K,)

        Returns
        -------
        x, xd : ndarray, shape (n, K)
        """
        Omega = self.base_frequency(self.params_at(lam))
        U = np.array(coefficient_blocks(np.asarray(u, dtype=float), self.n))  # C-ordered and writable, as numba takes it
        x, x1, _ = series_at(U, np.ascontiguousarray(Omega * np.atleast_1d(np.asarray(t, dtype=float))))
        return x.T.copy(), Omega * x1.T
