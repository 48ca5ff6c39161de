"""A gap on one dof: a contact spring and dashpot beyond a clearance, on one side or both.

Everything the package needs of the element is here: its law for the
harmonic balance (:func:`_gap_kernel`) and switching functions for the
crossings and the saltation matrices (:func:`_gap_switching_kernel`), its
compiled time-domain form (:class:`GapForm`, with the frozen-mode kernels
:func:`_gap_force` and :func:`_gap_switch`) and its scene keys
(``{type: gap, dof: x, clearance: g, stiffness: k, damping: c, sides: both, clip: false}``).
"""

from __future__ import annotations

import copy

import numpy as np

from contin.model.base import Monomial, register_force
from contin.model.elements.contact import ContactForce, ContactForm, contact_values
from contin.model.elements.registry import SceneKeys, item_label, shorten
from contin.util.jit import njit

__all__ = ["GapForce", "GapForm"]

#: the scene's spelling of the sides, and the kernels' code for each
SIDES = {"+": 1, "-": -1, "both": 0}


@njit(cache=True)
def _gap_kernel(x, xd, d, g, k, c, side, clip, f, dfdx, dfdxd, dp):
    # side: +1 contact when x > g, -1 when x < -g, 0 both sides.
    # dp: 0 = forces/Jacobian; 1, 2, 3 = d/dg, d/dk, d/dc into f
    N = x.shape[0]
    for j in range(N):
        xj = x[j, d]
        vj = xd[j, d]
        if (side >= 0) and xj > g:
            pen = xj - g
            s = 1.0
        elif (side <= 0) and xj < -g:
            pen = xj + g
            s = -1.0
        else:
            continue
        F = k * pen + c * vj
        if clip and s * F <= 0.0:
            continue  # no adhesion: the contact only pushes
        if dp == 0:
            f[j, d] += F
            dfdx[j, d, d] += k
            dfdxd[j, d, d] += c
        elif dp == 1:
            f[j, d] += -k * s
        elif dp == 2:
            f[j, d] += pen
        else:
            f[j, d] += vj


@njit(cache=True)
def _gap_switching_kernel(x, xd, d, g, k, c, side, clip, val, gx, gxd, diff, jump, dx, dxd, which):
    # two functions: 0 = side + (x - g), 1 = side - (-x - g); -1 for an absent side.
    # With clip: min(penetration, (signed force)/k), the law being active iff both are positive.
    # which: 0 = values and derivatives; 1, 2, 3 = d/dg, d/dk, d/dc of h into val and of the law into diff
    N = x.shape[0]
    kref = k if k > 0.0 else 1.0
    for j in range(N):
        xj = x[j, d]
        vj = xd[j, d]
        for i in range(2):
            s = 1.0 if i == 0 else -1.0
            if (i == 0 and side < 0) or (i == 1 and side > 0):
                val[j, i] = -1.0 if which == 0 else 0.0
                continue
            pen = s * xj - g
            F = k * (xj - s * g) + c * vj  # the force of the active law
            clipped = clip and s * F / kref < pen
            if which == 1:
                val[j, i] = -k / kref if clipped else -1.0
                diff[j, i, d] = -s * k
                continue
            if which == 2:
                dk = s * (xj - s * g) / kref - (s * F / (k * k) if k > 0.0 else 0.0)
                val[j, i] = dk if clipped else 0.0
                diff[j, i, d] = xj - s * g
                continue
            if which == 3:
                val[j, i] = s * vj / kref if clipped else 0.0
                diff[j, i, d] = vj
                continue
            val[j, i] = pen
            gx[j, i, d] = s
            if clipped:
                val[j, i] = s * F / kref
                gx[j, i, d] = s * k / kref
                gxd[j, i, d] = s * c / kref
            diff[j, i, d] = F
            dx[j, i, d, d] = k
            dxd[j, i, d, d] = c
            # on the surface: c v where x = +-g, zero where the clipped force vanishes
            jump[j, i, d] = F - s * k * val[j, i]


@register_force("gap")
class GapForce(ContactForce):
    """Contact spring (and dashpot) beyond a clearance on one dof.

    ``f = k (x - g) + c x'`` while ``x > g`` (side ``+``), ``f = k (x + g) + c x'``
    while ``x < -g`` (side ``-``), both for ``sides='both'``; zero inside the
    clearance. With ``clip`` the force is set to zero when it would pull
    (adhesion through the damping term during separation).

    Parameters
    ----------
    dof : int
    clearance, stiffness, damping : Monomial
    sides : {'+', '-', 'both'}
    clip : bool
    """

    def __init__(self, dof: int, clearance: Monomial, stiffness: Monomial, damping: Monomial = Monomial(0.0),
                 sides: str = "both", clip: bool = False, label: str = "gap"):
        if not isinstance(sides, str) or sides not in SIDES:
            raise ValueError(f"gap sides must be '+', '-' or 'both', got {sides!r}")
        self.dof = dof
        self.clearance, self.stiffness, self.damping = clearance, stiffness, damping
        self.side = SIDES[sides]
        self.sides = sides
        self.clip = bool(clip)
        self.label = label
        self._dummy = np.zeros((1, 1, 1))

    n_switch = 2

    def _kernel(self, x, xd, values, f, dfdx, dfdxd, which):
        g, k, c = values
        _gap_kernel(x, xd, self.dof, g, k, c, self.side, self.clip, f, dfdx, dfdxd, which)

    def _switch_kernel(self, x, xd, values, val, gx, gxd, diff, jump, dx, dxd, which):
        g, k, c = values
        _gap_switching_kernel(x, xd, self.dof, g, k, c, self.side, self.clip, val, gx, gxd, diff, jump, dx, dxd,
                              which)

    def active_dofs(self):
        return (int(self.dof),)

    def remapped(self, kept):
        new = copy.copy(self)
        new.dof = kept.index(int(self.dof))
        return new

    def describe(self, dof_names, param_names):
        return (f"{self.label}: contact on {dof_names[self.dof]} beyond clearance (sides {self.sides}), "
                f"k*(penetration) + c*velocity{', clipped at zero' if self.clip else ''}")

    # -- scene -----------------------------------------------------------------
    scene_keys = (SceneKeys({"type": True, "dof": True, "clearance": True, "stiffness": True, "damping": False,
                             "sides": False, "clip": False},
                            example="{type: gap, dof: x, clearance: 0.1, stiffness: 1000}"),)

    @classmethod
    def from_scene(cls, item, key, scene):
        clearance, stiffness, damping = contact_values(item, key, scene)
        clip = scene.boolean(item.get("clip"), f"{key}.clip")
        d = scene.dof(item["dof"], f"{key}.dof")
        sides = item.get("sides", "both")
        sides = "both" if sides is None else sides
        if not isinstance(sides, str) or sides not in SIDES:
            raise scene.error(f"{key}.sides", "one of '+', '-', 'both' (quote the signs in YAML: \"-\")",
                              shorten(sides))
        return cls(d, clearance, stiffness, damping, sides=sides, clip=clip, label=f"{item_label(key)} gap")

    # -- time simulation ---------------------------------------------------------
    def compiled_form(self):
        return GapForm(self)


