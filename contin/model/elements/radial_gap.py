"""Radial contact in the plane of two dofs: a bearing or a rotor in a circular clearance.

Everything the package needs of the element is here: its law for the
harmonic balance (:func:`_radial_kernel`) and switching function for the
crossings and the saltation matrices (:func:`_radial_switching_kernel`), its
compiled time-domain form (:class:`RadialGapForm`, with the frozen-mode
kernels :func:`_radial_force` and :func:`_radial_switch`) and its scene keys
(``{type: radial_gap, dofs: [x, y], clearance: delta, stiffness: k, damping: c, clip: false}``).
"""

from __future__ import annotations

import copy

import numpy as np

from contin.model.base import Monomial, register_force
from contin.model.elements.contact import ContactForce, ContactForm, contact_values
from contin.model.elements.registry import SceneKeys, item_label, shorten
from contin.util.jit import njit

__all__ = ["RadialGapForce", "RadialGapForm"]


@njit(cache=True)
def _radial_kernel(x, xd, ix, iy, delta, k, c, clip, f, dfdx, dfdxd, dp):
    # dp: 0 = forces/Jacobian; 1, 2, 3 = d/ddelta, d/dk, d/dc into f
    N = x.shape[0]
    for j in range(N):
        X = x[j, ix]
        Y = x[j, iy]
        r = np.sqrt(X * X + Y * Y)
        if r <= delta or r == 0.0:
            continue  # the law applies where r - delta > 0 (its switching function)
        ex = X / r
        ey = Y / r
        vx = xd[j, ix]
        vy = xd[j, iy]
        vn = vx * ex + vy * ey
        Fn = k * (r - delta) + c * vn
        if clip and Fn <= 0.0:
            continue
        if dp == 1:
            f[j, ix] += -k * ex
            f[j, iy] += -k * ey
            continue
        if dp == 2:
            f[j, ix] += (r - delta) * ex
            f[j, iy] += (r - delta) * ey
            continue
        if dp == 3:
            f[j, ix] += vn * ex
            f[j, iy] += vn * ey
            continue
        f[j, ix] += Fn * ex
        f[j, iy] += Fn * ey
        # d(e)/dx etc.: the radial direction turns with the position
        dexdx = ey * ey / r
        dexdy = -ex * ey / r
        deydx = dexdy
        deydy = ex * ex / r
        dvndx = vx * dexdx + vy * deydx
        dvndy = vx * dexdy + vy * deydy
        dFndx = k * ex + c * dvndx
        dFndy = k * ey + c * dvndy
        dfdx[j, ix, ix] += dFndx * ex + Fn * dexdx
        dfdx[j, ix, iy] += dFndy * ex + Fn * dexdy
        dfdx[j, iy, ix] += dFndx * ey + Fn * deydx
        dfdx[j, iy, iy] += dFndy * ey + Fn * deydy
        dfdxd[j, ix, ix] += c * ex * ex
        dfdxd[j, ix, iy] += c * ex * ey
        dfdxd[j, iy, ix] += c * ey * ex
        dfdxd[j, iy, iy] += c * ey * ey


