"""Harmonic and constant external forcing: ``A(p) cos(order tau + phase)`` on one dof.

Its scene keys are ``{dof: x, amplitude: F, order: 1, phase: 0}`` and
``{dof: x, constant: f0}``; an amplitude that is no product of parameter
powers joins the expression excitation
(:mod:`contin.model.elements.expression_excitation`). Its compiled
time-domain form is one cosine line (:class:`HarmonicForm`).
"""

from __future__ import annotations

import math

import numpy as np

from contin.model import expressions as ex
from contin.model.base import ExcitationElement, Monomial, register_excitation
from contin.model.elements.expression_excitation import ExpressionExcitation
from contin.model.elements.registry import CompiledForm, Joined, SceneKeys, item_label, literal

__all__ = ["HarmonicExcitation", "HarmonicForm"]


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
        amp = self.amplitude.text(param_names)
        if self.order == 0.0:
            return f"{self.label}: {dof_names[self.dof]} += {amp}*{np.cos(self.phase):g} (constant)"
        return f"{self.label}: {dof_names[self.dof]} += {amp}*cos({self.order:g}*tau{self.phase:+g})"

    # -- scene -----------------------------------------------------------------
    scene_keys = (SceneKeys({"dof": True, "amplitude": True, "order": False, "phase": False},
                            example="{dof: x, amplitude: F, order: 1, phase: 0}", marker="amplitude"),
                  SceneKeys({"dof": True, "constant": True}, example="{dof: x, constant: f0}", marker="constant"))

    @classmethod
    def from_scene(cls, item, key, scene):
        d = scene.dof(item["dof"], f"{key}.dof")
        if "amplitude" in item:
            coef = scene.coefficient(item["amplitude"], f"{key}.amplitude")
            order = scene.number(item.get("order"), f"{key}.order", 1.0, minimum=0)
            phase = scene.number(item.get("phase"), f"{key}.phase", 0.0)
        else:
            coef = scene.coefficient(item["constant"], f"{key}.constant")
            order, phase = 0.0, 0.0
        if isinstance(coef, Monomial):
            return cls(d, coef, order, phase, label=item_label(key))
        # an amplitude that is no monomial: evaluated as an expression of the parameters
        shape = ex.call("cos", ex.add(ex.mul(ex.Num(order), ex.Var("tau")), ex.Num(phase)))
        return Joined(ExpressionExcitation, (d, ex.mul(coef.node, shape)))

    # -- time simulation ---------------------------------------------------------
    def compiled_form(self):
        return HarmonicForm(self)


class HarmonicForm(CompiledForm):
    """The forcing in the generated simulation module: its amplitude is a constant, the cosine a line."""

    #: its lines are linear in its constants (``A cos(k tau + phi)``, ``A``): the same lines with the constants'
    #: derivatives give the excitation's derivative in a parameter (contin.timedomain.variational)
    linear_in_constants = True

    def constants(self, p):
        e = self.element
        A = e.amplitude.value(p)
        return [A * math.cos(e.phase) if e.order == 0.0 else A]

    def excitation_lines(self, tag, c):
        e = self.element
        if e.order == 0.0:
            return [f"R[{e.dof}] += cst[{c}]"]
        return [f"R[{e.dof}] += cst[{c}] * np.cos({literal(e.order)} * tau + {literal(e.phase)})"]

    def excitation_dtau_lines(self, tag, c):
        # d/dtau A cos(order tau + phase) = -A order sin(order tau + phase); a constant adds nothing
        e = self.element
        if e.order == 0.0:
            return []
        o = literal(e.order)
        return [f"R[{e.dof}] -= cst[{c}] * {o} * np.sin({o} * tau + {literal(e.phase)})"]
