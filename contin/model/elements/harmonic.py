"""Harmonic and constant external forcing."""

from __future__ import annotations

import numpy as np

from contin.model.base import ExcitationElement, Monomial, register_excitation

__all__ = ["HarmonicExcitation"]


@register_excitation("harmonic")
class HarmonicExcitation(ExcitationElement):
    """``f_ext[dof] += A(p) * cos(order*tau + phase)`` (``order = 0``: a constant ``A``).

    Parameters
    ----------
    dof : int
    amplitude : Monomial
    order : float
        Multiple of the excitation phase ``tau = w t`` (1 for forcing at w).
    phase : float
        Radians; ``-pi/2`` gives ``sin(order*tau)``.
    label : str
    """

    def __init__(self, dof: int, amplitude: Monomial, order: float = 1.0, phase: float = 0.0, label: str = "forcing"):
        if order < 0:
            raise ValueError(f"excitation order must be >= 0, got {order}")
        self.dof = dof
        self.amplitude = amplitude
        self.order = float(order)
        self.phase = float(phase)
        self.label = label

    def _shape(self, tau):
        if self.order == 0.0:
            return np.full(tau.shape, np.cos(self.phase))
        return np.cos(self.order * tau + self.phase)

    def evaluate(self, tau, p, f):
        f[:, self.dof] += self.amplitude.value(p) * self._shape(tau)

    def evaluate_dp(self, tau, p, k, dfdp):
        if self.amplitude.depends_on(k):
            dfdp[:, self.dof] += self.amplitude.derivative(p, k) * self._shape(tau)

    def depends_on(self, k):
        return self.amplitude.depends_on(k)

    def max_order(self):
        return self.order

    def describe(self, dof_names, param_names):
        amp = f"{self.amplitude.const:g}" + "".join(
            f"*{param_names[j]}" + (f"**{e}" if e != 1 else "") for j, e in self.amplitude.powers
        )
        if self.order == 0.0:
            return f"{self.label}: {dof_names[self.dof]} += {amp}*{np.cos(self.phase):g} (constant)"
        return f"{self.label}: {dof_names[self.dof]} += {amp}*cos({self.order:g}*tau{self.phase:+g})"
