"""Time simulation of a model: compiled fixed-step RK4 with located contact switching.

The equations of motion of a :class:`contin.model.base.Model`,

    M x'' + C x' + K x + f_nl(x, x', tau) = f_ext(tau),    tau = w t,

are integrated as the first-order system ``y = (x, x')``,
``y' = (x', M^-1 (f_ext - C x' - K x - f_nl))``, by the classical Runge-Kutta
scheme with the fixed step ``h = T / steps_per_period``, ``T = 2 pi / w`` (the
rotor paper integrates its eq. 11 this way with 4096 steps per revolution).
Because ``steps_per_period`` is an integer, the step grid meets the phases
``tau = 2 pi m`` exactly: the state at every ``steps_per_period``-th step is a
point of the Poincare section, and the excitation is evaluated at phases
``2 pi (k mod S + theta) / S`` that repeat exactly every period.

The right-hand side, the switching functions and the RK4 loop are generated
for each model structure and compiled together
(:mod:`contin.timedomain.integrator`), from the *compiled forms* that the
elements give (:class:`contin.model.elements.registry.CompiledForm`); with
``locate_events`` a contact switching is located inside its step, which
keeps the scheme's fourth order (see there).

Non-finite states stop the run with :class:`SimulationError` naming the time
and the parameter values. A fixed step too large for a stiff contact is
refused before the run: RK4 is stable for ``h |lambda| <= 2.8`` only, and in
an unstable contact mode the event location would otherwise chop the steps
and return a wrong answer instead of blowing up (:meth:`CompiledModel.fastest_rate`).
"""

from __future__ import annotations

import dataclasses
import math
import time
from typing import Callable, Mapping

import numpy as np

from contin.model.base import Model
from contin.model.elements.registry import CompiledForm
from contin.timedomain.integrator import RK4_STABILITY, CompiledModel, SimulationError, compile_model

__all__ = [
    "SimulationError",
    "SimulationResult",
    "CompiledForm",
    "CompiledModel",
    "compile_model",
    "simulate",
    "RK4_STABILITY",
]


# ---------------------------------------------------------------- results and driver
@dataclasses.dataclass(eq=False)
class SimulationResult:
    """A simulated time history.

    Attributes
    ----------
    t : ndarray, shape (K,)
        Recorded times (``t = k h`` on the step grid).
    x, v : ndarray, shape (K, n)
        Displacements and velocities at ``t``.
    section : ndarray, shape (P + 1, 2n)
        State ``(x, x')`` at ``t = m T``, ``m = 0..P`` (the Poincare section
        ``tau = 0 mod 2 pi``) over the whole run, transient included.
    w : float
        Forcing frequency (the model's frequency parameter).
    period : float
        ``T = 2 pi / w``.
    steps_per_period : int
    h : float
        Step ``T / steps_per_period``.
    steps : int
        Steps taken.
    events : int
        Switching events located.
    unresolved_events : int
        Sign changes taken without location (only with ``locate_events``:
        more than ``max_events_per_step`` in one step, or a start already
        past a surface).
    extra_evaluations : int
        RK4 trial steps spent locating events.
    wall_time : float
        Seconds spent integrating (compilation excluded).
    compile_time : float
        Seconds spent loading or compiling the generated module.
    params : dict
        Parameter values used.
    dof_names : tuple of str
    final_state : ndarray, shape (2n,)
    final_mode : ndarray, shape (n_switch,)
    notes : list of str
    """

    t: np.ndarray
    x: np.ndarray
    v: np.ndarray
    section: np.ndarray
    w: float
    period: float
    steps_per_period: int
    h: float
    steps: int
    events: int
    unresolved_events: int
    extra_evaluations: int
    wall_time: float
    compile_time: float
    params: dict
    dof_names: tuple
    final_state: np.ndarray
    final_mode: np.ndarray
    locate_events: bool = True
    notes: list = dataclasses.field(default_factory=list)

    @property
    def periods(self) -> float:
        """Revolutions (forcing periods) simulated."""
        return self.steps / self.steps_per_period

    @property
    def cost_per_period_us(self) -> float:
        """Wall time per forcing period in microseconds."""
        return 1e6 * self.wall_time / max(self.periods, 1e-300)

    @property
    def state(self) -> np.ndarray:
        """Recorded states ``(x, x')``, shape (K, 2n)."""
        return np.concatenate([self.x, self.v], axis=1)


