"""Geometric (membrane) stiffening of a string or beam reduced on shape functions (Galerkin models).

A continuous model reduced on shape functions ``phi_j(xi)``
(``w(xi) = sum_j x_j phi_j(xi)``) whose tension grows with the stretching
``int w'^2 dxi`` has a cubic force that a dense polynomial would evaluate at
``O(n^4)`` cost per time sample. With sine shapes ``phi_j = sin(j pi xi)``
the stretching is ``sum_k k^2 x_k^2 (pi^2/2)`` and the force on coordinate
``i`` is ``c * q_i x_i * sum_k q_k x_k^2`` with ``q_k = k^2`` (Nagai et al.,
Trans. JSME C 59-563 (1993), eq. 13, the term ``E_ijkl = (alpha pi^4/8) i j k
l delta_ij delta_kl``): ``O(n)`` per sample instead of the ``n^4`` tensor.

The numba kernel (``cache=True``) returns the analytic Jacobian ``df/dx``; on
one-sample views it is also the element's compiled time-domain form
(:class:`StringStretchingForm`). Built-in models build the element in Python;
it has no scene keys.
"""

from __future__ import annotations

import numpy as np

from contin.model.base import ForceElement, Monomial, register_force
from contin.model.elements.registry import CompiledForm, float_array
from contin.util.jit import njit

__all__ = ["StringStretchingForce", "StringStretchingForm"]


@njit(cache=True)
def _stretch_kernel(x, q, c, f, dfdx, want_jac):
    """``f_i += c q_i x_i S``, ``S = sum_k q_k x_k^2``, and its Jacobian.

    Parameters
    ----------
    x : ndarray, shape (N, n)
    q : ndarray, shape (n,)
        Weights (``k^2`` for sine shapes).
    c : float
    f : ndarray, shape (N, n), accumulated
    dfdx : ndarray, shape (N, n, n), accumulated if ``want_jac``
        ``df_i/dx_l = c q_i (delta_il S + 2 x_i q_l x_l)``.
    """
    N, n = x.shape
    for j in range(N):
        S = 0.0
        for k in range(n):
            S += q[k] * x[j, k] * x[j, k]
        for i in range(n):
            ci = c * q[i]
            f[j, i] += ci * x[j, i] * S
            if want_jac:
                dfdx[j, i, i] += ci * S
                g = 2.0 * ci * x[j, i]
                for l in range(n):
                    dfdx[j, i, l] += g * q[l] * x[j, l]


@register_force("string_stretching")
class StringStretchingForce(ForceElement):
    """Geometric stiffening ``f_i = c(p) q_i x_i sum_k q_k x_k^2`` (a rank-one cubic).

    Parameters
    ----------
    weights : array_like, shape (n,)
        ``q_k`` (``k^2`` for the sine shapes of a string).
    coefficient : Monomial
        ``c(p)`` (``pi^4/8 * alpha`` for the belt, paper eq. 13).
    label : str
    """

    degree = 3

    def __init__(self, weights, coefficient: Monomial, label: str = "stretching"):
        self.weights = np.ascontiguousarray(weights, dtype=float).reshape(-1)
        self.coefficient = coefficient
        self.label = label
        self._dummy = np.zeros((1, 1, 1))

    def evaluate(self, x, xd, tau, p, f, dfdx, dfdxd):
        _stretch_kernel(x, self.weights, self.coefficient.value(p), f, dfdx, True)

    def evaluate_dp(self, x, xd, tau, p, k, dfdp):
        dc = self.coefficient.derivative(p, k)
        if dc != 0.0:
            _stretch_kernel(x, self.weights, dc, dfdp, self._dummy, False)

    def depends_on(self, k):
        return self.coefficient.depends_on(k)

    def active_dofs(self):
        return tuple(np.flatnonzero(self.weights != 0.0).tolist())  # q_i = 0: no force on i, no part in the sum

    def describe(self, dof_names, param_names):
        c = self.coefficient.text(param_names)
        return (f"{self.label}: f_i += {c} * q_i x_i * sum_k q_k x_k^2 with q = "
                f"{np.array2string(self.weights, precision=4, separator=', ')} (O(n) per sample)")

    def compiled_form(self):
        return StringStretchingForm(self)


class StringStretchingForm(CompiledForm):
    """The stretching in the generated simulation module: its kernel on the one-sample views."""

    imports = ("from contin.model.elements.string_stretching import _stretch_kernel",)
    kernels = (_stretch_kernel,)

    def constants(self, p):
        return [self.element.coefficient.value(p)]

    def globals(self, tag):
        return [f"{tag}q = {float_array(self.element.weights)}"]

    def force_lines(self, tag, c, m):
        return [f"_stretch_kernel(X, {tag}q, cst[{c}], F, DUM, False)"]

    def jacobian_lines(self, tag, c, m):
        return [f"_stretch_kernel(X, {tag}q, cst[{c}], F, DX, True)"]
