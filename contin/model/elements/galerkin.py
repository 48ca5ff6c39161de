"""Forces of Galerkin (assumed-mode) models of strings and beams.

Two laws that a continuous model reduced on shape functions ``phi_j(xi)``
(``w(xi) = sum_j x_j phi_j(xi)``) produces and that a dense polynomial would
evaluate at ``O(n^4)`` cost per time sample:

- :class:`StringStretchingForce`: the geometric (membrane) stiffening of a
  string or beam whose tension grows with the stretching ``int w'^2 dxi``.
  With sine shapes ``phi_j = sin(j pi xi)`` the stretching is
  ``sum_k k^2 x_k^2 (pi^2/2)`` and the force on coordinate ``i`` is
  ``c * q_i x_i * sum_k q_k x_k^2`` with ``q_k = k^2`` (Nagai et al., Trans.
  JSME C 59-563 (1993), eq. 13, the term ``E_ijkl = (alpha pi^4/8) i j k l
  delta_ij delta_kl``): ``O(n)`` per sample instead of the ``n^4`` tensor.
- :class:`PointForce`: a force ``q(y)`` acting at one point ``xi_1`` of the
  structure, polynomial in the displacement there, ``y = sum_j s_j x_j``
  with ``s_j = phi_j(xi_1)``; projected on the shapes it is ``s_i q(y)``
  (the paper's magnet, the terms ``C, D, E`` with ``gamma_k``): ``O(n)``
  per sample too.

Both are registered force elements with numba kernels (``cache=True``) that
return the analytic Jacobian ``df/dx``; they have compiled forms for the time
simulation of :mod:`contin.timedomain.simulation`.
"""

from __future__ import annotations

from typing import Sequence

import numba as nb
import numpy as np

from contin.model.base import ForceElement, Monomial, register_force

__all__ = ["StringStretchingForce", "PointForce"]


@nb.njit(cache=True)
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


@nb.njit(cache=True)
def _point_kernel(x, s, poly, f, dfdx, want_jac):
    """``f_i += s_i q(y)``, ``y = s . x``, ``q(y) = sum_k poly[k] y^k``, and its Jacobian.

    Parameters
    ----------
    x : ndarray, shape (N, n)
    s : ndarray, shape (n,)
        Shape values at the point.
    poly : ndarray, shape (K+1,)
        Coefficients of ``y^0 .. y^K``.
    f : ndarray, shape (N, n), accumulated
    dfdx : ndarray, shape (N, n, n), accumulated if ``want_jac``
        ``df_i/dx_l = s_i s_l q'(y)``.
    """
    N, n = x.shape
    K = poly.shape[0] - 1
    for j in range(N):
        y = 0.0
        for k in range(n):
            y += s[k] * x[j, k]
        qv = poly[K]
        dq = 0.0
        for k in range(K - 1, -1, -1):  # Horner for q and q'
            dq = dq * y + qv
            qv = qv * y + poly[k]
        for i in range(n):
            if s[i] == 0.0:
                continue
            f[j, i] += s[i] * qv
            if want_jac:
                g = s[i] * dq
                for l in range(n):
                    dfdx[j, i, l] += g * s[l]


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
        c = _format(self.coefficient, param_names)
        return (f"{self.label}: f_i += {c} * q_i x_i * sum_k q_k x_k^2 with q = "
                f"{np.array2string(self.weights, precision=4, separator=', ')} (O(n) per sample)")


@register_force("point_polynomial")
class PointForce(ForceElement):
    """A force polynomial in the displacement at one point: ``f_i = s_i sum_k c_k(p) y^k``, ``y = s . x``.

    Parameters
    ----------
    shape : array_like, shape (n,)
        ``s_i``, the shape functions at the point.
    coefficients : sequence of (int, Monomial)
        ``(k, c_k)``: power and coefficient.
    label : str
    """

    def __init__(self, shape, coefficients: Sequence, label: str = "point force"):
        self.shape = np.ascontiguousarray(shape, dtype=float).reshape(-1)
        if not coefficients:
            raise ValueError("a point force needs at least one coefficient")
        powers = [int(k) for k, _ in coefficients]
        if min(powers) < 0 or len(set(powers)) != len(powers):
            raise ValueError(f"point force powers must be distinct non-negative integers, got {powers}")
        self.coefficients = tuple((int(k), c) for k, c in coefficients)
        self.degree = max(powers)
        self.label = label
        self._dummy = np.zeros((1, 1, 1))

    def _poly(self, p, k=None) -> np.ndarray:
        out = np.zeros(self.degree + 1)
        for power, c in self.coefficients:
            out[power] = c.value(p) if k is None else c.derivative(p, k)
        return out

    def evaluate(self, x, xd, tau, p, f, dfdx, dfdxd):
        _point_kernel(x, self.shape, self._poly(p), f, dfdx, True)

    def evaluate_dp(self, x, xd, tau, p, k, dfdp):
        dpoly = self._poly(p, k)
        if np.any(dpoly != 0.0):
            _point_kernel(x, self.shape, dpoly, dfdp, self._dummy, False)

    def depends_on(self, k):
        return any(c.depends_on(k) for _, c in self.coefficients)

    def active_dofs(self):
        return tuple(np.flatnonzero(self.shape != 0.0).tolist())  # s_i = 0: neither pushed nor part of y

    def describe(self, dof_names, param_names):
        terms = " + ".join(f"{_format(c, param_names)}*y^{k}" for k, c in self.coefficients)
        return (f"{self.label}: f_i += s_i ({terms}), y = s . x with s = "
                f"{np.array2string(self.shape, precision=4, separator=', ')}")


def _format(c: Monomial, names) -> str:
    s = f"{c.const:g}"
    for j, e in c.powers:
        s += f"*{names[j]}" + (f"**{e}" if e != 1 else "")
    return s


def _register_compiled_forms():
    """Compiled forms for :mod:`contin.timedomain.simulation` (the kernels on one-sample views)."""
    from contin.timedomain.simulation import CompiledForm, _float_array, register_compiled_form

    @register_compiled_form(StringStretchingForce)
    class StretchingForm(CompiledForm):
        imports = ("from contin.model.elements.galerkin import _stretch_kernel",)
        kernels = (_stretch_kernel,)

        def constants(self, p):
            return [self.element.coefficient.value(p)]

        def globals(self, tag):
            return [f"{tag}q = {_float_array(self.element.weights)}"]

        def force_lines(self, tag, c, m):
            return [f"_stretch_kernel(X, {tag}q, cst[{c}], F, DUM, False)"]

    @register_compiled_form(PointForce)
    class PointForm(CompiledForm):
        imports = ("from contin.model.elements.galerkin import _point_kernel",)
        kernels = (_point_kernel,)

        def constants(self, p):
            return list(self.element._poly(p))

        def globals(self, tag):
            return [f"{tag}s = {_float_array(self.element.shape)}"]

        def force_lines(self, tag, c, m):
            K = self.element.degree + 1
            return [f"_point_kernel(X, {tag}s, cst[{c}:{c + K}], F, DUM, False)"]


_register_compiled_forms()
