"""Polynomial internal forces: sums of monomials in displacements and velocities.

The element's law (:func:`_poly_kernel`, with its Jacobians) serves the
harmonic balance, and the same kernel on one-sample views is its compiled
time-domain form (:class:`PolynomialForm`). Built-in models build it in Python
(:mod:`contin.models.polynomial`); custom scene models write polynomials as
expression forces (:mod:`contin.model.elements.expression`).
"""

from __future__ import annotations

import copy

from typing import Sequence

import numpy as np

from contin.model.base import ForceElement, register_force
from contin.model.elements.registry import CompiledForm, float_array, int_array
from contin.util.jit import njit

__all__ = ["PolynomialForce", "PolynomialForm"]


@njit(cache=True)
def _poly_kernel(x, xd, tau, target, coef, ex, ev, torder, tphase, f, dfdx, dfdxd, want_jac):
    N, n = x.shape
    T = target.shape[0]
    for j in range(N):
        for t in range(T):
            r = target[t]
            c = coef[t]
            if torder[t] != 0.0:
                c *= np.cos(torder[t] * tau[j] + tphase[t])
            val = c
            for i in range(n):
                if ex[t, i] != 0:
                    val *= x[j, i] ** ex[t, i]
                if ev[t, i] != 0:
                    val *= xd[j, i] ** ev[t, i]
            f[j, r] += val
            if not want_jac:
                continue
            for i in range(n):
                for which in range(2):
                    e = ex[t, i] if which == 0 else ev[t, i]
                    if e == 0:
                        continue
                    d = c * e
                    for q in range(n):
                        eq = ex[t, q]
                        vq = ev[t, q]
                        if which == 0 and q == i:
                            eq -= 1
                        if which == 1 and q == i:
                            vq -= 1
                        if eq != 0:
                            d *= x[j, q] ** eq
                        if vq != 0:
                            d *= xd[j, q] ** vq
                    if which == 0:
                        dfdx[j, r, i] += d
                    else:
                        dfdxd[j, r, i] += d


@register_force("polynomial")
class PolynomialForce(ForceElement):
    """``f_r += c(p) * cos(o tau + phi) * prod_i x_i**e_i * xdot_i**d_i`` for a list of terms.

    The optional factor ``cos(o tau + phi)`` (``o = 0``: none) makes parametric
    excitation, e.g. the Mathieu term ``eps*cos(tau)*x``.

    Parameters
    ----------
    n_dof : int
    terms : sequence of (target, Monomial, ex, ev) or (target, Monomial, ex, ev, o, phi)
        ``target`` dof index; coefficient; integer exponent vectors of
        shape (n,) for displacements and velocities; order and phase in tau.
    label : str
        Effect name for reports.
    """

    def __init__(self, n_dof: int, terms: Sequence, label: str = "polynomial"):
        if not terms:
            raise ValueError("a polynomial force needs at least one term")
        self.n_dof = n_dof
        self.label = label
        self.target = np.array([t[0] for t in terms], dtype=np.int64)
        self.coefs = [t[1] for t in terms]
        self.ex = np.array([t[2] for t in terms], dtype=np.int64).reshape(len(terms), n_dof)
        self.ev = np.array([t[3] for t in terms], dtype=np.int64).reshape(len(terms), n_dof)
        if np.any(self.ex < 0) or np.any(self.ev < 0):
            raise ValueError("polynomial exponents must be non-negative integers")
        self.torder = np.array([float(t[4]) if len(t) > 4 else 0.0 for t in terms])
        self.tphase = np.array([float(t[5]) if len(t) > 5 else 0.0 for t in terms])
        self.degree = int(np.max(self.ex.sum(axis=1) + self.ev.sum(axis=1)))
        self._dummy = np.zeros((1, 1, 1))

    def _coef(self, p):
        return np.array([c.value(p) for c in self.coefs])

    def evaluate(self, x, xd, tau, p, f, dfdx, dfdxd):
        _poly_kernel(x, xd, tau, self.target, self._coef(p), self.ex, self.ev, self.torder, self.tphase, f, dfdx, dfdxd, True)

    def evaluate_dp(self, x, xd, tau, p, k, dfdp):
        dc = np.array([c.derivative(p, k) for c in self.coefs])
        if np.any(dc != 0.0):
            _poly_kernel(
                x, xd, tau, self.target, dc, self.ex, self.ev, self.torder, self.tphase, dfdp, self._dummy, self._dummy, False
            )

    def depends_on(self, k):
        return any(c.depends_on(k) for c in self.coefs)

    def tau_orders(self):
        return tuple(float(o) for o in self.torder if o != 0.0)

    def active_dofs(self):
        used = set(int(t) for t in self.target)
        used |= set(np.flatnonzero((self.ex != 0).any(axis=0) | (self.ev != 0).any(axis=0)).tolist())
        return tuple(sorted(used))

    def remapped(self, kept):
        new = copy.copy(self)
        cols = np.asarray(kept, dtype=np.int64)
        new.n_dof = len(kept)
        new.target = np.array([kept.index(int(t)) for t in self.target], dtype=np.int64)
        new.ex = np.ascontiguousarray(self.ex[:, cols])
        new.ev = np.ascontiguousarray(self.ev[:, cols])
        return new

    def describe(self, dof_names, param_names):
        parts = []
        for t, c in enumerate(self.coefs):
            mono = c.text(param_names)
            for i, name in enumerate(dof_names):
                for e, suffix in ((self.ex[t, i], ""), (self.ev[t, i], "_dot")):
                    if e:
                        mono += f"*{name}{suffix}" + (f"**{e}" if e > 1 else "")
            if self.torder[t]:
                mono += f"*cos({self.torder[t]:g}*tau{self.tphase[t]:+g})"
            parts.append(f"{dof_names[self.target[t]]}: +{mono}")
        return f"{self.label} (polynomial, degree {self.degree}): " + "; ".join(parts)

    def compiled_form(self):
        return PolynomialForm(self)


class PolynomialForm(CompiledForm):
    """The polynomial in the generated simulation module: its kernel on the one-sample views (Jacobian too)."""

    imports = ("from contin.model.elements.polynomial import _poly_kernel",)
    kernels = (_poly_kernel,)

    def constants(self, p):
        return list(self.element._coef(p))

    def globals(self, tag):
        e = self.element
        return [f"{tag}target = {int_array(e.target)}",
                f"{tag}ex = {int_array(e.ex)}",
                f"{tag}ev = {int_array(e.ev)}",
                f"{tag}torder = {float_array(e.torder)}",
                f"{tag}tphase = {float_array(e.tphase)}"]

    def force_lines(self, tag, c, m):
        T = len(self.element.coefs)
        return [f"_poly_kernel(X, V, TAU, {tag}target, cst[{c}:{c + T}], {tag}ex, {tag}ev, {tag}torder, "
                f"{tag}tphase, F, DUM, DUM, False)"]

    def jacobian_lines(self, tag, c, m):
        T = len(self.element.coefs)
        return [f"_poly_kernel(X, V, TAU, {tag}target, cst[{c}:{c + T}], {tag}ex, {tag}ev, {tag}torder, "
                f"{tag}tphase, F, DX, DXD, True)"]

