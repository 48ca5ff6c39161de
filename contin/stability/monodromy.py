"""Monodromy matrix of a harmonic-balance solution by time integration.

The first-order variational equations of ``M x'' + C x' + K x + f(x, x', tau) = f_ext(tau)``
about the periodic solution ``x*(t)`` are

    z' = A(t) z,    A = [[0, I], [-M^-1 (K + df/dx), -M^-1 (C + df/dx')]],    z = (dx, dx'),

and the monodromy matrix is ``Phi(T)`` with ``Phi(0) = I``, ``T = 2 pi nu / w``;
its eigenvalues are the Floquet multipliers.

Two paths are provided:

- :func:`monodromy_rk4` (production): the force elements are evaluated once,
  in one vectorised call per element, on ``2S`` points of the HB orbit
  (``S`` steps per period, the RK4 stages need the half steps), and
  ``Phi`` is propagated by a numba-compiled fixed-step classical Runge-Kutta
  scheme. For smooth forces the error is ``O(h^4)``, ``h = T/S``; a step
  beyond RK4's stability limit for the stiffest eigenvalue of ``A`` along the
  orbit is refused (``ArithmeticError`` naming the step count needed).
- :func:`monodromy_reference`: ``scipy.integrate.solve_ivp`` (DOP853, tight
  tolerances) of the *full nonlinear* state together with the variational
  equations, started from the HB state at ``t = 0``. It measures the HB
  truncation error too (``orbit_error``: how far the true flow is from
  returning to the start after one period). :func:`monodromy_orbit_ivp`
  integrates the variational equations along the HB orbit itself with the
  same adaptive scheme, isolating the error of the fixed-step scheme.

Non-smooth forces: switches and saltation matrices
--------------------------------------------------
A contact law is piecewise: each force element with a switching surface
reports it through :meth:`contin.model.ForceElement.switching_functions`
(value ``h``, gradient ``n = (dh/dx, dh/dx')`` and the jump of the force
across the surface; the gap and radial-gap contacts do, ``h = r - delta`` or,
with ``clip``, ``min(r - delta, Fn/k)`` so that the end of contact where the
clipped force reaches zero is a switch too). The monodromy knows no element
type: :func:`switching_events` samples every switching function on the
orbit, refines each sign change by Brent's method on the orbit's
trigonometric series (exact at any ``t``) to ``4 eps T``, and builds the
saltation matrix there,

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

Checks (``tests/stability/test_saltation.py``): against central finite
differences of the flow map of the independent simulator
(:func:`contin.simulation.simulate`), the reference monodromy of a
clearance oscillator with contact damping agrees to 1e-8 with saltation and
is off by 0.5 without, clipped and unclipped; on the rotor with ``c2 = 5``
(impacts) 9e-9 against 1.6e-5 without (the bearing damping wipes the kick
out within a period). Along the HB orbit the agreement is limited by the HB
truncation, algebraic in ``H`` for impacting orbits (2e-2 in ``Phi`` for the
rotor at ``H = 40``). Limits: a contact shorter than ``T/(2S)`` is not seen;
a switch where the force jumps while the orbit does not cross transversally
(grazing with a jump, sliding) raises ``ArithmeticError``; switching inside
expression forces (``abs``, ``min``, ...) is not located. Hill's method uses
the sampled Jacobian, which misses the jump (its derivative is a delta at
the surface): on impacting orbits its selection of exponents fails (flagged
ambiguous), though its spectrum holds the critical multipliers
(``tests/models/test_rotor_floquet.py``).
"""

from __future__ import annotations

import dataclasses

import numba as nb
import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from contin import aft
from contin.harmonics import coefficient_blocks

__all__ = [
    "Monodromy",
    "SwitchEvent",
    "switching_events",
    "state_matrices",
    "rk4_propagate",
    "monodromy_rk4",
    "monodromy_orbit_ivp",
    "monodromy_reference",
    "orbit_state",
]


@dataclasses.dataclass(frozen=True, eq=False)
class Monodromy:
    """A monodromy matrix and how it was obtained.

    Attributes
    ----------
    matrix : ndarray, shape (2n, 2n)
        ``Phi(T)`` for the state ``z = (x, x')``.
    period : float
    method : str
        ``"rk4"``, ``"orbit-dop853"`` or ``"dop853"``.
    steps : int
        RK4 steps per period (0 for the adaptive paths; then the number of
        right-hand-side evaluations is in ``evaluations``).
    evaluations : int
    orbit_error : float
        For ``"dop853"`` only: ``max |z(T) - z(0)|`` of the nonlinear flow
        started on the HB state (NaN otherwise).
    switches : tuple of SwitchEvent
        The switching events located along the orbit, in time order (empty
        for a smooth orbit, or when location was not asked for).
    saltation : bool
        Whether saltation matrices were applied at the switches.
    """

    matrix: np.ndarray
    period: float
    method: str
    steps: int = 0
    evaluations: int = 0
    orbit_error: float = float("nan")
    switches: tuple = ()
    saltation: bool = False

    @property
    def multipliers(self) -> np.ndarray:
        """Eigenvalues of :attr:`matrix`, shape (2n,) complex."""
        return np.linalg.eigvals(self.matrix)


