"""Stability of a quasi-periodic solution by time simulation started on it.

A torus of :class:`contin.hb.torus.QuasiPeriodicBalance` is an invariant
surface ``x(theta1, theta2)``; a trajectory on it has ``theta1 = Omega1 t``
and any ``theta2``. :func:`check_torus` starts the model's own time
integration (:func:`contin.timedomain.simulation.simulate`) on the torus
and on a slightly displaced copy, and follows their separation: it stays of
the size of the displacement near an attracting torus and grows
exponentially near a repelling one. Its fitted exponential rate is the
largest Lyapunov exponent of the motion on the torus while the separation
is small (zero for an attracting torus, whose direction along itself is
neutral; ``exp(rate T1)`` over one forcing period ``T1 = 2 pi nu / w`` is the
quasi-periodic analogue of the largest Floquet multiplier).
:func:`torus_distance` measures how far simulated states lie from the torus
section at ``theta1 = Omega1 t`` (the closest point over ``theta2``): the
error of the series.

An invariant circle of the stroboscopic map (:mod:`contin.timedomain.invariant_circle`)
is checked the same way but on its own: :func:`check_circle` starts one
trajectory off the circle, along the normal of the circle at one of its
points, and follows its distance to the circle once a forcing period
(:func:`circle_distance`). The component along the circle is no distance,
so the distance measures the normal directions alone: a check independent
of the Lyapunov exponents computed from the map's Jacobians
(:func:`contin.timedomain.invariant_circle.circle_lyapunov`).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from contin.timedomain.simulation import simulate

__all__ = ["CIRCLE_GROWTH", "SETTLED", "TorusVerdict", "check_circle", "circle_distance", "torus_distance",
           "check_torus"]

#: growth of the separation of two trajectories beyond which the torus repels
GROWN_UNSTABLE = 1e3
#: growth below which it attracts (a displacement along the torus is kept, and sheared by the flow)
GROWN_STABLE = 30.0
#: a circle's distance shrinking (growing) by this factor over the record is a verdict: stable (unstable)
CIRCLE_GROWTH = 4.0
#: a displacement off a circle shrunk to this fraction of itself has settled on the circle (its error against the
#: flow): no trend is read from there on (:func:`check_circle`)
SETTLED = 1e-3


@dataclasses.dataclass(frozen=True)
class TorusVerdict:
    """What a simulation started on a torus showed.

    Attributes
    ----------
    stable : bool or None
        None when the record is too short to tell.
    rate : float
        Fitted growth rate of the distance to the torus, 1/time.
    multiplier : float
        ``exp(rate T1)``, the distance's growth over one forcing period.
    distance : ndarray, shape (K,)
        Relative distance to the torus at the checked times.
    times : ndarray, shape (K,)
    message : str
    """

    stable: bool | None
    rate: float
    multiplier: float
    distance: np.ndarray
    times: np.ndarray
    message: str


def _section(qp, U, freqs, theta1: float, theta2: np.ndarray, order: int = 0):
    """States ``(x, x')`` of the torus at ``theta1`` and the phases ``theta2`` (shape (G,)), shape (G, 2n);
    with ``order`` 2 also their first and second derivatives in ``theta2``."""
    pairs = qp.basis.pairs
    k2 = pairs[1:, 1]
    ph = pairs[1:, 0][None, :] * theta1 + k2[None, :] * theta2[:, None]
    c, s = np.cos(ph), np.sin(ph)
    A, B = U[1::2], U[2::2]
    f = freqs[1:]
    out = [np.concatenate([U[0][None, :] + c @ A + s @ B, (-s * f) @ A + (c * f) @ B], axis=1)]
    if order:
        out.append(np.concatenate([(-s * k2) @ A + (c * k2) @ B, (-c * f * k2) @ A + (-s * f * k2) @ B], axis=1))
        k22 = k2 * k2
        out.append(np.concatenate([(-c * k22) @ A + (-s * k22) @ B, (s * f * k22) @ A + (-c * f * k22) @ B],
                                  axis=1))
    return out if order else out[0]


def torus_distance(qp, u, lam: float, t: np.ndarray, states: np.ndarray, grid: int = 256) -> np.ndarray:
    """Distance of simulated states to the torus, relative to the torus' RMS state size.

    Parameters
    ----------
    qp : QuasiPeriodicBalance
    u : ndarray, shape (qp.m,)
    lam : float
    t : ndarray, shape (K,)
        Times (``theta1 = Omega1 t`` there).
    states : ndarray, shape (K, 2n)
        Simulated ``(x, x')``.
    grid : int
        ``theta2`` samples of each section; the closest one is refined by Newton's method.

    Returns
    -------
    ndarray, shape (K,)
    """
    U = qp.blocks(u)
    freqs = qp.frequencies(u, lam)
    Omega1 = qp.base_frequency(qp.params_at(lam))
    th2 = 2.0 * np.pi * np.arange(grid) / grid
    x, xd, _, _ = qp.samples_of(u, lam)
    size = math.sqrt(np.mean(np.sum(x * x + xd * xd, axis=1))) or 1.0
    out = np.empty(len(t))
    for k, (tk, zk) in enumerate(zip(t, states)):
        d2 = np.sum((_section(qp, U, freqs, Omega1 * tk, th2) - zk) ** 2, axis=1)
        th = np.array([th2[int(np.argmin(d2))]])
        for _ in range(6):  # Newton on d/dtheta2 |z - zk|^2 / 2 = (z - zk) . z' = 0
            z, z1, z2 = (a[0] for a in _section(qp, U, freqs, Omega1 * tk, th, order=2))
            g = float((z - zk) @ z1)
            h = float(z1 @ z1 + (z - zk) @ z2)
            if h <= 0.0:
                break
            th = th - g / h
        z = _section(qp, U, freqs, Omega1 * tk, th)[0]
        out[k] = math.sqrt(min(float(d2.min()), float(np.sum((z - zk) ** 2)))) / size
    return out


def check_torus(qp, u, lam: float, *, periods: float = 200.0, steps_per_period: int = 256,
                perturbation: float = 1e-6, checks: int = 100, seed: int = 0) -> TorusVerdict:
    """Simulate from a point of the torus and from a perturbed copy; tell whether the two stay together.

    Two trajectories start on the torus, one displaced by ``perturbation``
    (relative to the torus' RMS state size). On an attracting torus their
    separation stays of the order of the displacement (the part off the
    torus dies out, the part along it is neutral); on a repelling one it
    grows exponentially. The verdict compares the separation with the
    displacement: ``stable`` when the last quarter of the record stays below
    ``GROWN_STABLE`` times it, unstable beyond ``GROWN_UNSTABLE`` times, no
    verdict in between (the record is too short for the rate). The distance
    of the unperturbed trajectory to the torus is the series' own error and
    is reported in the message.

    Parameters
    ----------
    qp : QuasiPeriodicBalance
    u : ndarray, shape (qp.m,)
        A solution ``(coefficients, w2)``.
    lam : float
    periods : float
        Forcing periods ``2 pi / w`` simulated.
    steps_per_period : int
        RK4 steps per forcing period (the model's contact may ask for more:
        :func:`contin.timedomain.simulation.simulate` refuses a step beyond
        its stability limit).
    perturbation : float
        Size of the initial displacement, relative to the torus' RMS state
        size, along a fixed pseudo-random direction.
    checks : int
        Times at which the separation is measured, evenly spread.

    Returns
    -------
    TorusVerdict
        ``distance`` is the separation relative to the torus size.
    """
    p = qp.params_at(lam)
    params = dict(zip(qp.model.param_names, p))
    x0, v0 = qp.state_at(u, lam, np.zeros(1))
    z0 = np.concatenate([x0[0], v0[0]])
    size = math.sqrt(float(np.mean(np.sum(np.concatenate(qp.samples_of(u, lam)[:2], axis=1) ** 2, axis=1)))) or 1.0
    dz = np.random.default_rng(seed).normal(size=z0.size)
    e0 = perturbation * size
    z1 = z0 + e0 * dz / np.linalg.norm(dz)
    n = qp.n
    S = int(steps_per_period)
    every = max(1, int(round(periods * S / checks)))
    runs = [simulate(qp.model, params, z[:n], z[n:], periods=periods, steps_per_period=S, record_every=every)
            for z in (z0, z1)]
    states = [np.concatenate([r.x, r.v], axis=1) for r in runs]
    t = runs[0].t
    sep = np.linalg.norm(states[1] - states[0], axis=1) / e0
    err = float(np.max(torus_distance(qp, u, lam, t, states[0])))
    T1 = 2.0 * math.pi / qp.base_frequency(p)
    keep = sep > 0
    rate = float(np.polyfit(t[keep], np.log(sep[keep]), 1)[0]) if np.count_nonzero(keep) > 2 else 0.0
    tail = sep[len(sep) * 3 // 4:]
    what = f"over {periods:g} forcing periods; the series lies within {err:.2g} of the simulated motion"
    if np.max(sep) > GROWN_UNSTABLE:
        stable, msg = False, f"a displacement of {perturbation:.0e} grew {np.max(sep):.3g} times {what}"
    elif np.max(tail) < GROWN_STABLE:
        stable, msg = True, f"a displacement of {perturbation:.0e} stayed within {np.max(tail):.3g} times {what}"
    else:
        stable, msg = None, (f"undecided: a displacement of {perturbation:.0e} grew {np.max(tail):.3g} times "
                             f"(between {GROWN_STABLE:g} and {GROWN_UNSTABLE:g}) {what}")
    return TorusVerdict(stable, rate, math.exp(min(rate * T1, 700.0)), sep * perturbation, t, msg)


def circle_distance(problem, u, states, fine: int = 16, newton: int = 3) -> np.ndarray:
    """The distance of each state (K, 2n) to the invariant circle ``u`` of ``problem``: shape (K,).

    The nearest of ``fine * N`` points of the circle's trigonometric interpolant
    ``p(theta)``, then ``newton`` Newton steps on ``(p(theta) - z) . p'(theta) = 0``.
    """
    U, _ = problem.blocks(u)
    N = problem.points
    c = np.fft.fft(U, axis=0) / N  # p(theta) = Re sum_k c_k exp(i k theta), N odd: no Nyquist term
    k = np.fft.fftfreq(N, 1.0 / N)
    Z = np.atleast_2d(np.asarray(states, dtype=float))
    grid = 2.0 * math.pi * np.arange(fine * N) / (fine * N)
    P = np.real(np.exp(1j * np.outer(grid, k)) @ c)  # (M, 2n)
    theta = grid[np.argmin(np.sum((Z[:, None, :] - P[None, :, :]) ** 2, axis=2), axis=1)]
    for _ in range(newton):
        E = np.exp(1j * np.outer(theta, k))
        r = np.real(E @ c) - Z
        d1, d2 = np.real(E @ (1j * k[:, None] * c)), np.real(E @ (-(k ** 2)[:, None] * c))
        theta = theta - np.sum(r * d1, axis=1) / np.maximum(np.sum(d1 * d1 + r * d2, axis=1), 1e-300)
    return np.linalg.norm(np.real(np.exp(1j * np.outer(theta, k)) @ c) - Z, axis=1)


def check_circle(problem, u, lam: float, *, periods: int = 400, displacement: float = 5e-2) -> TorusVerdict:
    """Simulate from a point displaced off an invariant circle; tell whether it returns (module docstring).

    The trajectory starts at the circle's point ``u_0`` moved by ``displacement``
    (relative to the circle's largest state) along the normal direction of the
    circle there nearest the state's first component, with the integrator and
    steps of the circle's own map. Its distance to the circle is measured once a
    forcing period. The distance does not shrink or grow evenly (the normal
    contraction varies along the circle and the faster normal directions die out
    first), and where the circle attracts it settles at the circle's own error
    against the flow: the rate fitted to its logarithm over the record is
    reported (a bound on the largest normal exponent there), and the verdict
    reads the end: stable where the distance over the last quarter of the record
    (its median: passing a corner of the circle makes a spike) is below
    ``1 / CIRCLE_GROWTH`` of that at the start and still shrinking over the
    record's second half (the rate fitted there negative: a weakly unstable
    torus loses the displacement's fast components first and then grows the
    rest slowly) or down to :data:`SETTLED` of it (at the circle's own error,
    where it stays), unstable where it grew ``CIRCLE_GROWTH`` times (or the
    trajectory blew up: ``rate`` infinite), else none.

    Parameters
    ----------
    problem : InvariantCircleProblem
    u : array_like, shape (problem.size,)
        A converged circle.
    lam : float
    periods : int
        Forcing periods simulated.
    displacement : float
        Relative to the circle's largest state.

    Returns
    -------
    TorusVerdict
        ``rate`` per forcing period (above), ``multiplier`` ``exp(rate)``, ``distance`` relative to the initial
        one at the ``times`` (forcing periods).
    """
    if isinstance(periods, bool) or not isinstance(periods, (int, np.integer)) or periods < 4:
        raise ValueError(f"periods: expected an integer of at least 4, got {periods!r}")
    U, _ = problem.blocks(u)
    n = problem.n
    N = problem.points
    freqs = np.fft.fftfreq(N, 1.0 / N)
    tangent = np.real((1j * freqs) @ (np.fft.fft(U, axis=0) / N))  # u'(0) of the trigonometric interpolant
    normal = np.eye(2 * n)[0] - tangent * tangent[0] / float(tangent @ tangent)
    scale = float(np.max(np.abs(U))) or 1.0
    z0 = U[0] + displacement * scale * normal / np.linalg.norm(normal)
    S = problem.options.steps_per_period
    try:
        run = simulate(problem.model, problem.params_at(lam), z0[:n], z0[n:], periods=periods, steps_per_period=S,
                       record_every=S)
    except ArithmeticError as exc:  # the trajectory ran away from the circle to infinity
        return TorusVerdict(False, math.inf, math.inf, np.ones(1), np.zeros(1),
                            f"a displacement of {displacement:.0e} off the circle ran away: {exc}")
    states = np.asarray(run.section, dtype=float)[:periods + 1]  # t = 0, T, ..., periods T
    d = circle_distance(problem, u, states)
    rel = d / d[0]
    k = np.arange(len(d))
    end = float(np.median(rel[-max(1, len(rel) // 4):]))  # the median: a corner of the circle passed is a spike
    rate = float(np.polyfit(k, np.log(np.maximum(rel, 1e-300)), 1)[0])
    what = (f"a displacement of {displacement:.0e} off the circle is {end:.3g} of itself over the last quarter of "
            f"{periods} periods")
    # the trend over the record's second half, once the fast normal directions have died out: a weakly
    # unstable torus (near its Neimark-Sacker point) has shrunk the distance by then, and grows it again slowly
    half = len(rel) // 2
    late = float(np.polyfit(k[half:], np.log(np.maximum(rel[half:], 1e-300)), 1)[0]) if len(rel) - half >= 2 else rate
    stable = (True if end < 1.0 / CIRCLE_GROWTH and (late < 0.0 or end < SETTLED)
              else (False if end > CIRCLE_GROWTH else None))
    if stable is None and end < 1.0 / CIRCLE_GROWTH:
        what += f", but growing again over the second half (rate {late:+.2e} a period)"
    return TorusVerdict(stable, rate, math.exp(min(rate, 700.0)), rel, k.astype(float),
                        what if stable is not None else f"undecided: {what}")
