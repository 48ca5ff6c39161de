"""What the contact elements share: clearance, stiffness and damping, their switching data and scene checks.

A contact element (:mod:`contin.model.elements.gap`,
:mod:`contin.model.elements.radial_gap`) has three parameter-dependent
coefficients: a clearance, a contact stiffness and a contact damping. Its
numba kernels take them as numbers and a selector ``which``: 0 for the law
(force and Jacobians, or switching functions and their gradients), 1, 2, 3
for the derivatives with respect to the clearance, stiffness and damping.
"""

from __future__ import annotations

from typing import Mapping

import numpy as np

from contin.model.base import ForceElement, Switching
from contin.model.elements.registry import CompiledForm, shorten
from contin.model.expressions.nodes import Var

__all__ = ["ContactForce", "ContactForm", "coefficient_parameter", "contact_values"]


class ContactForce(ForceElement):
    """Shared parameter handling of the contact elements (clearance, stiffness, damping).

    Subclasses set ``clearance``, ``stiffness``, ``damping`` (coefficients
    with ``value``, ``derivative``, ``depends_on``) and implement
    :meth:`_kernel` and :meth:`_switch_kernel`.
    """

    degree = None
    #: number of switching functions
    n_switch = 1

    def _values(self, p):
        return self.clearance.value(p), self.stiffness.value(p), self.damping.value(p)

    def _kernel(self, x, xd, values, f, dfdx, dfdxd, which):
        raise NotImplementedError

    def _switch_kernel(self, x, xd, values, val, gx, gxd, diff, jump, dx, dxd, which):
        raise NotImplementedError

    def _switching(self, x, xd, values, which):
        N, n = x.shape
        m = self.n_switch
        out = Switching(np.zeros((N, m)), np.zeros((N, m, n)), np.zeros((N, m, n)), np.zeros((N, m, n)),
                        np.zeros((N, m, n)), np.zeros((N, m, n, n)), np.zeros((N, m, n, n)))
        self._switch_kernel(np.ascontiguousarray(x, dtype=float), np.ascontiguousarray(xd, dtype=float),
                            values, out.value, out.grad_x, out.grad_xd, out.difference, out.jump,
                            out.difference_x, out.difference_xd, which)
        return out

    def switching_functions(self, x, xd, tau, p):
        """The contact surfaces (see :class:`contin.model.base.Switching`); jumps of the damping term included."""
        return self._switching(x, xd, self._values(p), 0)

    def switching_dp(self, x, xd, tau, p, k):
        N, n = x.shape
        hp = np.zeros((N, self.n_switch))
        Lp = np.zeros((N, self.n_switch, n))
        values = self._values(p)
        for which, mono in ((1, self.clearance), (2, self.stiffness), (3, self.damping)):
            dm = mono.derivative(p, k)
            if dm != 0.0:
                sw = self._switching(x, xd, values, which)
                hp += dm * sw.value
                Lp += dm * sw.difference
        return hp, Lp

    def evaluate(self, x, xd, tau, p, f, dfdx, dfdxd):
        self._kernel(x, xd, self._values(p), f, dfdx, dfdxd, 0)

    def evaluate_dp(self, x, xd, tau, p, k, dfdp):
        values = self._values(p)
        for which, mono in ((1, self.clearance), (2, self.stiffness), (3, self.damping)):
            dm = mono.derivative(p, k)
            if dm != 0.0:
                tmp = np.zeros_like(dfdp)
                self._kernel(x, xd, values, tmp, self._dummy, self._dummy, which)
                dfdp += dm * tmp

    def depends_on(self, k):
        return any(m.depends_on(k) for m in (self.clearance, self.stiffness, self.damping))

    def contact_parameters(self, param_names):
        """The parameters that are the contact's stiffness and clearance (None where a coefficient is not one)."""
        return coefficient_parameter(self.stiffness, param_names), coefficient_parameter(self.clearance, param_names)

    def _contact_matrices(self, p, n: int, dofs):
        """Contact stiffness and damping on the diagonal of ``dofs``, shape (n, n) each (the RK4 step check)."""
        _, k, c = self._values(p)
        Kc, Cc = np.zeros((n, n)), np.zeros((n, n))
        for i in dofs:
            Kc[i, i] = k
            Cc[i, i] = c
        return Kc, Cc


def coefficient_parameter(coefficient, param_names) -> str | None:
    """The parameter a coefficient is, when it is exactly one parameter (``k``; not ``2*k``, ``k**2`` or a number).

    Parameters
    ----------
    coefficient : Monomial or ExpressionCoefficient
    param_names : sequence of str
        The model's parameters, in the order of the parameter vector.

    Returns
    -------
    str or None
    """
    powers = getattr(coefficient, "powers", None)
    if powers is not None:  # a Monomial: const * prod p[j]**e
        if coefficient.const == 1.0 and len(powers) == 1 and powers[0][1] == 1:
            return param_names[powers[0][0]]
        return None
    node = getattr(coefficient, "node", None)  # an expression: one parameter's name alone
    if isinstance(node, Var) and node.name in param_names:
        return node.name
    return None


def contact_values(item: Mapping, key: str, scene):
    """Clearance, stiffness and damping of a contact item; none of them may be negative.

    A negative clearance would put the stop inside the free play, a
    negative stiffness or damping would pull the body into the stop. Zero
    is allowed: a stop touching at rest, a stop without elastic or viscous
    force (a limiting case, e.g. in a sweep of the stiffness).

    Parameters
    ----------
    item : mapping
        The scene item (keys ``clearance``, ``stiffness``, optional ``damping``).
    key : str
        Its dotted key.
    scene : contin.model.elements.registry.SceneContext

    Returns
    -------
    clearance, stiffness, damping : coefficients
    """
    clearance = scene.coefficient(item["clearance"], f"{key}.clearance")
    if clearance.value(scene.p0) < 0:
        raise scene.error(f"{key}.clearance", "a clearance >= 0 at the default parameters",
                          shorten(item["clearance"]))
    stiffness = scene.coefficient(item["stiffness"], f"{key}.stiffness")
    if stiffness.value(scene.p0) < 0:
        raise scene.error(f"{key}.stiffness", "a contact stiffness >= 0 at the default parameters (a negative "
                          "one would pull the body into the stop)", shorten(item["stiffness"]),
                          f"; it is {stiffness.value(scene.p0):g}")
    damping = item.get("damping")
    damping = scene.coefficient(0.0 if damping is None else damping, f"{key}.damping")
    if damping.value(scene.p0) < 0:
        raise scene.error(f"{key}.damping", "a contact damping >= 0 at the default parameters (a negative one "
                          "would feed energy in at every impact)", shorten(item["damping"]),
                          f"; it is {damping.value(scene.p0):g}")
    return clearance, stiffness, damping


class ContactForm(CompiledForm):
    """A contact element's compiled form: its three coefficients and the clip flag are the constants."""

    def dofs(self) -> tuple:
        """The dofs the contact force acts on."""
        raise NotImplementedError

    def constants(self, p):
        return list(self.element._values(p)) + [1.0 if self.element.clip else 0.0]

    def contact_matrices(self, p, n):
        return self.element._contact_matrices(p, n, self.dofs())