@njit(cache=True)
def _radial_switching_kernel(x, xd, ix, iy, delta, k, c, clip, val, gx, gxd, diff, jump, dx, dxd, which):
    # h = r - delta; with clip: min(r - delta, Fn/k), the law being active iff both are positive.
    # which: 0 = values and derivatives; 1, 2, 3 = d/ddelta, d/dk, d/dc of h into val and of the law into diff
    N = x.shape[0]
    kref = k if k > 0.0 else 1.0
    for j in range(N):
        X = x[j, ix]
        Y = x[j, iy]
        r = np.sqrt(X * X + Y * Y)
        if r == 0.0:
            val[j, 0] = -delta if which == 0 else 0.0  # at the centre, away from the surface
            continue
        ex = X / r
        ey = Y / r
        vx = xd[j, ix]
        vy = xd[j, iy]
        vn = vx * ex + vy * ey
        Fn = k * (r - delta) + c * vn
        clipped = clip and Fn / kref < r - delta
        if which != 0:
            if which == 1:
                hp = -k / kref if clipped else -1.0
                Lp = -k
            elif which == 2:
                hp = ((r - delta) / kref - (Fn / (k * k) if k > 0.0 else 0.0)) if clipped else 0.0
                Lp = r - delta
            else:
                hp = vn / kref if clipped else 0.0
                Lp = vn
            val[j, 0] = hp
            diff[j, 0, ix] = Lp * ex
            diff[j, 0, iy] = Lp * ey
            continue
        # d vn / d(X, Y): the radial direction turns with the position
        dexdx = ey * ey / r
        dexdy = -ex * ey / r
        deydy = ex * ex / r
        dvndx = vx * dexdx + vy * dexdy
        dvndy = vx * dexdy + vy * deydy
        val[j, 0] = r - delta
        gx[j, 0, ix] = ex
        gx[j, 0, iy] = ey
        if clipped:
            val[j, 0] = Fn / kref
            gx[j, 0, ix] = (k * ex + c * dvndx) / kref
            gx[j, 0, iy] = (k * ey + c * dvndy) / kref
            gxd[j, 0, ix] = c * ex / kref
            gxd[j, 0, iy] = c * ey / kref
        diff[j, 0, ix] = Fn * ex
        diff[j, 0, iy] = Fn * ey
        dFndx = k * ex + c * dvndx
        dFndy = k * ey + c * dvndy
        dx[j, 0, ix, ix] = dFndx * ex + Fn * dexdx
        dx[j, 0, ix, iy] = dFndy * ex + Fn * dexdy
        dx[j, 0, iy, ix] = dFndx * ey + Fn * dexdy
        dx[j, 0, iy, iy] = dFndy * ey + Fn * deydy
        dxd[j, 0, ix, ix] = c * ex * ex
        dxd[j, 0, ix, iy] = c * ex * ey
        dxd[j, 0, iy, ix] = c * ey * ex
        dxd[j, 0, iy, iy] = c * ey * ey
        # on the surface: c vn e where r = delta, zero where the clipped Fn vanishes
        Fs = Fn - k * val[j, 0]
        jump[j, 0, ix] = Fs * ex
        jump[j, 0, iy] = Fs * ey


@register_force("radial_gap")
class RadialGapForce(ContactForce):
    """Radial contact in the plane of two dofs (a bearing in a clearance).

    ``F = Fn (x/r, y/r)`` with ``r = sqrt(x^2 + y^2)`` and, for ``r >= delta``,
    ``Fn = k (r - delta) + c (x' cos th + y' sin th)`` (Inagaki, Ishida &
    Hayashi, Trans. JSME C 71 (2005), eq. 3); zero inside the clearance. With
    ``clip``, ``Fn`` is set to zero when it would pull.

    Parameters
    ----------
    dofs : (int, int)
    clearance, stiffness, damping : Monomial
    clip : bool
    """

    def __init__(self, dofs, clearance: Monomial, stiffness: Monomial, damping: Monomial = Monomial(0.0),
                 clip: bool = False, label: str = "radial_gap"):
        self.ix, self.iy = int(dofs[0]), int(dofs[1])
        if self.ix == self.iy:
            raise ValueError("radial_gap needs two different dofs")
        self.clearance, self.stiffness, self.damping = clearance, stiffness, damping
        self.clip = bool(clip)
        self.label = label
        self._dummy = np.zeros((1, 1, 1))

    def _kernel(self, x, xd, values, f, dfdx, dfdxd, which):
        d, k, c = values
        _radial_kernel(x, xd, self.ix, self.iy, d, k, c, self.clip, f, dfdx, dfdxd, which)

    def _switch_kernel(self, x, xd, values, val, gx, gxd, diff, jump, dx, dxd, which):
        d, k, c = values
        _radial_switching_kernel(x, xd, self.ix, self.iy, d, k, c, self.clip, val, gx, gxd, diff, jump, dx, dxd,
                                 which)

    def active_dofs(self):
        return tuple(sorted((self.ix, self.iy)))

    def remapped(self, kept):
        new = copy.copy(self)
        new.ix, new.iy = kept.index(self.ix), kept.index(self.iy)
        return new

    def describe(self, dof_names, param_names):
        return (f"{self.label}: radial contact of ({dof_names[self.ix]}, {dof_names[self.iy]}) beyond a clearance, "
                f"Fn = k*(r - delta) + c*radial velocity{', clipped at zero' if self.clip else ''}")

    # -- scene -----------------------------------------------------------------
    scene_keys = (SceneKeys({"type": True, "dofs": True, "clearance": True, "stiffness": True, "damping": False,
                             "clip": False},
                            example="{type: radial_gap, dofs: [x, y], clearance: 0.1, stiffness: 1000}"),)

    @classmethod
    def from_scene(cls, item, key, scene):
        clearance, stiffness, damping = contact_values(item, key, scene)
        clip = scene.boolean(item.get("clip"), f"{key}.clip")
        dofs = item["dofs"]
        if not isinstance(dofs, list) or len(dofs) != 2:
            raise scene.error(f"{key}.dofs", "a list of two dof names [X, Y]", shorten(dofs))
        ix = scene.dof(dofs[0], f"{key}.dofs[0]")
        iy = scene.dof(dofs[1], f"{key}.dofs[1]")
        if ix == iy:
            raise scene.error(f"{key}.dofs", "two different dofs", dofs)
        return cls((ix, iy), clearance, stiffness, damping, clip=clip, label=f"{item_label(key)} radial_gap")

    # -- time simulation ---------------------------------------------------------
    def compiled_form(self):
        return RadialGapForm(self)


