"""Reference monodromies by adaptive integration (``scipy.integrate.solve_ivp``, DOP853), and the :class:`Monodromy` result.

- :func:`monodromy_reference`: ``scipy.integrate.solve_ivp`` (DOP853, tight
  tolerances) of the *full nonlinear* state together with the variational
  equations, started from the HB state at ``t = 0``. It measures the HB
  truncation error too (``orbit_error``: how far the true flow is from
  returning to the start after one period). :func:`monodromy_orbit_ivp`
  integrates the variational equations along the HB orbit itself with the
  same adaptive scheme, isolating the error of the fixed-step scheme.

With switches (:mod:`contin.stability.saltation`), :func:`monodromy_orbit_ivp`
integrates between those of :func:`switching_events`; :func:`monodromy_reference`
finds its own on the nonlinear trajectory (terminal events of ``solve_ivp``,
each contact law frozen between them) and applies the same saltation matrices.

:class:`Monodromy` is the result of these and of
:func:`contin.stability.monodromy.monodromy_rk4`.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from contin.stability.saltation import (
    check_switch_mode,
    solution_period,
    switch_event,
    switch_segments,
    switching_elements,
    orbit_state,
    switching_events,
)

__all__ = ["Monodromy", "monodromy_orbit_ivp", "monodromy_reference"]


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


def _pointwise(hb, p):
    """Callables evaluating the model at one state (the reference path)."""
    n = hb.n
    M, C, K = hb.model.linear(p)
    Minv = np.linalg.inv(M)
    w = hb.excitation_frequency(p)
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


def _clamped(a, b, inner_a, inner_b):
    """``t -> t`` clamped into ``[a, b]`` shrunk by ``1e-9 (b - a)`` at the ends that are switches."""
    lo = a + (1e-9 * (b - a) if inner_a else 0.0)
    hi = b - (1e-9 * (b - a) if inner_b else 0.0)
    return lambda t: min(max(t, lo), hi)


def _variational_ivp(pieces, events, linear, rtol, atol):
    """``Phi`` over one period by DOP853, piece by piece, with the switches' saltation matrices between.

    ``pieces``: ``(a, b, state)`` with ``state(t)`` the orbit's state on ``[a, b]`` (its ends evaluated
    just inside); ``events[s]`` follows piece ``s``; ``linear = (Minv, C, K, forces, n)``.
    Returns ``(Phi, number of right-hand side evaluations)``.
    """
    from scipy.integrate import solve_ivp  # here: scipy.integrate is loaded only by a reference

    Minv, C, K, forces, n = linear
    d = 2 * n
    Phi, nfev = np.eye(d), 0
    for s, (a, b, state) in enumerate(pieces):
        if b > a:
            clamp = _clamped(a, b, s > 0, s < len(pieces) - 1)

            def rhs(t, y, clamp=clamp, state=state):
                tt = clamp(t)
                z = state(tt)
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
    return Phi, nfev


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
    check_switch_mode(switches)
    n = hb.n
    p = hb.params_at(lam)
    T = solution_period(hb, lam)
    _, C, K, Minv, forces, _ = _pointwise(hb, p)
    events = [] if switches == "ignore" else switching_events(hb, u, lam, samples, saltation=switches == "saltation")
    pieces = [(a, b, lambda t: orbit_state(hb, u, lam, t)) for a, b in switch_segments(events, T)]
    Phi, nfev = _variational_ivp(pieces, events, (Minv, C, K, forces, n), rtol, atol)
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
    from scipy.integrate import solve_ivp  # here: scipy.integrate is loaded only by a reference

    check_switch_mode(switches)
    n = hb.n
    p = hb.params_at(lam)
    T = solution_period(hb, lam)
    _, C, K, Minv, forces, excitation = _pointwise(hb, p)
    d = 2 * n
    z0 = orbit_state(hb, u, lam, 0.0)
    sw = [] if switches == "ignore" else switching_elements(hb.model)
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
    from scipy.integrate import solve_ivp  # here: scipy.integrate is loaded only by a reference

    n = hb.n
    w = hb.excitation_frequency(p)
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
        events.append(switch_event(hb, p, el, e, i, direction, tc, zc, force_in_mode(tc, zc, mode), saltation))
        if len(events) > max_switches:
            raise ArithmeticError(f"more than {max_switches} switches in one period (chatter) at t = {tc:.9g}")
        mode[k] = not mode[k]
        skip[0] = (k, tc, 1e-300 if mode[k] else -1e-300)
        t0, z = tc, zc
    Phi, nfev_var = _variational_ivp(pieces, events, (Minv, C, K, forces, n), rtol, atol)
    nfev += nfev_var
    return Monodromy(Phi, T, "dop853", evaluations=nfev, orbit_error=float(np.max(np.abs(zT - z0))),
                     switches=tuple(events), saltation=bool(events) and saltation)