def _frequency(hb, lam: float) -> float:
    Omega = float(hb.params_at(lam)[hb.kw]) / hb.nu
    if not Omega > 0:
        raise ValueError(f"the monodromy needs a positive excitation frequency, got w/nu = {Omega}")
    return Omega


def _force_jacobians(hb, x, xd, tau, p):
    N, n = x.shape
    f = np.zeros((N, n))
    dfdx = np.zeros((N, n, n))
    dfdxd = np.zeros((N, n, n))
    for el in hb.model.forces:
        el.evaluate(x, xd, tau, p, f, dfdx, dfdxd)
    return f, dfdx, dfdxd


def state_matrices(hb, u: np.ndarray, lam: float, samples: int):
    """``A(t_j)`` on ``t_j = j T / samples`` along the HB orbit.

    The force elements are called once each, on all samples.

    Parameters
    ----------
    hb : HarmonicBalance
    u : ndarray, shape (hb.size,)
    lam : float
    samples : int
        ``>= 2H+1``.

    Returns
    -------
    A : ndarray, shape (samples, 2n, 2n)
    period : float
    """
    n = hb.n
    if samples < 2 * hb.H + 1:
        raise ValueError(f"need at least 2H+1 = {2 * hb.H + 1} orbit samples, got {samples}")
    p = hb.params_at(lam)
    Omega = _frequency(hb, lam)
    U = np.ascontiguousarray(coefficient_blocks(u, n))
    x, xp = aft.synthesize(U, samples)
    xd = Omega * xp
    theta = 2.0 * np.pi * np.arange(samples) / samples
    return _state_matrices_at(hb, p, x, xd, hb.nu * theta), 2.0 * np.pi / Omega


def _state_matrices_at(hb, p, x, xd, tau):
    """``A`` at the states ``(x, xd)`` (each (N, n)) and phases ``tau`` (N,): shape (N, 2n, 2n)."""
    n = hb.n
    _, dfdx, dfdxd = _force_jacobians(hb, x, xd, tau, p)
    M, C, K = hb.model.linear(p)
    Minv = np.linalg.inv(M)
    A = np.zeros((x.shape[0], 2 * n, 2 * n))
    A[:, :n, n:] = np.eye(n)
    A[:, n:, :n] = -np.einsum("ab,jbc->jac", Minv, K[None] + dfdx)
    A[:, n:, n:] = -np.einsum("ab,jbc->jac", Minv, C[None] + dfdxd)
    return A


@nb.njit(cache=True)
def _matmul_into(A, B, out):
    d = A.shape[0]
    for i in range(d):
        for j in range(d):
            s = 0.0
            for k in range(d):
                s += A[i, k] * B[k, j]
            out[i, j] = s


@nb.njit(cache=True)
def _rk4_step(A0, A1, A2, Phi, h, k1, k2, k3, k4, tmp):
    """One classical RK4 step of ``Phi' = A(t) Phi`` in place (``A1`` at the half step)."""
    d = Phi.shape[0]
    _matmul_into(A0, Phi, k1)
    for i in range(d):
        for j in range(d):
            tmp[i, j] = Phi[i, j] + 0.5 * h * k1[i, j]
    _matmul_into(A1, tmp, k2)
    for i in range(d):
        for j in range(d):
            tmp[i, j] = Phi[i, j] + 0.5 * h * k2[i, j]
    _matmul_into(A1, tmp, k3)
    for i in range(d):
        for j in range(d):
            tmp[i, j] = Phi[i, j] + h * k3[i, j]
    _matmul_into(A2, tmp, k4)
    for i in range(d):
        for j in range(d):
            Phi[i, j] += h / 6.0 * (k1[i, j] + 2.0 * k2[i, j] + 2.0 * k3[i, j] + k4[i, j])


