"""A force polynomial in the displacement at one point of a structure reduced on shape functions.

A force ``q(y)`` acting at one point ``xi_1`` of a structure reduced on shape
functions ``phi_j(xi)``, polynomial in the displacement there,
``y = sum_j s_j x_j`` with ``s_j = phi_j(xi_1)``; projected on the shapes it
is ``s_i q(y)`` (Nagai et al., Trans. JSME C 59-563 (1993): the magnet, the
terms ``C, D, E`` with ``gamma_k``): ``O(n)`` per sample, where a dense
polynomial would cost ``O(n^4)``.

The numba kernel (``cache=True``) returns the analytic Jacobian ``df/dx``; on
one-sample views it is also the element's compiled time-domain form
(:class:`PointForm`). Built-in models build the element in Python; it has no
scene keys.
"""

from __future__ import annotations

import copy

from typing import Sequence

import numpy as np

from contin.model.base import ForceElement, register_force
from contin.model.elements.registry import CompiledForm, float_array
from contin.util.jit import njit

__all__ = ["PointForce", "PointForm"]


@njit(cache=True)
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

    def remapped(self, kept):
        new = copy.copy(self)
        new.shape = np.ascontiguousarray(self.shape[np.asarray(kept, dtype=int)])
        return new

    def describe(self, dof_names, param_names):
        terms = " + ".join(f"{c.text(param_names)}*y^{k}" for k, c in self.coefficients)
        return (f"{self.label}: f_i += s_i ({terms}), y = s . x with s = "
                f"{np.array2string(self.shape, precision=4, separator=', ')}")

    def compiled_form(self):
        return PointForm(self)


class PointForm(CompiledForm):
    """The point force in the generated simulation module: its kernel on the one-sample views."""

    imports = ("from contin.model.elements.point_polynomial import _point_kernel",)
    kernels = (_point_kernel,)

    def constants(self, p):
        return list(self.element._poly(p))

    def globals(self, tag):
        return [f"{tag}s = {float_array(self.element.shape)}"]

    def force_lines(self, tag, c, m):
        K = self.element.degree + 1
        return [f"_point_kernel(X, {tag}s, cst[{c}:{c + K}], F, DUM, False)"]

    def jacobian_lines(self, tag, c, m):
        K = self.element.degree + 1
        return [f"_point_kernel(X, {tag}s, cst[{c}:{c + K}], F, DX, True)"]
