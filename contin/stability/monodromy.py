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
  orbit is refused (:class:`~contin.stability.rk4_step_limit.RK4StepError`, an
  ``ArithmeticError`` naming the step count needed), or, with ``max_steps``,
  the integration is done again with that count. Where
  the orbit crosses a switching surface of a force element, the variational
  equations are integrated piecewise between the switches, with a saltation
  matrix at each.
- :func:`monodromy_reference`, :func:`monodromy_orbit_ivp`:
  ``scipy.integrate.solve_ivp`` (DOP853, tight tolerances), of the nonlinear
  flow from the HB state with its variational equations, or of the
  variational equations along the HB orbit.

This module holds :func:`monodromy_rk4` (with its piecewise path) and
:func:`state_matrices`, and re-exports the names of its ``__all__`` that live in
the others:

- :mod:`contin.stability.rk4`: the compiled fixed-step kernels;
- :mod:`contin.stability.rk4_step_limit`: RK4's stability check of the step;
- :mod:`contin.stability.saltation`: the HB orbit at any time
  (:func:`orbit_state`), switching events and saltation matrices;
- :mod:`contin.stability.monodromy_reference`: the :class:`Monodromy` result
  and the ``solve_ivp`` references.
"""

from __future__ import annotations

import numpy as np

from contin.hb import aft
from contin.hb.harmonics import coefficient_blocks
from contin.stability.monodromy_reference import Monodromy, monodromy_orbit_ivp, monodromy_reference
from contin.stability.rk4 import (
    force_jacobians,
    full_state_matrices,
    lower_blocks,
    variational_rk4,
    rk4_propagate,
)
from contin.stability.rk4_step_limit import RK4StepError, check_rk4_step
from contin.stability.saltation import (
    SWITCH_MODES,
    SwitchEvent,
    checked_base_frequency,
    solution_period,
    switch_values,
    switching_elements,
    element_switching_events,
    orbit_state,
    switching_events,
)

__all__ = [
    "Monodromy",
    "SwitchEvent",
    "switching_events",
    "state_matrices",
    "rk4_propagate",
    "monodromy_rk4",
    "RK4StepError",
    "monodromy_orbit_ivp",
    "monodromy_reference",
    "orbit_state",
]


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
    if samples < 2 * hb.H + 1:
        raise ValueError(f"need at least 2H+1 = {2 * hb.H + 1} orbit samples, got {samples}")
    p = hb.params_at(lam)
    x, xd, tau, T = _orbit_samples(hb, u, lam, samples)
    return full_state_matrices(_lower_blocks_at(hb, p, x, xd, tau)), T


def _orbit_samples(hb, u, lam, samples):
    """The HB orbit on ``samples`` equidistant points of the period.

    Returns ``(x, xd, tau, T)``: states (samples, n) each, the excitation
    phases ``nu theta_j`` (samples,) and the period.
    """
    Omega = checked_base_frequency(hb, lam)
    U = np.ascontiguousarray(coefficient_blocks(u, hb.n))
    x, xp = aft.synthesize(U, samples)
    xd = Omega * xp
    theta = 2.0 * np.pi * np.arange(samples) / samples
    return x, xd, hb.nu * theta, hb.period(hb.params_at(lam))


def _lower_blocks_at(hb, p, x, xd, tau):
    """The lower block row ``[-M^-1 (K + df/dx), -M^-1 (C + df/dx')]`` of ``A`` at the states ``(x, xd)``.

    Parameters
    ----------
    x, xd : ndarray, shape (N, n)
    tau : ndarray, shape (N,)
        Excitation phases.

    Returns
    -------
    ndarray, shape (N, n, 2n)
        The upper block row of ``A`` is ``[0, I]`` everywhere and is not stored.
    """
    _, dfdx, dfdxd = force_jacobians(hb, x, xd, tau, p, scratch=True)
    return lower_blocks(*_linear_terms(hb, p), dfdx, dfdxd)


def _linear_terms(hb, p):
    """``(M^-1, K, C)`` as contiguous float arrays."""
    M, C, K = hb.model.linear(p)
    return np.linalg.inv(M), np.ascontiguousarray(K, dtype=float), np.ascontiguousarray(C, dtype=float)


def _integrate(hb, p, x, xd, tau, starts, steps, h, jumps, T, lam, nominal):
    """``Phi(T)`` of the variational equations on the orbit nodes ``(x, xd, tau)`` (see :func:`variational_rk4`).

    The largest step is first checked against RK4's stability limit at every
    node (:func:`check_rk4_step`; ``nominal``: the steps per period asked
    for, which its advice scales).
    """
    _, dfdx, dfdxd = force_jacobians(hb, x, xd, tau, p, scratch=True)
    Minv, K, C = _linear_terms(hb, p)
    check_rk4_step(Minv, K, C, dfdx, dfdxd, float(np.max(h)), T, lam, nominal)
    Phi = variational_rk4(Minv, K, C, dfdx, dfdxd, starts, steps, h, jumps)
    if not np.isfinite(Phi).all():
        raise ArithmeticError(f"monodromy at lambda = {lam:.10g}: the RK4 integration is not finite")
    return Phi


def monodromy_rk4(hb, u: np.ndarray, lam: float, steps: int = 512, switches: str = "saltation",
                  max_steps: int | None = None) -> Monodromy:
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
        switching functions (:meth:`contin.model.base.ForceElement.switching_functions`)
        are located on the orbit, the variational equations are integrated
        piecewise between them (each segment in steps of at most ``T/S``,
        about ``S`` in all) and the saltation matrix is applied at each switch.
        ``'piecewise'``: the same without saltation matrices (wrong where the
        force law jumps; for comparison). ``'ignore'``: fixed steps straight
        across the switches (first order in ``h`` where the Jacobian jumps,
        and no saltation). An orbit without switches takes the fixed-step
        path in every mode, with the same result.
    max_steps : int, optional
        Where ``steps`` is too large a step for the stiffest mode along the
        orbit, take the step count that mode needs
        (:attr:`~contin.stability.rk4_step_limit.RK4StepError.needed`, measured at
        every node) and integrate again, as long as it is at most
        ``max_steps``. None (default): no refinement.

    Returns
    -------
    Monodromy
        ``steps``: the step count used.

    Raises
    ------
    RK4StepError
        (an ``ArithmeticError``) A step beyond RK4's stability limit for the
        stiffest eigenvalue of ``A`` along the orbit, and the step count
        that mode needs (its ``needed``, named in the message) beyond
        ``max_steps``.
    ArithmeticError
        A switch that cannot be resolved (see :func:`switching_events`), or
        a non-finite Jacobian or result.
    """
    steps = int(steps)
    if steps < hb.H + 1:
        raise ValueError(f"steps_per_period must be >= H+1 = {hb.H + 1}, got {steps}")
    if switches not in SWITCH_MODES:
        raise ValueError(f"switches must be one of {list(SWITCH_MODES)}, got {switches!r}")
    first = steps
    while True:
        try:
            return _monodromy_rk4(hb, u, lam, steps, switches)
        except RK4StepError as exc:
            if max_steps is None:
                raise
            if exc.needed > max_steps:
                tried = f" (refined from {first})" if steps != first else ""
                raise RK4StepError(
                    f"monodromy at lambda = {lam:.10g}: the stiffest mode along the orbit (|eigenvalue| "
                    f"{exc.rate:.4g}) needs steps_per_period >= {exc.needed}{tried}, beyond max_steps_per_period = "
                    f"{max_steps}; raise max_steps_per_period to >= {exc.needed}", exc.rate, steps, exc.needed, exc.phase
                ) from None
            # needed > steps, and at most max_steps: the loop ends
            steps = exc.needed


def _monodromy_rk4(hb, u, lam, steps, switches):
    """:func:`monodromy_rk4` with one step count (arguments checked)."""
    p = hb.params_at(lam)
    x, xd, tau, T = _orbit_samples(hb, u, lam, 2 * steps)
    if switches != "ignore":
        sw = switching_elements(hb.model)
        events = element_switching_events(hb, u, lam, 2 * steps, switches == "saltation", sw, (x, xd)) if sw else []
        if events:
            return _piecewise_rk4(hb, u, lam, steps, events, switches == "saltation")
    Phi = _integrate(hb, p, x, xd, tau, np.zeros(1, np.int64), np.array([steps], np.int64), np.array([T / steps]),
                     np.zeros((0, 2 * hb.n, 2 * hb.n)), T, lam, steps)
    return Monodromy(Phi, T, "rk4", steps=steps, evaluations=2 * steps)


def _modes(hb, u, lam, p, t, z=None, sw_elements=None):
    """Signs ``h > 0`` of every switching function at the orbit times ``t``: shape (len(t), total m).

    ``z`` (shape (len(t), 2n)): the orbit states there, if already known;
    ``sw_elements``: :func:`switching_elements` of the model, if known.
    """
    n = hb.n
    if z is None:
        z = orbit_state(hb, u, lam, np.asarray(t, dtype=float))
    if sw_elements is None:
        sw_elements = switching_elements(hb.model)
    tau = hb.excitation_frequency(p) * np.asarray(t, dtype=float)
    cols = [switch_values(el, z[:, :n], z[:, n:], tau, p) > 0.0 for _, el, _ in sw_elements]
    return np.concatenate(cols, axis=1) if cols else np.zeros((len(t), 0), dtype=bool)


def _mode_columns(model) -> dict:
    """Column of each ``(element index, function)`` in :func:`_modes`."""
    cols, k = {}, 0
    for e, _, m in switching_elements(model):
        for i in range(m):
            cols[(e, i)] = k
            k += 1
    return cols


def _piecewise_nodes(hb, u, lam, p, events, T, steps):
    """RK4 nodes of each segment between switches, with one-sided end nodes.

    Returns ``(t, z, starts, nsteps, h)``: node times (K,), the orbit there
    (K, 2n), the first node and the step count of each segment, and its step. End nodes at a switch are
    moved into their segment by ``1e-9`` (up to ``1e-3``) of the half step, so
    that the elements evaluate the segment's law there; every node of a
    segment is checked to be in the segment's contact mode.
    """
    sw_elements = switching_elements(hb.model)
    bounds = np.array([0.0] + [ev.time for ev in events] + [T])
    a, b = bounds[:-1], bounds[1:]
    G = a.size
    L = b - a
    # no step longer than T/steps (the factor forgives the rounding of a whole number of steps), so that
    # RK4's stability check, and the step count it asks for, hold on every segment
    nsteps = np.where(L <= 0.0, 0, np.maximum(1, np.ceil(steps * L / T * (1.0 - 1e-12)))).astype(np.int64)
    hs = np.where(nsteps > 0, L / np.maximum(nsteps, 1), 0.0)
    count = np.where(nsteps > 0, 2 * nsteps + 1, 0)
    starts = np.concatenate([[0], np.cumsum(count)[:-1]]).astype(np.int64)
    seg = np.repeat(np.arange(G), count)
    k = np.arange(seg.size) - starts[seg]
    t = a[seg] + L[seg] * k / (2 * nsteps[seg])
    live = np.nonzero(nsteps > 0)[0]
    last = starts[live] + 2 * nsteps[live]
    t[last] = b[live]
    z = orbit_state(hb, u, lam, t)
    mode = _modes(hb, u, lam, p, t, z, sw_elements)
    # the expected mode of each segment: that of its middle node
    mid_node = starts + nsteps
    expected = mode[mid_node[seg]]
    # the end nodes at a switch, in the order (segment, first, last); each moves into its segment
    half = L / np.maximum(2 * nsteps, 1)
    ends = np.stack([starts[live], last], axis=1)
    sign = np.broadcast_to([1.0, -1.0], ends.shape)
    move = np.stack([live > 0, live < G - 1], axis=1)
    node, sign, half = ends[move], sign[move], np.repeat(half[live], 2).reshape(-1, 2)[move]
    base = t[node]
    pending = np.arange(node.size)
    for q in range(7):
        if not pending.size:
            break
        tq = base[pending] + sign[pending] * 1e-9 * 10.0**q * half[pending]
        zq = orbit_state(hb, u, lam, tq)
        ok = np.all(_modes(hb, u, lam, p, tq, zq, sw_elements) == expected[node[pending]], axis=1)
        t[node[pending[ok]]] = tq[ok]
        z[node[pending[ok]]] = zq[ok]
        pending = pending[~ok]
    if pending.size:
        raise ArithmeticError(f"the contact mode next to the switch at t = {base[pending[0]]:.12g} cannot be resolved")
    mode[node] = expected[node]
    bad = np.nonzero(np.any(mode != expected, axis=1))[0]
    if bad.size:
        raise ArithmeticError(
            f"the orbit switches at t = {t[bad[0]]:.9g} between the located switches (a contact shorter than "
            f"T/{2 * steps}, or a grazing); raise steps_per_period")
    # each switch flips its own function and nothing else, and the mode is periodic
    cols = _mode_columns(hb.model)
    mid = [mode[mid_node[s]] if nsteps[s] else None for s in range(G)]
    current = (mid[0] if mid[0] is not None else mid[-1]).copy()
    for s, ev in enumerate(events):
        current[cols[(ev.element, ev.function)]] ^= True
        if mid[s + 1] is not None and not np.array_equal(current, mid[s + 1]):
            raise ArithmeticError(f"the contact mode after the switch at t = {ev.time:.12g} is not the one the "
                                  "switch leads to: an unlocated switch; raise steps_per_period")
    if mid[0] is not None and not np.array_equal(current, mid[0]):
        raise ArithmeticError("the contact mode at the end of the period differs from the start: an unlocated switch")
    return t, z, starts, nsteps, hs


def _piecewise_rk4(hb, u, lam, steps, events, saltation):
    n = hb.n
    p = hb.params_at(lam)
    T = solution_period(hb, lam)
    t, z, starts, nsteps, h = _piecewise_nodes(hb, u, lam, p, events, T, steps)
    jumps = np.array([ev.saltation for ev in events])
    tau = hb.excitation_frequency(p) * t
    Phi = _integrate(hb, p, np.ascontiguousarray(z[:, :n]), np.ascontiguousarray(z[:, n:]), tau,
                     starts, nsteps, h, jumps, T, lam, steps)
    return Monodromy(Phi, T, "rk4", steps=int(nsteps.sum()), evaluations=len(t), switches=tuple(events),
                     saltation=bool(saltation))