@nb.njit(cache=True)
def rk4_propagate(A, h):
    """Classical RK4 for ``Phi' = A(t) Phi``, ``Phi(0) = I``, over one period.

    Parameters
    ----------
    A : ndarray, shape (2S, d, d)
        ``A`` at ``t_j = j h / 2`` (periodic: ``A(S h) = A(0)``).
    h : float
        Step ``T / S``.

    Returns
    -------
    ndarray, shape (d, d)
        ``Phi(T)``.
    """
    S = A.shape[0] // 2
    d = A.shape[1]
    Phi = np.eye(d)
    k1, k2, k3, k4, tmp = np.empty((d, d)), np.empty((d, d)), np.empty((d, d)), np.empty((d, d)), np.empty((d, d))
    for step in range(S):
        _rk4_step(A[2 * step], A[2 * step + 1], A[(2 * step + 2) % (2 * S)], Phi, h, k1, k2, k3, k4, tmp)
    return Phi


@nb.njit(cache=True)
def rk4_segments(A, starts, steps, h, jumps):
    """Classical RK4 for ``Phi' = A(t) Phi`` over consecutive segments, with a jump matrix after each.

    Segment ``s`` takes ``steps[s]`` steps of length ``h[s]`` with ``A`` read
    at its ``2 steps[s] + 1`` nodes ``A[starts[s] + j]``, ``j = 0 .. 2 steps[s]``
    (the half steps included; the end nodes are the one-sided limits at the
    segment ends). After the segment ``Phi <- jumps[s] Phi``.

    Parameters
    ----------
    A : ndarray, shape (K, d, d)
    starts, steps : ndarray of int64, shape (G,)
    h : ndarray, shape (G,)
    jumps : ndarray, shape (G, d, d)

    Returns
    -------
    ndarray, shape (d, d)
    """
    d = A.shape[1]
    Phi = np.eye(d)
    k1, k2, k3, k4, tmp = np.empty((d, d)), np.empty((d, d)), np.empty((d, d)), np.empty((d, d)), np.empty((d, d))
    for seg in range(steps.shape[0]):
        for step in range(steps[seg]):
            j0 = starts[seg] + 2 * step
            _rk4_step(A[j0], A[j0 + 1], A[j0 + 2], Phi, h[seg], k1, k2, k3, k4, tmp)
        _matmul_into(jumps[seg], Phi, tmp)
        for i in range(d):
            for j in range(d):
                Phi[i, j] = tmp[i, j]
    return Phi


def monodromy_rk4(hb, u: np.ndarray, lam: float, steps: int = 512, switches: str = "saltation") -> Monodromy:
    """Monodromy matrix by fixed-step RK4 on the sampled HB orbit.

    Parameters
    ----------
    hb : HarmonicBalance
    u : ndarray, shape (hb.size,)
    lam : float
    steps : int
        RK4 steps per period ``S`` (at least ``H+1``, so that the ``2S``
        orbit samples resolve every harmonic).
    switches : {'saltation', 'piecewise', 'ignore'}
        ``'saltation'`` (default): the switches of the force elements'
        switching functions (:meth:`contin.model.ForceElement.switching_functions`)
        are located on the orbit, the variational equations are integrated
        piecewise between them (about ``S`` steps in all, distributed by
        segment length) and the saltation matrix is applied at each switch.
        ``'piecewise'``: the same without saltation matrices (wrong where the
        force law jumps; for comparison). ``'ignore'``: fixed steps straight
        across the switches (first order in ``h`` where the Jacobian jumps,
        and no saltation). An orbit without switches takes the fixed-step
        path in every mode, with the same result.

    Returns
    -------
    Monodromy

    Raises
    ------
    ArithmeticError
        A step beyond RK4's stability limit for the stiffest eigenvalue of
        ``A`` along the orbit (the message gives the step count needed), or a
        switch that cannot be resolved (see :func:`switching_events`).
    """
    steps = int(steps)
    if steps < hb.H + 1:
        raise ValueError(f"steps_per_period must be >= H+1 = {hb.H + 1}, got {steps}")
    if switches not in _SWITCH_MODES:
        raise ValueError(f"switches must be one of {list(_SWITCH_MODES)}, got {switches!r}")
    if switches != "ignore":
        events = switching_events(hb, u, lam, 2 * steps, saltation=switches == "saltation")
        if events:
            return _piecewise_rk4(hb, u, lam, steps, events, switches == "saltation")
    A, T = state_matrices(hb, u, lam, 2 * steps)
    _check_rk4_step(A, T / steps, T, lam)
    Phi = rk4_propagate(A, T / steps)
    return Monodromy(Phi, T, "rk4", steps=steps, evaluations=2 * steps)


#: largest h*|lambda| for which classical RK4 is stable (2 sqrt 2 on the imaginary axis, 2.785 on the real one)
RK4_STABILITY = 2.78


