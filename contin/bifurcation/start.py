"""Robust starting points for stiff problems: homotopy in a parameter.

A Newton solve of a harmonic-balance problem from the linear solution can fail
when the problem is stiff or its linear part is singular. The rotor with a
clearance bearing is both: out of contact the shaft pivots as a rigid body
(singular K), and in contact the contact is 12881 times stiffer than the shaft,
so Newton's basin is tiny. A homotopy in the contact stiffness solves the soft
problem first (a wide basin, where the static load alone fixes the contact
side), then follows the solution with the continuation engine to the real
stiffness, and finally to the wanted start value of the continuation
parameter if the homotopy had to be done elsewhere.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from contin.engine.continuation import ContinuationOptions, continuation
from contin.hb.problem import HarmonicBalance
from contin.engine.newton import solve_at_parameter
from contin.model.base import Model

__all__ = ["HomotopyFailed", "homotopy_start", "simulation_start", "integrated_model"]


class HomotopyFailed(RuntimeError):
    """No start could be found; the message says which stage failed and why."""


def homotopy_start(hb: HarmonicBalance, lam0: float, parameter: str, soft_value: float, guess: np.ndarray,
                   at: float | None = None, options: ContinuationOptions | None = None,
                   harmonics: int | None = None) -> np.ndarray:
    """A converged solution of ``hb`` at ``lam = lam0`` by homotopy in ``parameter``.

    Parameters
    ----------
    hb : HarmonicBalance
        The problem whose continuation parameter is ``lam``.
    lam0 : float
        Where the solution is wanted.
    parameter : str
        The homotopy parameter (e.g. the contact stiffness ``kbn``); its target
        value is the one ``hb`` holds.
    soft_value : float
        Its value in the easy problem.
    guess : ndarray, shape (hb.size,)
        Start guess for the easy problem.
    at : float, optional
        Value of ``lam`` at which to do the homotopy (default ``lam0``); the
        solution is then continued in ``lam`` to ``lam0``.
    options : ContinuationOptions, optional
    harmonics : int, optional
        Do the homotopy with this many harmonics (fewer than ``hb.H``: each
        step is cheaper), then solve ``hb`` by Newton from its solution padded
        with zeros; if either fails, the homotopy is done with ``hb.H``.

    Returns
    -------
    ndarray, shape (hb.size,)

    Raises
    ------
    HomotopyFailed
    """
    if harmonics is not None and 0 <= harmonics < hb.H:
        coarse = hb.with_options(harmonics=int(harmonics))
        try:
            u = homotopy_start(coarse, lam0, parameter, soft_value, np.asarray(guess, float)[:coarse.size], at,
                               options)
        except HomotopyFailed:
            u = None
        if u is not None:
            padded = np.zeros(hb.size)
            padded[:u.size] = u  # harmonic-major coefficients: the higher harmonics come last
            res = solve_at_parameter(hb, padded, lam0, options or ContinuationOptions(newton_max_iter=30))
            if res.converged:
                return res.x
        return homotopy_start(hb, lam0, parameter, soft_value, guess, at, options)
    opts = options or ContinuationOptions(ds=0.01, ds_max=0.1, newton_max_iter=30)
    at = lam0 if at is None else at
    model = hb.model
    target = float(hb.p0[model.parameter_index(parameter)])
    params = hb.parameters()
    params[hb.parameter] = at
    params[parameter] = soft_value
    easy = HarmonicBalance(model, parameter, hb.options, params, hb.frequency)
    guess = np.asarray(guess, float)
    if hb.options.crossings != "none":
        # Newton's path from a rough guess wanders through states with many contact switches; the plain
        # sampled law gets there as reliably, and its solution is within O(1/N) of the resolved one
        plain = HarmonicBalance(model, parameter, dataclasses.replace(hb.options, crossings="none"), params,
                                hb.frequency)
        first = solve_at_parameter(plain, guess, soft_value, opts)
        if first.converged:
            guess = first.x
    res = solve_at_parameter(easy, guess, soft_value, opts)
    if not res.converged:
        raise HomotopyFailed(f"the soft problem ({parameter}={soft_value:g}, {hb.parameter}={at:g}) did not "
                             f"converge: {res.message}")
    lo, hi = sorted((soft_value, target))
    br = continuation(easy, res.x, soft_value, (lo, hi), opts.replace(direction=1 if target > soft_value else -1),
                      parameter_name=parameter)
    if not len(br) or br.parameter[-1] != target:
        raise HomotopyFailed(f"the homotopy in {parameter} stopped at "
                             f"{br.parameter[-1] if len(br) else soft_value:g} before {target:g}: {br.message}")
    u = br.unknowns[-1]
    if at == lam0:
        return u
    params[parameter] = target
    lo, hi = sorted((at, lam0))
    path = continuation(hb, u, at, (lo, hi), opts.replace(direction=1 if lam0 > at else -1),
                        parameter_name=hb.parameter)
    if not len(path) or path.parameter[-1] != lam0:
        raise HomotopyFailed(f"continuing the start from {hb.parameter}={at:g} to {lam0:g} stopped: {path.message}")
    return path.unknowns[-1]


def simulation_start(hb: HarmonicBalance, lam0: float, *, transient: float = 500, steps_per_period: int = 4096,
                     x0=None, v0=None, options: ContinuationOptions | None = None) -> np.ndarray:
    """A converged solution at ``lam = lam0`` started from a time simulation.

    The model is integrated (:func:`contin.timedomain.simulation.simulate`) for
    ``transient`` revolutions, then over ``nu`` more; the Fourier coefficients
    of that last stretch (period ``2 pi nu / w``) are the Newton guess. This is
    how a stable subharmonic is reached without switching at a period doubling,
    where a guess from one or two harmonics would fall back onto the harmonic
    solution.

    Raises
    ------
    HomotopyFailed
        If the motion is not ``nu``-periodic enough for Newton to converge
        (the message gives the residual of the simulated orbit).
    """
    from contin.timedomain.simulation import simulate

    params = hb.parameters()
    params[hb.parameter] = lam0
    n, nu, H = hb.n, hb.nu, hb.H
    model = integrated_model(hb)
    run = simulate(model, params, x0, v0, periods=transient, steps_per_period=steps_per_period,
                   record_every=steps_per_period)
    xs, vs = run.final_state[:n], run.final_state[n:]
    last = simulate(model, params, xs, vs, periods=nu, steps_per_period=steps_per_period, record_every=1,
                    mode0=run.final_mode)
    x = last.x[: nu * steps_per_period]
    F = np.fft.rfft(x, axis=0) / len(x)
    U = np.zeros((2 * H + 1, n))
    U[0] = F[0].real
    kmax = min(H, F.shape[0] - 1)
    U[1:2 * kmax:2] = 2 * F[1:kmax + 1].real
    U[2:2 * kmax + 1:2] = -2 * F[1:kmax + 1].imag
    u = U.reshape(-1)
    res = solve_at_parameter(hb, u, lam0, options or ContinuationOptions(newton_max_iter=30))
    if not res.converged:
        r0 = float(np.abs(hb.residual(u, lam0)).max())
        raise HomotopyFailed(f"the simulated motion at {hb.parameter}={lam0:g} after {transient:g} revolutions is not "
                             f"close to a solution of order nu={nu} (residual {r0:.2e}); Newton: {res.message}")
    return res.x


def integrated_model(hb: HarmonicBalance) -> Model:
    """The model that the time integrators take for ``hb``: ``hb.model`` with ``hb.frequency`` as its frequency.

    The integrators (:func:`contin.timedomain.simulation.simulate`) read the
    forcing frequency from the model; where the problem's frequency was
    chosen apart from the model's declared one, a copy declares it (the
    model itself is not changed).
    """
    if hb.frequency == hb.model.frequency:
        return hb.model
    return dataclasses.replace(hb.model, frequency=hb.frequency)