# ---------------------------------------------------------------- time simulation
# The Jacobian's and the gradient's kernels take and return numbers, not arrays: an array passed to a compiled
# function that is not inlined is reference-counted at each call (two atomic operations), and they run at every
# stage of a linearisation's RK4 steps. The force's and the switching function's keep their arrays: with numbers
# the plain flow's loop compiled slower (docs/howto/custom-models.md, the compiled kernels).
@njit(cache=True, inline="always")
def _radial_frame(x, y, vx, vy):
    """``(r, ex, ey, vn)``: the radius, the radial unit vector and the radial velocity (``r = 0``: zeros)."""
    r = np.sqrt(x * x + y * y)
    if r == 0.0:
        return 0.0, 0.0, 0.0, 0.0
    ex_ = x / r
    ey_ = y / r
    return r, ex_, ey_, vx * ex_ + vy * ey_


@njit(cache=True)
def _radial_force(X, V, ix, iy, delta, k, c, active, F):
    """Radial contact force of the frozen mode (law of :class:`RadialGapForce`, paper eq. 3), added to ``F``."""
    if active == 0:
        return
    r, ex_, ey_, vn = _radial_frame(X[0, ix], X[0, iy], V[0, ix], V[0, iy])
    if r == 0.0:
        return
    Fn = k * (r - delta) + c * vn
    F[0, ix] += Fn * ex_
    F[0, iy] += Fn * ey_


@njit(cache=True)
def _radial_switch(X, V, ix, iy, delta, k, c, clip, S, off):
    """Switching function ``r - delta`` (with ``clip``: ``min(r - delta, Fn/k)``), into ``S[off]``."""
    x = X[0, ix]
    y = X[0, iy]
    r = np.sqrt(x * x + y * y)
    pen = r - delta
    if clip and r > 0.0:
        kref = k if k > 0.0 else 1.0
        vn = (V[0, ix] * x + V[0, iy] * y) / r
        pen = min(pen, (k * pen + c * vn) / kref)
    S[off] = pen


@njit(cache=True)
def _radial_force_jac(x, y, vx, vy, delta, k, c, active):
    """Jacobian of :func:`_radial_force` (as in :func:`_radial_kernel`, without its test of the side):
    ``(on, dF/dx (xx, xy, yx, yy), dF/dx' (xx, xy, yx, yy))``, ``on`` False where it adds nothing."""
    if active == 0:
        return False, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    r, ex_, ey_, vn = _radial_frame(x, y, vx, vy)
    if r == 0.0:
        return False, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    Fn = k * (r - delta) + c * vn
    # the radial direction turns with the position
    dexdx = ey_ * ey_ / r
    dexdy = -ex_ * ey_ / r
    deydy = ex_ * ex_ / r
    dvndx = vx * dexdx + vy * dexdy
    dvndy = vx * dexdy + vy * deydy
    dFndx = k * ex_ + c * dvndx
    dFndy = k * ey_ + c * dvndy
    return (True, dFndx * ex_ + Fn * dexdx, dFndy * ex_ + Fn * dexdy, dFndx * ey_ + Fn * dexdy,
            dFndy * ey_ + Fn * deydy, c * ex_ * ex_, c * ex_ * ey_, c * ey_ * ex_, c * ey_ * ey_)