def _param_text(model: Model, p: np.ndarray) -> str:
    return ", ".join(f"{k}={v:.6g}" for k, v in zip(model.param_names, p))


def simulate(model: Model, params: Mapping[str, float] | None = None, x0=None, v0=None, *, t_end: float | None = None,
             periods: float | None = None, steps_per_period: int = 4096, record_every: int | None = None,
             record_from: float = 0.0, locate_events: bool = True, max_events_per_step: int = 8,
             progress: Callable[[float, float], None] | None = None, should_stop: Callable[[], bool] | None = None,
             mode0=None, check_step: bool = True) -> SimulationResult:
    """Integrate a model in time with fixed-step RK4 (event-located contact switching).

    Parameters
    ----------
    model : Model
    params : dict, optional
        Parameter overrides by name (the model's values otherwise).
    x0, v0 : array_like, shape (n,), optional
        Initial displacements and velocities (default zeros), at ``t = 0``
        (``tau = 0``).
    t_end : float, optional
        End time; rounded up to the step grid.
    periods : float, optional
        Or the number of forcing periods ``T = 2 pi / w`` (one of the two).
    steps_per_period : int
        ``S``; the step is ``h = T / S`` (the rotor paper: 4096).
    record_every : int, optional
        Record every this many steps (default ``max(1, S // 128)``).
    record_from : float
        Start recording after this many periods (the transient is not stored).
    locate_events : bool
        Locate contact switching in time (4th order) or step across it (1st order).
    max_events_per_step : int
        Events located within one step before the rest of the step is taken as is.
    progress : callable, optional
        ``progress(done_periods, total_periods)``, called between chunks.
    should_stop : callable, optional
        Polled between chunks; when true the run ends early (the result holds
        what was integrated).
    mode0 : array_like of int, optional
        Initial contact mode (default: from the signs of the switching functions).
    check_step : bool
        Refuse a step beyond RK4's stability limit for the linear part with
        the contacts closed (``h |lambda|max > 2.8``, :meth:`CompiledModel.fastest_rate`).

    Returns
    -------
    SimulationResult

    Raises
    ------
    SimulationError
        Non-finite state (with the time, step and parameter values), a step
        too large for the contact stiffness, or a model that cannot be
        simulated (singular mass matrix, element without compiled form).
    ValueError
        Bad arguments (non-positive frequency, both or neither of ``t_end`` and
        ``periods``, shapes).
    """
    model.check_variable(None, params)
    cm = compile_model(model)
    n = model.n_dof
    p = model.parameter_vector(params)
    kw = model.parameter_index(model.frequency)
    w = float(p[kw])
    if not (math.isfinite(w) and w > 0):
        raise ValueError(f"simulate: the forcing frequency {model.frequency} must be positive, got {w}")
    S = int(steps_per_period)
    if S != steps_per_period or S < 4:
        raise ValueError(f"simulate: steps_per_period must be an integer >= 4, got {steps_per_period!r}")
    T = 2.0 * math.pi / w
    h = T / S
    if (t_end is None) == (periods is None):
        raise ValueError("simulate: give exactly one of t_end and periods")
    if periods is not None:
        if not (periods > 0 and math.isfinite(periods)):
            raise ValueError(f"simulate: periods must be positive, got {periods}")
        nsteps = int(math.ceil(periods * S - 1e-9))
    else:
        if not (t_end > 0 and math.isfinite(t_end)):
            raise ValueError(f"simulate: t_end must be positive, got {t_end}")
        nsteps = int(math.ceil(t_end / h - 1e-9))
    rec_every = max(1, S // 128) if record_every is None else int(record_every)
    if rec_every < 1:
        raise ValueError(f"simulate: record_every must be >= 1, got {record_every}")
    rec_start = int(math.ceil(record_from * S - 1e-9))
    if not 0 <= rec_start <= nsteps:
        raise ValueError(f"simulate: record_from ({record_from} periods) must lie within the run "
                         f"({nsteps / S:g} periods)")
    y = np.zeros(2 * n)
    for arr, sl, name in ((x0, slice(0, n), "x0"), (v0, slice(n, 2 * n), "v0")):
        if arr is not None:
            a = np.asarray(arr, dtype=float).reshape(-1)
            if a.shape != (n,):
                raise ValueError(f"simulate: {name} must have {n} entries (dofs {list(model.dof_names)}), got {a.size}")
            y[sl] = a
    if not np.all(np.isfinite(y)):
        raise ValueError("simulate: the initial state is not finite")
    Minv, C, K, cst = cm.arguments(p)
    rate = cm.fastest_rate(p)
    if check_step and rate * h > RK4_STABILITY:
        need = int(math.ceil(rate * T / RK4_STABILITY))
        raise SimulationError(
            f"simulation of '{model.name}': the step h = T/{S} = {h:.3g} is too large for the stiffest mode "
            f"(|lambda| = {rate:.4g} with the contacts closed: h*|lambda| = {rate * h:.3g} > {RK4_STABILITY}, RK4 "
            f"would blow up or, with event location, chop its steps into a wrong answer); use steps_per_period >= "
            f"{need} ({_param_text(model, p)})")
    tc = time.perf_counter()
    mod = cm.module
    if mode0 is None:
        mode = cm.mode_of(y, p)
    else:
        mode = np.asarray(mode0, dtype=np.int64).reshape(-1).copy()
        if mode.shape != (cm.n_switch,):
            raise ValueError(f"simulate: mode0 must have {cm.n_switch} entries")
    if mode.size == 0:
        mode = np.zeros(1, dtype=np.int64)
    n_rec = (nsteps - rec_start) // rec_every + 1
    out_y = np.zeros((n_rec, 2 * n))
    n_sec = nsteps // S + 1
    sec_y = np.zeros((n_sec, 2 * n))
    sec_y[0] = y
    if rec_start == 0:
        out_y[0] = y
    stats = np.zeros(5, dtype=np.int64)
    # compile (or load from the cache) outside the timed region: a zero-step call
    mod.integrate(y.copy(), mode.copy(), 0, 0, S, h, p, Minv, C, K, cst, bool(locate_events), int(max_events_per_step),
                  rec_start, rec_every, out_y[:0], sec_y[:0], stats.copy())
    compile_time = time.perf_counter() - tc
    chunk = max(S, min(1 << 18, 64 * S))
    t0 = time.perf_counter()
    k = 0
    while k < nsteps:
        k1 = min(nsteps, k + chunk)
        status = mod.integrate(y, mode, k, k1, S, h, p, Minv, C, K, cst, bool(locate_events),
                               int(max_events_per_step), rec_start, rec_every, out_y, sec_y, stats)
        if status != 0:
            kf = int(stats[2])
            raise SimulationError(
                f"simulation of '{model.name}' blew up: non-finite state at t = {kf * h:.6g} (step {kf}, "
                f"{kf / S:.2f} periods) with {_param_text(model, p)}; the step h = T/{S} = {h:.3g} may be too "
                f"large for the stiffest force (RK4 needs h*omega_max < 2.8: raise steps_per_period)"
            )
        k = k1
        if progress is not None:
            progress(k / S, nsteps / S)
        if should_stop is not None and k < nsteps and should_stop():
            break
    wall = time.perf_counter() - t0
    done = k
    n_done = 0 if done < rec_start else (done - rec_start) // rec_every + 1
    out_y = out_y[:n_done]
    sec_y = sec_y[: done // S + 1]
    t = (rec_start + rec_every * np.arange(n_done)) * h
    return SimulationResult(
        t=t, x=out_y[:, :n].copy(), v=out_y[:, n:].copy(), section=sec_y, w=w, period=T, steps_per_period=S, h=h,
        steps=done, events=int(stats[0]), unresolved_events=int(stats[1]), extra_evaluations=int(stats[4]),
        wall_time=wall, compile_time=compile_time, params=dict(zip(model.param_names, map(float, p))),
        dof_names=tuple(model.dof_names), final_state=y.copy(), final_mode=mode[: cm.n_switch].copy(),
        locate_events=bool(locate_events), notes=list(cm.notes),
    )
