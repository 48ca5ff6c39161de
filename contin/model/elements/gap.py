"""Piecewise-linear contact forces: a gap on one dof and a radial clearance in a plane."""

from __future__ import annotations

import numba as nb
import numpy as np

from contin.model.base import ForceElement, Monomial, Switching, register_force

__all__ = ["GapForce", "RadialGapForce"]


@nb.njit(cache=True)
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


@nb.njit(cache=True)
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


class _ContactForce(ForceElement):
    """Shared parameter handling of the contact elements (clearance, stiffness, damping)."""

    degree = None

    def _values(self, p):
        return self.clearance.value(p), self.stiffness.value(p), self.damping.value(p)

    def _kernel(self, x, xd, values, f, dfdx, dfdxd, which):
        raise NotImplementedError

    #: number of switching functions
    n_switch = 1

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


@register_force("gap")
class GapForce(_ContactForce):
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
        if sides not in ("+", "-", "both"):
            raise ValueError(f"gap sides must be '+', '-' or 'both', got {sides!r}")
        self.dof = dof
        self.clearance, self.stiffness, self.damping = clearance, stiffness, damping
        self.side = {"+": 1, "-": -1, "both": 0}[sides]
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

    def describe(self, dof_names, param_names):
        return (f"{self.label}: contact on {dof_names[self.dof]} beyond clearance (sides {self.sides}), "
                f"k*(penetration) + c*velocity{', clipped at zero' if self.clip else ''}")


@nb.njit(cache=True)
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


@nb.njit(cache=True)
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
class RadialGapForce(_ContactForce):
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

    def describe(self, dof_names, param_names):
        return (f"{self.label}: radial contact of ({dof_names[self.ix]}, {dof_names[self.iy]}) beyond a clearance, "
                f"Fn = k*(r - delta) + c*radial velocity{', clipped at zero' if self.clip else ''}")
