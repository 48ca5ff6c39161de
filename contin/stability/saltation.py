"""Switching events along the HB orbit and their saltation matrices.

The orbit is evaluated exactly at any time from its trigonometric series
(:func:`orbit_state`); the switches are located on it and the saltation
matrices built there (:func:`switching_events`). The piecewise RK4 path
between the switches is :func:`contin.stability.monodromy.monodromy_rk4`.

Non-smooth forces: switches and saltation matrices
--------------------------------------------------
A contact law is piecewise: each force element with a switching surface
reports it through :meth:`contin.model.base.ForceElement.switching_functions`
(value ``h``, gradient ``n = (dh/dx, dh/dx')`` and the jump of the force
across the surface; the gap and radial-gap contacts do, ``h = r - delta`` or,
with ``clip``, ``min(r - delta, Fn/k)`` so that the end of contact where the
clipped force reaches zero is a switch too). The monodromy knows no element
type: :func:`switching_events` samples every switching function on the
orbit, refines each sign change by Brent's method on the orbit's
trigonometric series (exact at any ``t``) to ``4 eps T`` (all the sign
changes at once, each round of the iteration one call per element), and
builds the saltation matrix there,

    S = I + (f+ - f-) n^T / (n^T f-),     f+ - f- = (0, -M^-1 [f_nl]),

``f-``, ``f+`` the first-order vector fields before and after the switch and
``[f_nl]`` the jump of the contact force (Aizerman & Gantmakher, PMM 22
(1958); Leine & Nijmeijer, *Dynamics and Bifurcations of Non-Smooth
Mechanical Systems*, Springer 2004, ch. 7). For the paper's contact law,
``Fn = kbn (r - delta) + cbn r'`` switched on and off at ``r = delta``, the
force jumps by ``cbn r' e`` and ``S - I`` has the entries ``cbn/beta`` (the
jump divided by ``r' = n^T f-``: finite even at grazing incidence); with the
clipped law contact starts with that jump and ends continuously (``S = I``).
The variational equations are then integrated piecewise, segment by segment
between the switches (about ``S`` steps in all, their ends evaluated on the
segment's side of the surface), with ``Phi <- S Phi`` at each switch: fourth
order again where fixed steps straight across a switch are first order
(``switches='ignore'``, the former behaviour; ``'piecewise'`` drops the
saltation matrices, for comparison). An orbit without switches takes the
fixed-step path with the same result as before. :func:`monodromy_orbit_ivp`
uses the same switches; :func:`monodromy_reference` finds its own on the
nonlinear trajectory (terminal events of ``solve_ivp``, each contact law
frozen between them) and applies the same saltation matrices.

Limits: a contact shorter than ``T/(2S)`` is not seen; a switch where the
force jumps while the orbit does not cross transversally (grazing with a
jump, sliding) raises ``ArithmeticError``; switching inside expression forces
(``abs``, ``min``, ...) is not located. Hill's method uses the sampled
Jacobian, which misses the jump. The measured agreement with the independent
simulator and along the HB orbit is in ``docs/validation/monodromy.md``.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from contin.hb import aft
from contin.hb.harmonics import coefficient_blocks
from contin.stability.rk4 import force_jacobians
from contin.util.jit import njit

__all__ = ["SwitchEvent", "switching_events", "orbit_state", "SWITCH_MODES", "check_switch_mode",
           "checked_base_frequency", "solution_period", "switching_elements", "switch_values", "switch_event",
           "element_switching_events", "switch_segments"]


SWITCH_MODES = ("saltation", "piecewise", "ignore")
_EPS = np.finfo(float).eps


def check_switch_mode(switches):
    if switches not in SWITCH_MODES:
        raise ValueError(f"switches must be one of {list(SWITCH_MODES)}, got {switches!r}")


def checked_base_frequency(hb, lam: float) -> float:
    """The base frequency ``Omega = w/nu`` at ``lam``, checked positive."""
    Omega = hb.base_frequency(hb.params_at(lam))
    if not Omega > 0:
        raise ValueError(f"the monodromy needs a positive excitation frequency, got w/nu = {Omega}")
    return Omega


def solution_period(hb, lam: float) -> float:
    """The solution period ``2 pi nu / w`` at ``lam``, its frequency checked positive."""
    checked_base_frequency(hb, lam)
    return hb.period(hb.params_at(lam))


def orbit_state(hb, u: np.ndarray, lam: float, t) -> np.ndarray:
    """State ``(x, x')`` of the HB solution at times ``t``.

    Parameters
    ----------
    t : float or ndarray, shape (K,)

    Returns
    -------
    ndarray, shape (2n,) or (K, 2n)
    """
    Omega = checked_base_frequency(hb, lam)
    U = np.ascontiguousarray(coefficient_blocks(u, hb.n), dtype=float)
    tt = np.atleast_1d(np.asarray(t, dtype=float))
    z = _synthesize_at(U, Omega, np.ascontiguousarray(Omega * tt))
    return z[0] if np.ndim(t) == 0 else z


@njit(cache=True)
def _synthesize_at(U, Omega, th):
    """``(x, x')`` at the phases ``th`` (K,) from ``U`` (2H+1, n): shape (K, 2n).

    ``cos k th``, ``sin k th`` by the rotation recurrence from ``cos th``,
    ``sin th`` (rounding error growing like ``k eps``). The phases are taken
    in blocks, the recurrence and the sums running across a block so that
    they vectorise; each point still sees the same operations in the same
    order as when it is synthesised alone.
    """
    H = (U.shape[0] - 1) // 2
    n = U.shape[1]
    K = th.shape[0]
    z = np.empty((K, 2 * n))
    nb_ = 64
    c1 = np.empty(nb_)
    s1 = np.empty(nb_)
    ck = np.empty(nb_)
    sk = np.empty(nb_)
    acc = np.empty((2 * n, nb_))
    for j0 in range(0, K, nb_):
        m = min(nb_, K - j0)
        for j in range(m):
            c1[j] = np.cos(th[j0 + j])
            s1[j] = np.sin(th[j0 + j])
            ck[j] = 1.0
            sk[j] = 0.0
        for i in range(n):
            for j in range(m):
                acc[i, j] = U[0, i]
                acc[n + i, j] = 0.0
        for k in range(1, H + 1):
            wk = Omega * k
            for j in range(m):
                c = ck[j] * c1[j] - sk[j] * s1[j]
                sk[j] = sk[j] * c1[j] + ck[j] * s1[j]
                ck[j] = c
            for i in range(n):
                a = U[2 * k - 1, i]
                b = U[2 * k, i]
                for j in range(m):
                    acc[i, j] += a * ck[j] + b * sk[j]
                    acc[n + i, j] += wk * (b * ck[j] - a * sk[j])
        for j in range(m):
            for i in range(2 * n):
                z[j0 + j, i] = acc[i, j]
    return z


@dataclasses.dataclass(frozen=True, eq=False)
class SwitchEvent:
    """A crossing of a switching surface ``h(x, x') = 0`` by the periodic orbit.

    Attributes
    ----------
    time : float
        ``t_c`` in ``[0, T)``.
    element : int
        Index of the force element in ``model.forces``.
    label : str
        The element's label (or kind).
    function : int
        Index of the switching function within the element.
    direction : int
        ``+1`` where the element's law switches on (``h`` turns positive),
        ``-1`` where it switches off.
    state : ndarray, shape (2n,)
        ``z(t_c) = (x, x')``.
    normal : ndarray, shape (2n,)
        ``n = (dh/dx, dh/dx')`` at ``z(t_c)``.
    field_before, field_after : ndarray, shape (2n,)
        The first-order vector field ``f^-``, ``f^+`` at ``(z(t_c), t_c)``
        with the laws before and after the switch.
    transversality : float
        ``n^T f^-``, the rate ``dh/dt`` at which the orbit meets the surface.
    saltation : ndarray, shape (2n, 2n)
        ``S = I + (f^+ - f^-) n^T / (n^T f^-)``; the identity where the
        force is continuous across the surface (or when saltation was not
        asked for).
    """

    time: float
    element: int
    label: str
    function: int
    direction: int
    state: np.ndarray
    normal: np.ndarray
    field_before: np.ndarray
    field_after: np.ndarray
    transversality: float
    saltation: np.ndarray


def switching_elements(model):
    """``[(index, element, number of functions)]`` of the force elements with switching functions."""
    out = []
    n = model.n_dof
    p = model.parameter_vector()
    for e, el in enumerate(model.forces):
        sw = el.switching_functions(np.zeros((0, n)), np.zeros((0, n)), np.zeros(0), p)
        if sw is not None:
            out.append((e, el, int(sw.value.shape[1])))
    return out


#: states per call of an element's switching functions in the orbit-wide evaluations
_SWITCH_BLOCK = 4096


def switch_values(el, x, xd, tau, p):
    """``el.switching_functions(x, xd, tau, p).value`` (N, m), evaluated in blocks of states.

    The elements return seven arrays per call, up to (N, m, n, n) each; in
    blocks they stay small enough for the allocator to recycle, where at full
    length their pages would be faulted in afresh on every call.
    """
    N = x.shape[0]
    if N <= _SWITCH_BLOCK:
        return el.switching_functions(x, xd, tau, p).value
    parts = [el.switching_functions(x[a:a + _SWITCH_BLOCK], xd[a:a + _SWITCH_BLOCK], tau[a:a + _SWITCH_BLOCK], p).value
             for a in range(0, N, _SWITCH_BLOCK)]
    return np.concatenate(parts, axis=0)


def _excitation_at(hb, p, tau):
    fe = np.zeros((len(tau), hb.n))
    for el in hb.model.excitations:
        el.evaluate(tau, p, fe)
    return fe


def switch_event(hb, p, el, e, i, direction, t, z, force_before, saltation=True) -> SwitchEvent:
    """The :class:`SwitchEvent` of function ``i`` of element ``el`` at ``(t, z)``.

    ``force_before`` (shape (n,)) is the total internal force with the laws
    in force just before the switch. ``f^+ - f^- = (0, -M^-1 direction * jump)``.
    """
    n = hb.n
    w = hb.excitation_frequency(p)
    x, xd = z[:n], z[n:]
    sw = el.switching_functions(x[None], xd[None], np.array([w * t]), p)
    normal = np.concatenate([sw.grad_x[0, i], sw.grad_xd[0, i]])
    M, C, K = hb.model.linear(p)
    Minv = np.linalg.inv(M)
    fe = _excitation_at(hb, p, np.array([w * t]))[0]
    acc = Minv @ (fe - C @ xd - K @ x - force_before)
    f_minus = np.concatenate([xd, acc])
    f_plus = np.concatenate([xd, acc - Minv @ (direction * sw.jump[0, i])])
    nf = float(normal @ f_minus)
    nf_plus = float(normal @ f_plus)
    S = np.eye(2 * n)
    label = getattr(el, "label", "") or el.kind
    dfield = f_plus - f_minus
    continuous = np.abs(dfield).max() <= 64 * _EPS * max(np.abs(f_minus).max(), np.abs(f_plus).max(), 1e-300)
    if not continuous and not (direction * nf > 0 and direction * nf_plus > 0):
        raise ArithmeticError(
            f"switch of '{label}' (function {i}) at t = {t:.12g}: the orbit does not cross the surface "
            f"transversally (n^T f- = {nf:.3g}, n^T f+ = {nf_plus:.3g} for a switch "
            f"{'on' if direction > 0 else 'off'}) while the force jumps there; the saltation matrix is undefined "
            "(grazing, or sliding along the surface)")
    if saltation and not continuous:
        S += np.outer(dfield, normal) / nf
    return SwitchEvent(float(t), int(e), str(label), int(i), int(direction), z.copy(), normal, f_minus, f_plus, nf, S)


def switching_events(hb, u: np.ndarray, lam: float, samples: int = 4096, saltation: bool = True) -> list:
    """Locate where the HB orbit crosses the switching surfaces of its force elements.

    The switching functions ``h(x(t), x'(t))`` of every element that has
    them (:meth:`contin.model.base.ForceElement.switching_functions`) are sampled
    on ``samples`` equidistant points of the period; each sign change is
    refined by Brent's method on the orbit's trigonometric series (evaluated
    exactly at any ``t``) to ``|dt| <= 4 eps T``, and the saltation matrix
    ``S = I + (f^+ - f^-) n^T / (n^T f^-)`` (Leine & Nijmeijer, *Dynamics and
    Bifurcations of Non-Smooth Mechanical Systems*, Springer 2004, ch. 7;
    Aizerman & Gantmakher, PMM 22 (1958)) is built there.

    All the sign changes are refined together: the iterations of Brent's
    method (the algorithm of ``scipy.optimize.brentq``, step for step, see
    :func:`_brent_advance`) run side by side, each round evaluating the
    switching functions at all the trial times in one call per element.

    Parameters
    ----------
    hb : HarmonicBalance
    u : ndarray, shape (hb.size,)
    lam : float
    samples : int
        Detection grid. A contact that starts and ends between two samples
        (shorter than ``T / samples``) is not seen.
    saltation : bool
        Build the saltation matrices (else they are the identity).

    Returns
    -------
    list of SwitchEvent
        In time order.

    Raises
    ------
    ArithmeticError
        A switch at which the force jumps but the orbit does not cross the
        surface transversally (grazing or sliding), or whose side cannot be
        resolved.
    """
    sw_elements = switching_elements(hb.model)
    if not sw_elements:
        return []
    return element_switching_events(hb, u, lam, int(samples), saltation, sw_elements)


def element_switching_events(hb, u, lam, samples, saltation, sw_elements, orbit=None):
    """:func:`switching_events` for the elements ``sw_elements`` (see :func:`switching_elements`).

    ``orbit``: the states ``(x, xd)`` (each (samples, n)) on the detection
    grid, if already synthesised.
    """
    n = hb.n
    p = hb.params_at(lam)
    Omega = checked_base_frequency(hb, lam)
    T = hb.period(p)
    w = hb.excitation_frequency(p)
    if orbit is None:
        U = np.ascontiguousarray(coefficient_blocks(u, n))
        x, xp = aft.synthesize(U, samples)
        xd = Omega * xp
    else:
        x, xd = orbit
    t = T * np.arange(samples) / samples
    tau = w * t
    # the brackets, in the order (element, sample, function) in which they are reported at equal times
    rows, elems, funcs, dirs = [], [], [], []
    for q, (_, el, _) in enumerate(sw_elements):
        on = switch_values(el, x, xd, tau, p) > 0.0
        after = np.roll(on, -1, axis=0)
        j, i = np.nonzero(on != after)
        rows.append(j)
        funcs.append(i)
        elems.append(np.full(j.shape, q))
        dirs.append(np.where(after[j, i], 1, -1))
    j, fun, elem, direction = (np.concatenate(v) for v in (rows, funcs, elems, dirs))
    if not j.size:
        return []
    a = t[j]
    b = np.append(t, T)[j + 1]
    values = _SwitchValues(hb, u, lam, p, sw_elements, elem, fun)
    ha, hb_ = values(a), values(b)
    tc = np.where(np.abs(ha) <= np.abs(hb_), a, b)  # a root at rounding level on a node
    bracket = (ha != 0.0) & (hb_ != 0.0) & ((ha > 0) != (hb_ > 0))
    if bracket.any():
        tc[bracket] = _brentq_all(values, a, b, ha, hb_, bracket, 4 * _EPS * T, 4 * _EPS, 200)
    tc = np.where(tc >= T, tc - T, tc)
    order = np.argsort(tc, kind="stable")
    return _switch_events_at(hb, u, lam, p, sw_elements, tc[order], elem[order], fun[order], direction[order],
                             saltation)


class _SwitchValues:
    """``h_i(z(t))`` of the bracketed functions at trial times, one element call per round.

    Bracket ``r`` is function ``fun[r]`` of element ``sw_elements[elem[r]]``;
    calling with times for the brackets ``which`` (default all) returns
    their values. Each value is computed exactly as a call at the single time.
    """

    def __init__(self, hb, u, lam, p, sw_elements, elem, fun):
        self.hb, self.u, self.lam, self.p = hb, u, lam, p
        self.w = hb.excitation_frequency(p)
        self.elements = [el for _, el, _ in sw_elements]
        self.elem, self.fun = elem, fun

    def __call__(self, t, which=None):
        which = np.arange(len(self.elem)) if which is None else which
        n = self.hb.n
        z = orbit_state(self.hb, self.u, self.lam, t)
        out = np.empty(len(t))
        elem, fun = self.elem[which], self.fun[which]
        for q in np.unique(elem):
            sel = np.nonzero(elem == q)[0]
            val = self.elements[q].switching_functions(z[sel, :n], z[sel, n:], self.w * t[sel], self.p).value
            out[sel] = val[np.arange(sel.size), fun[sel]]
        return out


def _brentq_all(f, a, b, fa, fb, active, xtol, rtol, maxiter):
    """Roots of ``f`` in the brackets ``[a[r], b[r]]`` with ``r`` in ``active``, by Brent's method side by side.

    ``f(t, which)`` returns the values at the times ``t`` of the brackets
    ``which``. ``fa``, ``fb``: the values at the ends (nonzero, of opposite
    signs). The iterates are those of ``scipy.optimize.brentq(f_r, a, b,
    xtol, rtol, maxiter)`` for each bracket alone.

    Returns
    -------
    ndarray
        The roots of the active brackets, in their order.

    Raises
    ------
    RuntimeError
        A bracket not converged in ``maxiter`` iterations (as ``brentq``).
    """
    idx = np.nonzero(active)[0]
    xpre, xcur = a[idx].astype(float), b[idx].astype(float)
    fpre, fcur = fa[idx].astype(float), fb[idx].astype(float)
    xblk, fblk, spre, scur = (np.zeros(idx.size) for _ in range(4))
    done = np.zeros(idx.size, dtype=np.bool_)
    for _ in range(maxiter):
        _brent_advance(xpre, xcur, xblk, fpre, fcur, fblk, spre, scur, done, xtol, rtol)
        pending = np.nonzero(~done)[0]
        if not pending.size:
            return xcur
        fcur[pending] = f(xcur[pending], idx[pending])
    raise RuntimeError(f"Failed to converge after {maxiter} iterations, value is {xcur[~done][0]}")


@njit(cache=True)
def _brent_advance(xpre, xcur, xblk, fpre, fcur, fblk, spre, scur, done, xtol, rtol):
    """One iteration of Brent's method for every bracket not yet ``done``, up to its next evaluation.

    The state arrays are updated in place; a bracket that has converged is
    marked ``done`` with its root in ``xcur``, the others hold their next
    trial point in ``xcur`` and wait for ``fcur`` there. The arithmetic is
    that of SciPy's ``brentq`` (``scipy/optimize/Zeros/brentq.c``), operation
    for operation, so that the roots are the same to the last bit.
    """
    for r in range(xcur.shape[0]):
        if done[r]:
            continue
        if fpre[r] != 0.0 and fcur[r] != 0.0 and ((fpre[r] < 0.0) != (fcur[r] < 0.0)):
            xblk[r] = xpre[r]
            fblk[r] = fpre[r]
            spre[r] = xcur[r] - xpre[r]
            scur[r] = spre[r]
        if abs(fblk[r]) < abs(fcur[r]):
            xpre[r] = xcur[r]
            xcur[r] = xblk[r]
            xblk[r] = xpre[r]
            fpre[r] = fcur[r]
            fcur[r] = fblk[r]
            fblk[r] = fpre[r]
        delta = (xtol + rtol * abs(xcur[r])) / 2
        sbis = (xblk[r] - xcur[r]) / 2
        if fcur[r] == 0.0 or abs(sbis) < delta:
            done[r] = True
            continue
        if abs(spre[r]) > delta and abs(fcur[r]) < abs(fpre[r]):
            if xpre[r] == xblk[r]:
                stry = -fcur[r] * (xcur[r] - xpre[r]) / (fcur[r] - fpre[r])
            else:
                dpre = (fpre[r] - fcur[r]) / (xpre[r] - xcur[r])
                dblk = (fblk[r] - fcur[r]) / (xblk[r] - xcur[r])
                stry = -fcur[r] * (fblk[r] * dblk - fpre[r] * dpre) / (dblk * dpre * (fblk[r] - fpre[r]))
            lim = abs(spre[r])
            if 3 * abs(sbis) - delta < lim:
                lim = 3 * abs(sbis) - delta
            if 2 * abs(stry) < lim:
                spre[r] = scur[r]
                scur[r] = stry
            else:
                spre[r] = sbis
                scur[r] = sbis
        else:
            spre[r] = sbis
            scur[r] = sbis
        xpre[r] = xcur[r]
        fpre[r] = fcur[r]
        if abs(scur[r]) > delta:
            xcur[r] += scur[r]
        else:
            xcur[r] += delta if sbis > 0 else -delta


def _switch_events_at(hb, u, lam, p, sw_elements, tc, elem, fun, direction, saltation):
    """The :class:`SwitchEvent` list for the switches at the times ``tc`` (E,), in that order.

    ``elem`` indexes ``sw_elements``; ``fun``, ``direction`` as in
    :class:`SwitchEvent`. The elements are evaluated once each on all the
    switch states; each event is then what :func:`switch_event` gives, with
    the force before the switch ``f_nl + (on - [h_i > 0]) difference_i``
    (law ``i`` taken on for a switch off and off for a switch on, the rest
    as evaluated): exact on the surface, where the elements' own choice of
    law is a matter of rounding.
    """
    n = hb.n
    w = hb.excitation_frequency(p)
    z = orbit_state(hb, u, lam, tc)
    x, xd = np.ascontiguousarray(z[:, :n]), np.ascontiguousarray(z[:, n:])
    tau = w * tc
    F = force_jacobians(hb, x, xd, tau, p)[0]
    fe = _excitation_at(hb, p, tau)
    M, C, K = hb.model.linear(p)
    Minv = np.linalg.inv(M)
    E = tc.shape[0]
    force_before = np.empty((E, n))
    normal = np.empty((E, 2 * n))
    jump = np.empty((E, n))
    for q in np.unique(elem):
        sel = np.nonzero(elem == q)[0]
        r, i = np.arange(sel.size), fun[sel]
        sw = sw_elements[q][1].switching_functions(x[sel], xd[sel], tau[sel], p)
        on = (direction[sel] < 0).astype(float)
        force_before[sel] = F[sel] + (on - (sw.value[r, i] > 0.0))[:, None] * sw.difference[r, i]
        normal[sel, :n] = sw.grad_x[r, i]
        normal[sel, n:] = sw.grad_xd[r, i]
        jump[sel] = sw.jump[r, i]
    f_minus, f_plus, nf, nf_plus = _fields(z, normal, jump, fe, force_before, direction.astype(float), Minv,
                                           np.ascontiguousarray(C, dtype=float), np.ascontiguousarray(K, dtype=float))
    dfield = f_plus - f_minus
    scale = np.maximum(np.maximum(np.abs(f_minus).max(axis=1), np.abs(f_plus).max(axis=1)), 1e-300)
    continuous = np.abs(dfield).max(axis=1) <= 64 * _EPS * scale
    crossing = (direction * nf > 0) & (direction * nf_plus > 0)
    S = np.broadcast_to(np.eye(2 * n), (E, 2 * n, 2 * n)).copy()
    kick = ~continuous if saltation else np.zeros(E, dtype=bool)
    S[kick] += dfield[kick, :, None] * normal[kick, None, :] / nf[kick, None, None]
    events = []
    for k in range(E):
        e, el, _ = sw_elements[elem[k]]
        label = getattr(el, "label", "") or el.kind
        if not continuous[k] and not crossing[k]:
            raise ArithmeticError(
                f"switch of '{label}' (function {fun[k]}) at t = {tc[k]:.12g}: the orbit does not cross the surface "
                f"transversally (n^T f- = {nf[k]:.3g}, n^T f+ = {nf_plus[k]:.3g} for a switch "
                f"{'on' if direction[k] > 0 else 'off'}) while the force jumps there; the saltation matrix is "
                "undefined (grazing, or sliding along the surface)")
        events.append(SwitchEvent(float(tc[k]), int(e), str(label), int(fun[k]), int(direction[k]), z[k].copy(),
                                  normal[k], f_minus[k], f_plus[k], float(nf[k]), S[k]))
    return events


@njit(cache=True)
def _fields(z, normal, jump, fe, force_before, direction, Minv, C, K):
    """The vector fields before and after each switch and their rates across the surface.

    Parameters
    ----------
    z, normal : ndarray, shape (E, 2n)
    jump, fe, force_before : ndarray, shape (E, n)
    direction : ndarray, shape (E,)
    Minv, C, K : ndarray, shape (n, n)

    Returns
    -------
    f_minus, f_plus : ndarray, shape (E, 2n)
        ``(x', M^-1 (fe - C x' - K x - force_before))`` and the same with the
        acceleration less ``M^-1 direction jump``.
    nf, nf_plus : ndarray, shape (E,)
        ``normal . f_minus``, ``normal . f_plus``.
    """
    E = z.shape[0]
    n = Minv.shape[0]
    f_minus = np.empty((E, 2 * n))
    f_plus = np.empty((E, 2 * n))
    nf = np.empty(E)
    nf_plus = np.empty(E)
    r = np.empty(n)
    for k in range(E):
        for a in range(n):
            cx = 0.0
            kx = 0.0
            for b in range(n):
                cx += C[a, b] * z[k, n + b]
                kx += K[a, b] * z[k, b]
            r[a] = fe[k, a] - cx - kx - force_before[k, a]
        for a in range(n):
            acc = 0.0
            dj = 0.0
            for b in range(n):
                acc += Minv[a, b] * r[b]
                dj += Minv[a, b] * (direction[k] * jump[k, b])
            f_minus[k, a] = z[k, n + a]
            f_plus[k, a] = z[k, n + a]
            f_minus[k, n + a] = acc
            f_plus[k, n + a] = acc - dj
        s1 = 0.0
        s2 = 0.0
        for a in range(2 * n):
            s1 += normal[k, a] * f_minus[k, a]
            s2 += normal[k, a] * f_plus[k, a]
        nf[k] = s1
        nf_plus[k] = s2
    return f_minus, f_plus, nf, nf_plus


def switch_segments(events, T):
    """Segment bounds ``[(a, b)]`` between the switch times over ``[0, T]``."""
    bounds = [0.0] + [ev.time for ev in events] + [T]
    return list(zip(bounds[:-1], bounds[1:]))


# the former private names, which code outside this package's layers still imports
_switching_elements = switching_elements