def _check_rk4_step(A, h, T, lam):
    """Refuse a step beyond RK4's stability limit for the stiffest eigenvalue of ``A`` along the orbit.

    Beyond it the fixed-step monodromy blows up or, worse, returns finite
    garbage. ``A`` (K, d, d) is subsampled to at most 256 matrices.
    """
    stride = max(1, A.shape[0] // 256)
    rate = float(np.abs(np.linalg.eigvals(A[::stride])).max())
    if rate * h > RK4_STABILITY:
        need = int(np.ceil(rate * T / RK4_STABILITY))
        raise ArithmeticError(
            f"monodromy at lambda = {lam:.10g}: the RK4 step T/{round(T / h)} is too large for the stiffest "
            f"mode along the orbit (|eigenvalue| {rate:.4g}, h |eigenvalue| = {rate * h:.3g} > {RK4_STABILITY}); "
            f"use steps_per_period >= {need}")


# ---------------------------------------------------------------- switching events and saltation matrices
_SWITCH_MODES = ("saltation", "piecewise", "ignore")
_EPS = np.finfo(float).eps


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


def _switching_elements(model):
    """``[(index, element, number of functions)]`` of the force elements with switching functions."""
    out = []
    n = model.n_dof
    p = model.parameter_vector()
    for e, el in enumerate(model.forces):
        sw = el.switching_functions(np.zeros((0, n)), np.zeros((0, n)), np.zeros(0), p)
        if sw is not None:
            out.append((e, el, int(sw.value.shape[1])))
    return out


def _mode_columns(model) -> dict:
    """Column of each ``(element index, function)`` in :func:`_modes`."""
    cols, k = {}, 0
    for e, _, m in _switching_elements(model):
        for i in range(m):
            cols[(e, i)] = k
            k += 1
    return cols


def _excitation_at(hb, p, tau):
    fe = np.zeros((len(tau), hb.n))
    for el in hb.model.excitations:
        el.evaluate(tau, p, fe)
    return fe


def _saltation(hb, p, el, e, i, direction, t, z, force_before, saltation=True) -> SwitchEvent:
    """The :class:`SwitchEvent` of function ``i`` of element ``el`` at ``(t, z)``.

    ``force_before`` (shape (n,)) is the total internal force with the laws
    in force just before the switch. ``f^+ - f^- = (0, -M^-1 direction * jump)``.
    """
    n = hb.n
    w = float(p[hb.kw])
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


def _force_with_law(hb, p, t, z, el, i, on):
    """Total internal force at ``(t, z)`` with law ``i`` of ``el`` taken ``on`` (or off), the rest as evaluated.

    ``f_nl + (on - [h_i(z) > 0]) * difference_i(z)``: exact on the surface,
    where the elements' own choice of law is a matter of rounding.
    """
    n = hb.n
    x, xd = z[None, :n], z[None, n:]
    tau = np.array([float(p[hb.kw]) * t])
    F = _force_jacobians(hb, x, xd, tau, p)[0][0]
    sw = el.switching_functions(x, xd, tau, p)
    return F + (float(bool(on)) - float(sw.value[0, i] > 0.0)) * sw.difference[0, i]


def switching_events(hb, u: np.ndarray, lam: float, samples: int = 4096, saltation: bool = True) -> list:
    """Locate where the HB orbit crosses the switching surfaces of its force elements.

    The switching functions ``h(x(t), x'(t))`` of every element that has
    them (:meth:`contin.model.ForceElement.switching_functions`) are sampled
    on ``samples`` equidistant points of the period; each sign change is
    refined by Brent's method on the orbit's trigonometric series (evaluated
    exactly at any ``t``) to ``|dt| <= 4 eps T``, and the saltation matrix
    ``S = I + (f^+ - f^-) n^T / (n^T f^-)`` (Leine & Nijmeijer, *Dynamics and
    Bifurcations of Non-Smooth Mechanical Systems*, Springer 2004, ch. 7;
    Aizerman & Gantmakher, PMM 22 (1958)) is built there.

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
    sw_elements = _switching_elements(hb.model)
    if not sw_elements:
        return []
    n = hb.n
    p = hb.params_at(lam)
    Omega = _frequency(hb, lam)
    T = 2.0 * np.pi / Omega
    w = float(p[hb.kw])
    U = np.ascontiguousarray(coefficient_blocks(u, n))
    x, xp = aft.synthesize(U, int(samples))
    xd = Omega * xp
    t = T * np.arange(samples) / samples
    tau = w * t
    found = []
    for e, el, _ in sw_elements:
        val = el.switching_functions(x, xd, tau, p).value
        on = val > 0.0
        after = np.roll(on, -1, axis=0)
        for j, i in zip(*np.nonzero(on != after)):
            a, b = t[j], (t[j + 1] if j + 1 < samples else T)

            def h(tt, el=el, i=i):
                z = orbit_state(hb, u, lam, np.array([tt]))
                return float(el.switching_functions(z[:, :n], z[:, n:], np.array([w * tt]), p).value[0, i])

            ha, hb_ = h(a), h(b)
            if ha == 0.0 or hb_ == 0.0 or (ha > 0) == (hb_ > 0):
                tc = a if abs(ha) <= abs(hb_) else b  # a root at rounding level on a node
            else:
                tc = brentq(h, a, b, xtol=4 * _EPS * T, rtol=4 * _EPS, maxiter=200)
            if tc >= T:
                tc -= T
            found.append((tc, e, el, int(i), 1 if after[j, i] else -1))
    found.sort(key=lambda f: f[0])
    events = []
    for tc, e, el, i, direction in found:
        z = orbit_state(hb, u, lam, np.array([tc]))[0]
        F_minus = _force_with_law(hb, p, tc, z, el, i, direction < 0)
        events.append(_saltation(hb, p, el, e, i, direction, tc, z, F_minus, saltation))
    return events


def _segments(events, T):
    """Segment bounds ``[(a, b)]`` between the switch times over ``[0, T]``."""
    bounds = [0.0] + [ev.time for ev in events] + [T]
    return list(zip(bounds[:-1], bounds[1:]))


def _modes(hb, u, lam, p, t, z=None):
    """Signs ``h > 0`` of every switching function at the orbit times ``t``: shape (len(t), total m).

    ``z`` (shape (len(t), 2n)): the orbit states there, if already known.
    """
    n = hb.n
    if z is None:
        z = orbit_state(hb, u, lam, np.asarray(t, dtype=float))
    tau = float(p[hb.kw]) * np.asarray(t, dtype=float)
    cols = [el.switching_functions(z[:, :n], z[:, n:], tau, p).value > 0.0
            for _, el, _ in _switching_elements(hb.model)]
    return np.concatenate(cols, axis=1) if cols else np.zeros((len(t), 0), dtype=bool)


def _piecewise_nodes(hb, u, lam, p, events, T, steps):
    """RK4 nodes of each segment between switches, with one-sided end nodes.

    Returns ``(t, z, starts, nsteps, h)``: node times (K,), the orbit there
    (K, 2n), the first node and the step count of each segment, and its step. End nodes at a switch are
    moved into their segment by ``1e-9`` (up to ``1e-3``) of the half step, so
    that the elements evaluate the segment's law there; every node of a
    segment is checked to be in the segment's contact mode.
    """
    segs = _segments(events, T)
    times, starts, nsteps, hs, ends = [], [], [], [], []
    k = 0
    for s, (a, b) in enumerate(segs):
        L = b - a
        m = 0 if L <= 0.0 else max(1, round(steps * L / T))
        starts.append(k)
        nsteps.append(m)
        hs.append(L / m if m else 0.0)
        if m:
            tt = a + L * np.arange(2 * m + 1) / (2 * m)
            tt[-1] = b
            times.append(tt)
            ends.append((k, s > 0, k + 2 * m, s < len(segs) - 1, L / (2 * m)))
            k += 2 * m + 1
    t = np.concatenate(times)
    z = orbit_state(hb, u, lam, t)
    mode = _modes(hb, u, lam, p, t, z)
    # the expected mode of each segment: that of its middle node
    expected = np.zeros_like(mode)
    for s, m in enumerate(nsteps):
        if m:
            expected[starts[s]: starts[s] + 2 * m + 1] = mode[starts[s] + m]
    for first, nudge_first, last, nudge_last, half in ends:
        for node, move, sign in ((first, nudge_first, 1.0), (last, nudge_last, -1.0)):
            if not move:
                continue
            base = t[node]
            for q in range(7):
                t[node] = base + sign * 1e-9 * 10.0**q * half
                z[node] = orbit_state(hb, u, lam, t[node:node + 1])[0]
                if np.array_equal(_modes(hb, u, lam, p, t[node:node + 1], z[node:node + 1])[0], expected[node]):
                    break
            else:
                raise ArithmeticError(f"the contact mode next to the switch at t = {base:.12g} cannot be resolved")
            mode[node] = expected[node]
    bad = np.nonzero(np.any(mode != expected, axis=1))[0]
    if bad.size:
        raise ArithmeticError(
            f"the orbit switches at t = {t[bad[0]]:.9g} between the located switches (a contact shorter than "
            f"T/{2 * steps}, or a grazing); raise steps_per_period")
    # each switch flips its own function and nothing else, and the mode is periodic
    cols = _mode_columns(hb.model)
    mid = [mode[starts[s] + nsteps[s]] if nsteps[s] else None for s in range(len(segs))]
    current = (mid[0] if mid[0] is not None else mid[-1]).copy()
    for s, ev in enumerate(events):
        current[cols[(ev.element, ev.function)]] ^= True
        if mid[s + 1] is not None and not np.array_equal(current, mid[s + 1]):
            raise ArithmeticError(f"the contact mode after the switch at t = {ev.time:.12g} is not the one the "
                                  "switch leads to: an unlocated switch; raise steps_per_period")
    if mid[0] is not None and not np.array_equal(current, mid[0]):
        raise ArithmeticError("the contact mode at the end of the period differs from the start: an unlocated switch")
    return t, z, np.array(starts, dtype=np.int64), np.array(nsteps, dtype=np.int64), np.array(hs)


def _piecewise_rk4(hb, u, lam, steps, events, saltation):
    n = hb.n
    p = hb.params_at(lam)
    T = 2.0 * np.pi / _frequency(hb, lam)
    t, z, starts, nsteps, h = _piecewise_nodes(hb, u, lam, p, events, T, steps)
    A = _state_matrices_at(hb, p, np.ascontiguousarray(z[:, :n]), np.ascontiguousarray(z[:, n:]),
                           float(p[hb.kw]) * t)
    jumps = np.array([ev.saltation for ev in events] + [np.eye(2 * n)])
    _check_rk4_step(A, float(h.max()), T, lam)
    Phi = rk4_segments(A, starts, nsteps, h, jumps)
    return Monodromy(Phi, T, "rk4", steps=int(nsteps.sum()), evaluations=len(t), switches=tuple(events),
                     saltation=bool(saltation))


def orbit_state(hb, u: np.ndarray, lam: float, t) -> np.ndarray:
    """State ``(x, x')`` of the HB solution at times ``t``.

    Parameters
    ----------
    t : float or ndarray, shape (K,)

    Returns
    -------
    ndarray, shape (2n,) or (K, 2n)
    """
    Omega = _frequency(hb, lam)
    U = np.ascontiguousarray(coefficient_blocks(u, hb.n), dtype=float)
    tt = np.atleast_1d(np.asarray(t, dtype=float))
    z = _synthesize_at(U, Omega, np.ascontiguousarray(Omega * tt))
    return z[0] if np.ndim(t) == 0 else z


@nb.njit(cache=True)
def _synthesize_at(U, Omega, th):
    """``(x, x')`` at the phases ``th`` (K,) from ``U`` (2H+1, n): shape (K, 2n).

    ``cos k th``, ``sin k th`` by the rotation recurrence from ``cos th``,
    ``sin th`` (rounding error growing like ``k eps``).
    """
    H = (U.shape[0] - 1) // 2
    n = U.shape[1]
    K = th.shape[0]
    z = np.zeros((K, 2 * n))
    for j in range(K):
        c1 = np.cos(th[j])
        s1 = np.sin(th[j])
        ck = 1.0
        sk = 0.0
        for i in range(n):
            z[j, i] = U[0, i]
        for k in range(1, H + 1):
            ck, sk = ck * c1 - sk * s1, sk * c1 + ck * s1
            for i in range(n):
                a = U[2 * k - 1, i]
                b = U[2 * k, i]
                z[j, i] += a * ck + b * sk
                z[j, n + i] += Omega * k * (b * ck - a * sk)
    return z


def _pointwise(hb, p):
    """Callables evaluating the model at one state (the reference path)."""
    n = hb.n
    M, C, K = hb.model.linear(p)
    Minv = np.linalg.inv(M)
    w = float(p[hb.kw])
    f = np.zeros((1, n))
    dfdx = np.zeros((1, n, n))
    dfdxd = np.zeros((1, n, n))
    fe = np.zeros((1, n))
    tau = np.zeros(1)

    def forces(x, xd, t):
        f[:] = 0.0
        dfdx[:] = 0.0
        dfdxd[:] = 0.0
        tau[0] = w * t
        for el in hb.model.forces:
            el.evaluate(x[None, :], xd[None, :], tau, p, f, dfdx, dfdxd)
        return f[0], dfdx[0], dfdxd[0]

    def excitation(t):
        fe[:] = 0.0
        tau[0] = w * t
        for el in hb.model.excitations:
            el.evaluate(tau, p, fe)
        return fe[0]

    return M, C, K, Minv, forces, excitation


def _state_matrix(Minv, C, K, dfdx, dfdxd, n):
    A = np.zeros((2 * n, 2 * n))
    A[:n, n:] = np.eye(n)
    A[n:, :n] = -Minv @ (K + dfdx)
    A[n:, n:] = -Minv @ (C + dfdxd)
    return A


def _check_switch_mode(switches):
    if switches not in _SWITCH_MODES:
        raise ValueError(f"switches must be one of {list(_SWITCH_MODES)}, got {switches!r}")


def _clamped(a, b, inner_a, inner_b):
    """``t -> t`` clamped into ``[a, b]`` shrunk by ``1e-9 (b - a)`` at the ends that are switches."""
    lo = a + (1e-9 * (b - a) if inner_a else 0.0)
    hi = b - (1e-9 * (b - a) if inner_b else 0.0)
    return lambda t: min(max(t, lo), hi)


def monodromy_orbit_ivp(hb, u: np.ndarray, lam: float, rtol: float = 1e-11, atol: float = 1e-12,
                        switches: str = "saltation", samples: int = 4096) -> Monodromy:
    """Monodromy of the variational equations along the HB orbit, adaptive DOP853.

    Same equations as :func:`monodromy_rk4` (the orbit is the HB solution,
    evaluated exactly at every requested time) with an error-controlled
    integrator: the reference for the fixed-step error. With switches
    (``switches`` as in :func:`monodromy_rk4`; located on ``samples``
    points) each segment between two switches is integrated separately, its
    ends evaluated ``1e-9`` of its length inside, and the saltation matrices
    are applied in between.
    """
    _check_switch_mode(switches)
    n = hb.n
    p = hb.params_at(lam)
    Omega = _frequency(hb, lam)
    T = 2.0 * np.pi / Omega
    _, C, K, Minv, forces, _ = _pointwise(hb, p)
    d = 2 * n
    events = [] if switches == "ignore" else switching_events(hb, u, lam, samples, saltation=switches == "saltation")
    segs = _segments(events, T)
    Phi = np.eye(d)
    nfev = 0
    for s, (a, b) in enumerate(segs):
        if b > a:
            clamp = _clamped(a, b, s > 0, s < len(segs) - 1)

            def rhs(t, y, clamp=clamp):
                tt = clamp(t)
                z = orbit_state(hb, u, lam, tt)
                _, dfdx, dfdxd = forces(z[:n], z[n:], tt)
                A = _state_matrix(Minv, C, K, dfdx, dfdxd, n)
                return (A @ y.reshape(d, d)).reshape(-1)

            sol = solve_ivp(rhs, (a, b), Phi.reshape(-1), method="DOP853", rtol=rtol, atol=atol)
            if not sol.success:
                raise ArithmeticError(f"solve_ivp failed on the variational equations: {sol.message}")
            Phi = sol.y[:, -1].reshape(d, d)
            nfev += int(sol.nfev)
        if s < len(events):
            Phi = events[s].saltation @ Phi
    return Monodromy(Phi, T, "orbit-dop853", evaluations=nfev, switches=tuple(events),
                     saltation=bool(events) and switches == "saltation")


def monodromy_reference(hb, u: np.ndarray, lam: float, rtol: float = 1e-11, atol: float = 1e-12,
                        switches: str = "saltation", max_switches: int = 1000) -> Monodromy:
    """Reference monodromy: the nonlinear flow from the HB state and its variational equations, DOP853.

    Integrates ``M x'' + C x' + K x + f(x, x', w t) = f_ext(w t)`` together with
    ``Phi' = A(t) Phi`` from the HB state at ``t = 0`` over one period. The
    right-hand side calls the elements with ``(1, n)`` arrays (slow, but this
    is the reference).

    For a model with switching functions (and ``switches != 'ignore'``) the
    state is integrated first, one contact mode at a time: each law is frozen
    (the elements' force is corrected by ``(mode - [h > 0]) * difference``, so that a
    trial stage beyond a surface sees the smooth extension of the current
    law), the switches are terminal events located by ``solve_ivp`` on its
    dense output, and the mode flips there. The variational equations are
    then integrated segment by segment along that dense trajectory, with the
    saltation matrix at each switch (``switches='piecewise'``: without). This
    path shares nothing with the HB orbit but its start, so it checks
    :func:`monodromy_rk4` up to the HB truncation error (``orbit_error``).

    Returns
    -------
    Monodromy
        With ``orbit_error = max |z(T) - z(0)|`` and the switches of the
        nonlinear trajectory.

    Raises
    ------
    ArithmeticError
        ``solve_ivp`` fails, more than ``max_switches`` switches (chatter), or
        a switch without a defined saltation matrix.
    """
    _check_switch_mode(switches)
    n = hb.n
    p = hb.params_at(lam)
    Omega = _frequency(hb, lam)
    T = 2.0 * np.pi / Omega
    _, C, K, Minv, forces, excitation = _pointwise(hb, p)
    d = 2 * n
    z0 = orbit_state(hb, u, lam, 0.0)
    sw = [] if switches == "ignore" else _switching_elements(hb.model)
    if sw:
        return _reference_with_switches(hb, p, T, z0, sw, rtol, atol, switches == "saltation", max_switches)

    def rhs(t, y):
        x, xd = y[:n], y[n:d]
        f, dfdx, dfdxd = forces(x, xd, t)
        acc = Minv @ (excitation(t) - C @ xd - K @ x - f)
        A = _state_matrix(Minv, C, K, dfdx, dfdxd, n)
        out = np.empty_like(y)
        out[:n] = xd
        out[n:d] = acc
        out[d:] = (A @ y[d:].reshape(d, d)).reshape(-1)
        return out

    y0 = np.concatenate([z0, np.eye(d).reshape(-1)])
    sol = solve_ivp(rhs, (0.0, T), y0, method="DOP853", rtol=rtol, atol=atol)
    if not sol.success:
        raise ArithmeticError(f"solve_ivp failed on the reference integration: {sol.message}")
    yT = sol.y[:, -1]
    return Monodromy(
        yT[d:].reshape(d, d), T, "dop853", evaluations=int(sol.nfev), orbit_error=float(np.max(np.abs(yT[:d] - z0)))
    )


def _reference_with_switches(hb, p, T, z0, sw, rtol, atol, saltation, max_switches):
    """:func:`monodromy_reference` for a model with switching functions (see there)."""
    n = hb.n
    d = 2 * n
    w = float(p[hb.kw])
    _, C, K, Minv, forces, excitation = _pointwise(hb, p)
    funcs = [(e, el, i) for e, el, m in sw for i in range(m)]

    def switching(t, z):
        tau = np.array([w * t])
        out = [el.switching_functions(z[None, :n], z[None, n:], tau, p) for _, el, _ in sw]
        return np.concatenate([o.value[0] for o in out]), np.concatenate([o.difference[0] for o in out])

    def force_in_mode(t, z, mode):
        f = forces(z[:n], z[n:], t)[0].copy()
        h, jump = switching(t, z)
        return f + ((mode.astype(float) - (h > 0.0)) @ jump)

    mode = switching(0.0, z0)[0] > 0.0
    skip = [None]  # (function, restart time, value there): the sign just after a switch

    def rhs_state(t, z):
        acc = Minv @ (excitation(t) - C @ z[n:] - K @ z[:n] - force_in_mode(t, z, mode))
        return np.concatenate([z[n:], acc])

    def event(k):
        def h(t, z):
            if skip[0] is not None and skip[0][0] == k and t == skip[0][1]:
                return skip[0][2]
            return float(switching(t, z)[0][k])

        h.terminal = True
        return h

    evs = [event(k) for k in range(len(funcs))]
    t0, z = 0.0, z0.copy()
    pieces, events, nfev = [], [], 0
    while True:
        sol = solve_ivp(rhs_state, (t0, T), z, method="DOP853", rtol=rtol, atol=atol, events=evs, dense_output=True)
        nfev += int(sol.nfev)
        if not sol.success:
            raise ArithmeticError(f"solve_ivp failed on the reference integration: {sol.message}")
        t1 = float(sol.t[-1])
        pieces.append((t0, t1, sol.sol))
        if sol.status == 0:
            zT = sol.y[:, -1]
            break
        k = next(j for j in range(len(funcs)) if len(sol.t_events[j]))
        tc, zc = float(sol.t_events[k][0]), np.array(sol.y_events[k][0])
        e, el, i = funcs[k]
        direction = -1 if mode[k] else 1
        events.append(_saltation(hb, p, el, e, i, direction, tc, zc, force_in_mode(tc, zc, mode), saltation))
        if len(events) > max_switches:
            raise ArithmeticError(f"more than {max_switches} switches in one period (chatter) at t = {tc:.9g}")
        mode[k] = not mode[k]
        skip[0] = (k, tc, 1e-300 if mode[k] else -1e-300)
        t0, z = tc, zc
    Phi = np.eye(d)
    for s, (a, b, dense) in enumerate(pieces):
        if b > a:
            clamp = _clamped(a, b, s > 0, s < len(pieces) - 1)

            def rhs(t, y, clamp=clamp, dense=dense):
                tt = clamp(t)
                zz = dense(tt)
                _, dfdx, dfdxd = forces(zz[:n], zz[n:], tt)
                A = _state_matrix(Minv, C, K, dfdx, dfdxd, n)
                return (A @ y.reshape(d, d)).reshape(-1)

            sol = solve_ivp(rhs, (a, b), Phi.reshape(-1), method="DOP853", rtol=rtol, atol=atol)
            if not sol.success:
                raise ArithmeticError(f"solve_ivp failed on the variational equations: {sol.message}")
            Phi = sol.y[:, -1].reshape(d, d)
            nfev += int(sol.nfev)
        if s < len(events):
            Phi = events[s].saltation @ Phi
    return Monodromy(Phi, T, "dop853", evaluations=nfev, orbit_error=float(np.max(np.abs(zT - z0))),
                     switches=tuple(events), saltation=bool(events) and saltation)