# ---------------------------------------------------------------- time simulation
@njit(cache=True)
def _gap_force(X, V, d, g, k, c, side, active_plus, active_minus, F):
    """Gap force of the frozen mode on a 1-sample view (law of :class:`GapForce`)."""
    x = X[0, d]
    v = V[0, d]
    if side >= 0 and active_plus != 0:
        F[0, d] += k * (x - g) + c * v
    if side <= 0 and active_minus != 0:
        F[0, d] += k * (x + g) + c * v


@njit(cache=True)
def _gap_switch(X, V, d, g, k, c, side, clip, S, off):
    """Switching functions of a gap: ``x - g`` (side +) and ``-x - g`` (side -); -1 for an absent side."""
    x = X[0, d]
    v = V[0, d]
    kref = k if k > 0.0 else 1.0
    if side >= 0:
        pen = x - g
        val = pen
        if clip:
            val = min(pen, (k * pen + c * v) / kref)
        S[off] = val
    else:
        S[off] = -1.0
    if side <= 0:
        pen = -x - g
        val = pen
        if clip:
            val = min(pen, (k * pen - c * v) / kref)
        S[off + 1] = val
    else:
        S[off + 1] = -1.0


@njit(cache=True)
def _gap_switch_grad(x, v, g, k, c, s, clip):
    """Gradient of a gap's switching function on the side ``s`` (+1: ``x - g``, -1: ``-x - g``) in ``(x, x')``:
    ``(gx, gv, clipped)``; with ``clip`` the branch of the ``min`` that gives the value gives the gradient
    (the force's, ``(k, c)/k``, where it is the smaller; only that branch has a velocity part)."""
    kref = k if k > 0.0 else 1.0
    pen = s * x - g
    if clip and (k * pen + s * c * v) / kref < pen:
        return s * k / kref, s * c / kref, True
    return s, 0.0, False


class GapForm(ContactForm):
    """The gap in the generated simulation module: the frozen mode's law and the two switching functions."""

    n_switch = 2
    imports = ("from contin.model.elements.gap import _gap_force, _gap_switch, _gap_switch_grad",)
    kernels = (_gap_force, _gap_switch, _gap_switch_grad)

    def dofs(self):
        return (self.element.dof,)

    def force_lines(self, tag, c, m):
        e = self.element
        return [f"_gap_force(X, V, {e.dof}, cst[{c}], cst[{c + 1}], cst[{c + 2}], {e.side}, mode[{m}], "
                f"mode[{m + 1}], F)"]

    def switch_lines(self, tag, c, m):
        e = self.element
        return [f"_gap_switch(X, V, {e.dof}, cst[{c}], cst[{c + 1}], cst[{c + 2}], {e.side}, "
                f"cst[{c + 3}] != 0.0, S, {m})"]

    def _sides(self):
        # (switching function, sign) of the gap's present sides
        side = self.element.side
        return [(i, s) for i, s in ((0, 1.0), (1, -1.0)) if (side >= 0 if i == 0 else side <= 0)]

    # the Jacobian lines and the gradients' are written out, their kernel takes numbers (see radial_gap.py: an
    # array passed to a compiled function is reference-counted at each call)
    def jacobian_lines(self, tag, c, m):
        d = self.element.dof
        lines = []
        for i, _ in self._sides():  # the frozen mode's law: k and c on the diagonal where active
            lines += [f"if mode[{m + i}] != 0:", f"    DX[0, {d}, {d}] += cst[{c + 1}]",
                      f"    DXD[0, {d}, {d}] += cst[{c + 2}]"]
        return lines

    def switch_gradient_lines(self, tag, c, m):
        d = self.element.dof
        lines = []
        for i, s in self._sides():  # an absent side is a constant -1: no gradient
            lines += [f"{tag}gx, {tag}gv, {tag}clipped = _gap_switch_grad(X[0, {d}], V[0, {d}], cst[{c}], "
                      f"cst[{c + 1}], cst[{c + 2}], {s!r}, cst[{c + 3}] != 0.0)",
                      f"G[{m + i}, {d}] = {tag}gx",
                      f"if {tag}clipped:",
                      f"    G[{m + i}, N + {d}] = {tag}gv"]
        return lines