@njit(cache=True)
def _radial_switch_grad(x, y, vx, vy, delta, k, c, clip):
    """Gradient of :func:`_radial_switch` in ``(x, y, vx, vy)`` (the branch of the ``min``):
    ``(which, gx, gy, gvx, gvy)``, ``which`` 0 at the centre (no direction: the surface is far), 1 for
    ``r - delta`` (no velocity part), 2 for the clipped branch."""
    r = np.sqrt(x * x + y * y)
    if r == 0.0:
        return 0, 0.0, 0.0, 0.0, 0.0
    ex_ = x / r
    ey_ = y / r
    pen = r - delta
    if clip:
        kref = k if k > 0.0 else 1.0
        vn = vx * ex_ + vy * ey_
        if (k * pen + c * vn) / kref < pen:
            dexdx = ey_ * ey_ / r
            dexdy = -ex_ * ey_ / r
            deydy = ex_ * ex_ / r
            return (2, (k * ex_ + c * (vx * dexdx + vy * dexdy)) / kref,
                    (k * ey_ + c * (vx * dexdy + vy * deydy)) / kref, c * ex_ / kref, c * ey_ / kref)
    return 1, ex_, ey_, 0.0, 0.0


class RadialGapForm(ContactForm):
    """The radial contact in the generated simulation module: the frozen mode's law and ``r - delta``."""

    n_switch = 1
    imports = ("from contin.model.elements.radial_gap import _radial_force, _radial_force_jac, _radial_switch, "
               "_radial_switch_grad",)
    kernels = (_radial_force, _radial_switch, _radial_force_jac, _radial_switch_grad)

    def dofs(self):
        # the radial direction may point along either dof
        return (self.element.ix, self.element.iy)

    def _call(self, kernel, c, last):
        # the kernel's arguments: the bearing's displacement and velocity, the law's constants and ``last``
        e = self.element
        return (f"{kernel}(X[0, {e.ix}], X[0, {e.iy}], V[0, {e.ix}], V[0, {e.iy}], cst[{c}], cst[{c + 1}], "
                f"cst[{c + 2}], {last})")

    def force_lines(self, tag, c, m):
        e = self.element
        return [f"_radial_force(X, V, {e.ix}, {e.iy}, cst[{c}], cst[{c + 1}], cst[{c + 2}], mode[{m}], F)"]

    def switch_lines(self, tag, c, m):
        e = self.element
        return [f"_radial_switch(X, V, {e.ix}, {e.iy}, cst[{c}], cst[{c + 1}], cst[{c + 2}], "
                f"cst[{c + 3}] != 0.0, S, {m})"]

    def jacobian_lines(self, tag, c, m):
        e = self.element
        names = [f"{tag}j{i}" for i in range(8)]
        lines = [f"{tag}on, {', '.join(names)} = {self._call('_radial_force_jac', c, f'mode[{m}]')}",
                 f"if {tag}on:"]
        cells = [(a, b) for a in (e.ix, e.iy) for b in (e.ix, e.iy)]
        lines += [f"    DX[0, {a}, {b}] += {name}" for (a, b), name in zip(cells, names[:4])]
        lines += [f"    DXD[0, {a}, {b}] += {name}" for (a, b), name in zip(cells, names[4:])]
        return lines

    def switch_gradient_lines(self, tag, c, m):
        e = self.element
        return [f"{tag}w, {tag}gx, {tag}gy, {tag}gvx, {tag}gvy = "
                f"{self._call('_radial_switch_grad', c, f'cst[{c + 3}] != 0.0')}",
                f"if {tag}w != 0:",
                f"    G[{m}, {e.ix}] = {tag}gx",
                f"    G[{m}, {e.iy}] = {tag}gy",
                f"if {tag}w == 2:",
                f"    G[{m}, N + {e.ix}] = {tag}gvx",
                f"    G[{m}, N + {e.iy}] = {tag}gvy"]
