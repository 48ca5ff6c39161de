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

A homotopy in the harmonics (:func:`harmonic_start`) helps where many
harmonics are asked for: Newton from the linear solution with H = 25 can
wander off where with H = 5 it converges, and the low-H solution padded with
zeros is close to the high-H one (the higher harmonics are small).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from contin.engine.continuation import ContinuationOptions, continuation
from contin.hb.condensation import condense
from contin.hb.factory import harmonic_balance
from contin.hb.problem import HarmonicBalance
from contin.engine.newton import solve_at_parameter
from contin.model.base import Model
from contin.timedomain.simulation import RK4_STABILITY, SimulationError, compile_model, simulate

__all__ = ["HomotopyFailed", "homotopy_start", "harmonic_start", "contact_start", "contact_parameters",
           "simulation_start", "integrated_model", "START_LOW_HARMONICS"]

#: the harmonics :func:`harmonic_start` solves with first
START_LOW_HARMONICS = 5


class HomotopyFailed(RuntimeError):
    """No start could be found; the message says which stage failed and why."""


def homotopy_start(hb: HarmonicBalance, lam0: float, parameter: str, soft_value: float, guess: np.ndarray,
                   at: float | None = None, options: ContinuationOptions | None = None,
                   harmonics: int | None = None, condensed: bool = False) -> np.ndarray:
    """A converged solution of ``hb`` at ``lam = lam0`` by homotopy in ``parameter``.

    Parameters
    ----------
    hb : HarmonicBalance
        The problem whose continuation parameter is ``lam``.
    lam0 : float
        Where the solution is wanted.
    parameter : str
        The homotopy parameter (e.g. a contact's stiffness); its target
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
    condensed : bool
        Follow the problems condensed onto the dofs that carry nonlinear forces
        (:func:`contin.hb.condensation.condense`; a finite-element model); ``guess``
        and the result are full coefficient vectors all the same.

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
                               options, condensed=condensed)
        except HomotopyFailed:
            u = None
        if u is not None:
            padded = np.zeros(hb.size)
            padded[:u.size] = u  # harmonic-major coefficients: the higher harmonics come last
            target_hb = condense(hb, require=True) if condensed else hb
            start = target_hb.restrict(padded) if condensed else padded
            res = solve_at_parameter(target_hb, start, lam0, options or ContinuationOptions(newton_max_iter=30))
            if res.converged:
                return target_hb.expand(res.x, lam0) if condensed else res.x
        return homotopy_start(hb, lam0, parameter, soft_value, guess, at, options, condensed=condensed)
    opts = options or ContinuationOptions(ds=0.01, ds_max=0.1, newton_max_iter=30)
    at = lam0 if at is None else at
    model = hb.model
    target = float(hb.p0[model.parameter_index(parameter)])
    params = hb.parameters()
    params[hb.parameter] = at
    params[parameter] = soft_value
    easy = harmonic_balance(model, parameter, hb.options, params, hb.frequency, condense=bool(condensed))
    guess = np.asarray(guess, float)
    if condensed:
        guess = easy.restrict(guess)
    if hb.options.crossings != "none":
        # Newton's path from a rough guess wanders through states with many contact switches; the plain
        # sampled law gets there as reliably, and its solution is within O(1/N) of the resolved one
        plain = harmonic_balance(model, parameter, dataclasses.replace(hb.options, crossings="none"), params,
                                 hb.frequency, condense=bool(condensed))
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
        return easy.expand(u, target) if condensed else u
    params[parameter] = target
    lo, hi = sorted((at, lam0))
    follow = condense(hb, require=True) if condensed else hb
    path = continuation(follow, u, at, (lo, hi), opts.replace(direction=1 if lam0 > at else -1),
                        parameter_name=hb.parameter)
    if not len(path) or path.parameter[-1] != lam0:
        raise HomotopyFailed(f"continuing the start from {hb.parameter}={at:g} to {lam0:g} stopped: {path.message}")
    return follow.expand(path.unknowns[-1], lam0) if condensed else path.unknowns[-1]


def harmonic_start(problem, lam0: float, guess: np.ndarray, options: ContinuationOptions | None = None,
                   low: int = START_LOW_HARMONICS) -> np.ndarray:
    """A converged solution at ``lam = lam0``: Newton from ``guess``, else by a homotopy in the harmonics.

    When Newton from ``guess`` does not converge and the problem has more than
    ``low`` harmonics, the problem is solved with ``low`` harmonics from the
    first coefficients of ``guess`` (from its own linear solution if that
    fails too), and the solution, padded with zeros, is the Newton guess with
    twice as many harmonics, up to ``problem.H``.

    Parameters
    ----------
    problem : HarmonicBalance or CondensedHarmonicBalance
        Anything with ``H``, ``size``, ``with_options(harmonics=...)``,
        ``linear_solution`` and ``linearize``; its coefficients harmonic-major
        (the higher harmonics last), so that padding with zeros adds harmonics.
    lam0 : float
    guess : ndarray, shape (problem.size,)
    options : ContinuationOptions, optional
        ``newton_tol`` and ``newton_max_iter`` (at least 30 iterations are allowed).
    low : int
        The harmonics of the first solve.

    Returns
    -------
    ndarray, shape (problem.size,)

    Raises
    ------
    HomotopyFailed
        Saying where Newton failed: from ``guess`` and at which step of the homotopy.
    """
    opts = options or ContinuationOptions()
    opts = opts.replace(newton_max_iter=max(int(opts.newton_max_iter), 30))
    guess = np.asarray(guess, float)
    first = solve_at_parameter(problem, guess, lam0, opts)
    if first.converged:
        return first.x
    why = f"Newton from the guess with H={problem.H}: {first.message}"
    H = int(problem.H)
    if H <= low:
        raise HomotopyFailed(why)
    ladder = [low]
    while 2 * ladder[-1] < H:
        ladder.append(2 * ladder[-1])
    ladder.append(H)
    coarse = problem.with_options(harmonics=ladder[0])
    res = solve_at_parameter(coarse, guess[:coarse.size], lam0, opts)
    if not res.converged:  # the guess's low harmonics may be what misleads Newton: the linear solution instead
        res = solve_at_parameter(coarse, coarse.linear_solution(lam0), lam0, opts)
    if not res.converged:
        raise HomotopyFailed(f"{why}; with H={ladder[0]} too: {res.message}")
    u = res.x
    for h in ladder[1:]:
        fine = problem if h == H else problem.with_options(harmonics=h)
        padded = np.zeros(fine.size)
        padded[:u.size] = u  # harmonic-major coefficients: the added harmonics come last, zero
        res = solve_at_parameter(fine, padded, lam0, opts)
        if not res.converged:
            raise HomotopyFailed(f"{why}; from the solution with H={ladder[ladder.index(h) - 1]} padded with "
                                 f"zeros to H={h}: {res.message}")
        u = res.x
    return u


def contact_start(hb: HarmonicBalance, lam0: float, *, stiffness: str | None = None, clearance: str | None = None,
                  soft=(20.0, 5.0, 80.0), direction=(0.0, 1.0), harmonics: int = 8,
                  simulation: float = 400.0) -> np.ndarray:
    """A start for a model whose one contact is what its dofs are condensed onto (a finite-element rotor).

    The guess is exact for a *linear* spring of stiffness ``soft`` pulling the
    contact dofs towards the clearance circle at ``clearance * direction``:
    with the condensed linear operator ``S`` (the Schur complement, the
    residual's Jacobian at ``u = 0`` where the contact is open) and its
    residual ``R(0)``, ``(S + soft I) u = -R(0) + soft * clearance * direction``
    on the mean. From it the soft contact is solved by Newton and its
    stiffness raised to the model's value by continuation, on the condensed
    problem (:func:`homotopy_start` with ``condensed=True``).

    Parameters
    ----------
    hb : HarmonicBalance
    lam0 : float
    stiffness, clearance : str, optional
        The model parameters that are the contact's stiffness and clearance;
        by default those its contact element declares
        (:meth:`contin.model.base.ForceElement.contact_parameters`).
    soft : float or sequence of float
        The homotopy's first stiffness; with several, each is tried in turn until one leads to a solution
        (a soft contact lets the orbit swing wide, a stiffer one starts nearer a resonance).
    direction : sequence of float
        Where the contact rests, in the dofs condensed onto: ``(x, y)`` of a radial contact (the side
        load's direction), ``(+-1,)`` for a one-directional gap.
    harmonics : int
        Harmonics of the homotopy (fewer than ``hb.H`` is cheaper).
    simulation : float
        When every homotopy fails: revolutions of a time simulation to start from
        (:func:`simulation_start`, a stable orbit only); 0 to skip.

    Raises
    ------
    HomotopyFailed
    ValueError
        When ``stiffness`` or ``clearance`` is not given and the model does
        not declare it (no contact element, several with other parameters, a
        coefficient that is not one parameter), or is not a model parameter.
    """
    stiffness, clearance = contact_parameters(hb.model, stiffness, clearance)
    failures = []
    for value in np.atleast_1d(np.asarray(soft, float)):
        try:
            return _contact_start(hb, lam0, stiffness, clearance, float(value), direction, harmonics)
        except HomotopyFailed as exc:
            failures.append(f"{stiffness}={value:g}: {exc}")
    if simulation:
        # RK4's limit for the stiffest mode with the contact closed (its step is refused beyond it)
        p = hb.params_at(lam0)
        rate = compile_model(integrated_model(hb)).fastest_rate(p)
        steps = max(1024, int(np.ceil(1.1 * rate * hb.period(p) / hb.nu / RK4_STABILITY)))
        try:
            return simulation_start(hb, lam0, transient=simulation, steps_per_period=steps)
        except (HomotopyFailed, SimulationError) as exc:
            failures.append(f"from a time simulation ({steps} steps per period): {exc}")
    raise HomotopyFailed("; ".join(failures))


def contact_parameters(model: Model, stiffness: str | None = None, clearance: str | None = None) -> tuple[str, str]:
    """The model parameters that are its contact's stiffness and clearance: those given, else the contact's own.

    Parameters
    ----------
    model : Model
    stiffness, clearance : str, optional
        Given names are checked against the model's parameters; a missing one
        is the one every contact element of the model declares
        (:meth:`contin.model.base.ForceElement.contact_parameters`).

    Returns
    -------
    (stiffness, clearance) : tuple of str

    Raises
    ------
    ValueError
        Naming ``stiffness`` or ``clearance`` and why it cannot be told.
    """
    names = list(model.param_names)
    declared = [d for d in (el.contact_parameters(names) for el in model.forces) if d is not None]
    chosen = []
    for i, (key, given) in enumerate((("stiffness", stiffness), ("clearance", clearance))):
        if given is not None:
            if given not in names:
                raise ValueError(f"contact_start: {key} must be a parameter of the model {names}, got {given!r}")
            chosen.append(given)
            continue
        found = {d[i] for d in declared}
        if not declared:
            raise ValueError(f"contact_start: {key} not given and model '{model.name}' has no contact element "
                             "to tell it")
        if len(found) != 1 or None in found:
            seen = sorted(str(f) for f in found)
            raise ValueError(f"contact_start: {key} not given and the contact elements of model '{model.name}' do "
                             f"not name one parameter for it (they give {seen}); pass {key}=")
        chosen.append(found.pop())
    return chosen[0], chosen[1]


def _contact_start(hb, lam0, stiffness, clearance, soft, direction, harmonics):
    params = hb.parameters()
    params[hb.parameter] = lam0
    params[stiffness] = soft
    H = min(hb.H, int(harmonics))
    easy = harmonic_balance(hb.model, hb.parameter, dataclasses.replace(hb.options, harmonics=H), params,
                            hb.frequency, condense=True)
    d = np.asarray(direction, float).reshape(-1)
    if easy.n != d.size:
        raise HomotopyFailed(f"contact_start: the direction {tuple(d)} is not one of the contact's dofs "
                             f"{easy.dof_names} it condenses onto")
    R0, S, _ = easy.linearize(np.zeros(easy.size), lam0)
    rhs = -R0
    rhs[:d.size] += soft * params[clearance] * d / np.linalg.norm(d)
    try:
        uc = np.linalg.solve(S + soft * np.eye(easy.size), rhs)
    except np.linalg.LinAlgError:
        raise HomotopyFailed("contact_start: the linear guess with the soft spring is singular") from None
    guess = np.zeros(hb.size)
    full = easy.expand(uc, lam0)
    guess[:full.size] = full  # harmonic-major: the higher harmonics come last
    return homotopy_start(hb, lam0, stiffness, soft, guess, harmonics=H, condensed=True)


def simulation_start(hb: HarmonicBalance, lam0: float, *, transient: float = 500, steps_per_period: int = 4096,
                     x0=None, v0=None, options: ContinuationOptions | None = None, run_up=()) -> np.ndarray:
    """A converged solution at ``lam = lam0`` started from a time simulation.

    The model is integrated (:func:`contin.timedomain.simulation.simulate`) for
    ``transient`` revolutions, then over ``nu`` more; the Fourier coefficients
    of that last stretch (period ``2 pi nu / w``) are the Newton guess. This is
    how a stable subharmonic is reached without switching at a period doubling,
    where a guess from one or two harmonics would fall back onto the harmonic
    solution.

    With ``run_up`` the model is first integrated ``transient`` revolutions
    at each of those values of ``lambda`` in turn, each started from the
    last state of the one before (a slow sweep up to ``lam0``): an attractor
    that a start from rest misses (an entrained subharmonic that coexists
    with a self-excited whirl) is reached as a speed sweep reaches it.

    Raises
    ------
    HomotopyFailed
        If the motion is not ``nu``-periodic enough for Newton to converge
        (the message gives the residual of the simulated orbit).
    """
    params = hb.parameters()
    params[hb.parameter] = lam0
    n, nu, H = hb.n, hb.nu, hb.H
    model = integrated_model(hb)
    mode = None
    for value in run_up:
        before = simulate(model, {**params, hb.parameter: float(value)}, x0, v0, periods=transient,
                          steps_per_period=steps_per_period, record_every=steps_per_period, mode0=mode)
        x0, v0, mode = before.final_state[:n], before.final_state[n:], before.final_mode
    run = simulate(model, params, x0, v0, periods=transient, steps_per_period=steps_per_period,
                   record_every=steps_per_period, mode0=mode)
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
        raise HomotopyFailed(f"the simulated motion at {hb.parameter}={lam0:g} after {transient:g} revolutions"
                             f"{' (and a run-up)' if len(run_up) else ''} is not "
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
