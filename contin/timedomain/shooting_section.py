"""Where a shooting branch takes its unknowns: the section of its orbits farthest from the contact surfaces.

A branch of :class:`~contin.timedomain.multiple_shooting.ShootingProblem` is a
curve in the orbits' states at the section ``t0`` (``start_step``; forcing
phase zero by default). The orbits are the same whatever the section, but the
curve is not equally easy to follow: where ``t0`` falls inside a bounce of a
stiff contact (a journal landing on its casing after a lift-off and chattering),
a small change of the orbit slides the bounce's timing across ``t0`` and the
state there sweeps the bounce's whole velocity reversal. The curve is then
stretched over a tiny change of the orbit, its tangent turns at each corner
the contact puts into it, and the steps crawl (the bearing rotor's
subharmonic near ``w = 2.1855``, parametrised at ``t = 0``: 75 steps and no
way past; at ``t = T``, where the journal slides steadily on its casing, three
steps: docs/theory/events.md).

:func:`quiet_step` picks the step of the orbit's grid farthest in time from
every switch along it (the middle of its longest stretch without a contact
arc opening or closing: in a steady contact or a flight, far from the
landings and lift-offs where grazing and chatter happen); along an orbit
without switches, the state farthest from every switching surface (each
function relative to its largest modulus along the orbit).
:func:`at_quiet_section` moves an orbit's unknowns there (:func:`resectioned`,
:func:`unknowns_at`). The section is chosen once, where a branch starts.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from contin.timedomain.multiple_shooting import ShootingProblem

__all__ = ["at_quiet_section", "quiet_step", "resectioned", "state_at_zero", "unknowns_at"]


def resectioned(problem: ShootingProblem, k0: int, segments: int | None = None) -> ShootingProblem:
    """The same orbits parametrised at the section ``start_step = k0`` and, with ``segments``, cut into that many
    segments (an orbit's unknowns there: :func:`unknowns_at`)."""
    opts = dataclasses.replace(problem.options, start_step=int(k0),
                               segments=problem.segments if segments is None else int(segments))
    return ShootingProblem(problem.model, problem.parameter, problem.base, opts)


def unknowns_at(problem: ShootingProblem, u: np.ndarray, lam: float, k0: int,
                segments: int | None = None) -> np.ndarray:
    """The unknowns of ``problem``'s orbit ``u`` at the section ``k0`` with ``segments`` segments (default: the
    problem's): the orbit's states at the steps ``k0 + k L`` of its grid, integrated again; those of
    :func:`resectioned` ``(problem, k0, segments)``. Shape (2 n segments,)."""
    M = problem.segments if segments is None else int(segments)
    W = problem.step_states(u, lam)  # from t = 0
    idx = (int(k0) + np.arange(M) * (W.shape[0] // M)) % W.shape[0]
    return W[idx].reshape(-1).copy()


def state_at_zero(problem: ShootingProblem, u: np.ndarray, lam: float) -> np.ndarray:
    """The orbit's state at ``t = 0`` (forcing phase zero), shape (2n,): its first unknowns at the default
    section, else the step states' first."""
    if not problem.options.start_step:
        return np.asarray(u, dtype=float)[:2 * problem.n].copy()
    return problem.step_states(u, lam)[0].copy()


def quiet_step(problem, u: np.ndarray, lam: float, segments: int | None = None) -> int:
    """The section (a step of the orbit's grid from ``t = 0``, below the segments' length ``L``) whose segment starts
    ``k0 + j L`` are all farthest in time from every switch along the orbit (module docstring); 0 for a model without
    switching functions.

    Parameters
    ----------
    problem : ShootingProblem
    u : ndarray, shape (problem.size,)
        The orbit's unknowns (a converged orbit).
    lam : float
    segments : int, optional
        The segments the orbit will be cut into (default: the problem's).
    """
    if not problem.n_switch:
        return 0
    s = problem.switching_values(problem.step_states(u, lam), lam)  # (steps, n_switch), from t = 0
    n = s.shape[0]
    side = s > 0.0
    switched = np.flatnonzero(np.any(side != np.roll(side, 1, axis=0), axis=1))  # a switch just before these steps
    if switched.size:  # the circular distance to the nearest switch, either way round
        k = np.arange(n)
        at = np.searchsorted(switched, k)
        ahead, behind = switched[at % switched.size], switched[(at - 1) % switched.size]
        score = np.minimum((ahead - k) % n, (k - behind) % n).astype(float)
    else:
        a = np.abs(s)
        top = a.max(axis=0)
        score = (a / np.where(top > 0.0, top, 1.0)).min(axis=1)
    # every segment start must be quiet: the sections k0 in [0, L) scored by their worst start k0 + j L
    M = problem.segments if segments is None else int(segments)
    return int(np.argmax(score.reshape(M, n // M).min(axis=0)))


def at_quiet_section(problem, u: np.ndarray, lam: float, segments: int | None = None):
    """``(problem', u')``: the orbit ``u`` of ``problem`` parametrised at its :func:`quiet_step` with ``segments``
    segments (default: the problem's); the problem and unknowns themselves where nothing changes."""
    M = problem.segments if segments is None else int(segments)
    k = quiet_step(problem, u, lam, M)
    if k == problem.options.start_step and M == problem.segments:
        return problem, np.asarray(u, dtype=float)
    return resectioned(problem, k, M), unknowns_at(problem, u, lam, k, M)
