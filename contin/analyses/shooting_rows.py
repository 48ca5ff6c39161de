"""Shooting in ``frequency_response``: the method key, the shooting problem of a start, and rows of its orbits.

A branch followed by shooting (:class:`contin.timedomain.shooting.ShootingProblem`)
holds the state ``z = (x, x')`` at ``t = 0`` (forcing phase zero) as its
unknowns. Its rows in ``branches.csv`` are those of a harmonic-balance row,
computed from the integrated orbit itself: the orbit is sampled on the RK4
step grid over its period (``nu * steps_per_period`` samples), its Fourier
coefficients up to ``H`` harmonics of ``w / nu`` (the discrete Fourier
transform of the samples) give the ``hK`` columns and the model's own
columns (a rotor's whirl radii), and the extremes (``max_``, ``min_``,
``amp_``) are those of the samples, not of a truncated series. The
coefficients are what a shooting row stores as its solution (exports, plots);
``state.jsonl`` stores the engine's unknowns (the state), from which a
resumed run goes on.
"""

from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING

import numpy as np

from contin.hb.grazing import grazing_events
from contin.model.periodic import is_shooting
from contin.scene.schema import SceneError

if TYPE_CHECKING:
    from contin.timedomain.shooting import ShootingProblem

# The time-domain modules (integrator, shooting, scipy.optimize and .interpolate) are imported where a shooting
# branch is made or sampled: a run of harmonic-balance branches alone never loads them.

__all__ = ["METHODS", "ShootingSettings", "analysis_method", "is_shooting", "order_of", "shooting_problem",
           "shooting_row", "shooting_start", "orbit_coefficients", "stored_shooting_problem"]

#: the values of ``analysis.method``
METHODS = ("hb", "shooting", "auto")


@dataclasses.dataclass(frozen=True)
class ShootingSettings:
    """``analysis.shooting``: the discretisation of a branch followed by shooting.

    Attributes
    ----------
    segments : int
        ``M``, the shooting segments of the period (1: single shooting).
    steps_per_period : int
        RK4 steps per forcing period ``2 pi / w`` (also the samples of a row's orbit per forcing period).
    """

    segments: int = 1
    steps_per_period: int = 1024

    def __post_init__(self):
        for name, lo, hi in (("segments", 1, 1024), ("steps_per_period", 16, 2 ** 20)):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not lo <= v <= hi:
                raise ValueError(f"analysis.shooting.{name}: expected an integer from {lo} to {hi}, got {v!r}")
        if self.steps_per_period % self.segments:
            raise ValueError(f"analysis.shooting.segments: expected a divisor of steps_per_period "
                             f"({self.steps_per_period}), got {self.segments}")

    @classmethod
    def from_dict(cls, d, key: str = "analysis.shooting") -> "ShootingSettings":
        """From the scene's mapping; an unknown key or a bad value raises :class:`SceneError` naming the key."""
        if d is None:
            d = {}
        if not isinstance(d, dict):
            raise SceneError(key, "a mapping with keys among segments, steps_per_period", d)
        names = [f.name for f in dataclasses.fields(cls)]
        for k in d:
            if k not in names:
                raise SceneError(f"{key}.{k}", "a key among " + ", ".join(names), k)
        try:
            return cls(**d)
        except ValueError as exc:  # "analysis.shooting.FIELD: expected WHAT, got VALUE"
            where, _, what = str(exc).partition(": expected ")
            field = where.rsplit(".", 1)[-1]
            raise SceneError(f"{key}.{field}", what.rsplit(", got ", 1)[0], d.get(field)) from None


def has_contacts(hb) -> bool:
    """Whether ``hb``'s model has contact elements (switching force laws: grazing can end a branch)."""
    return bool(grazing_events(hb))


def analysis_method(analysis: dict, hb) -> str:
    """The method a start runs with: ``hb``, ``shooting``, or ``auto`` (harmonic balance handed to shooting at a
    grazing point it cannot pass); ``auto`` is ``hb`` for a model without contact elements."""
    how = analysis.get("method", "auto")
    if how == "auto" and not has_contacts(hb):
        return "hb"
    return how


def order_of(problem) -> int:
    """``nu`` of a branch's problem: its period in forcing periods."""
    if is_shooting(problem):
        return int(problem.options.subharmonic)
    return int(problem.nu)


def shooting_problem(hb, settings: ShootingSettings, nu: int | None = None) -> ShootingProblem:
    """The shooting problem of ``hb``'s model, parameter, frequency and parameter values, of order ``nu``."""
    from contin.bifurcation.start import integrated_model  # deferred: the time domain, for shooting only
    from contin.timedomain.shooting import ShootingOptions, ShootingProblem  # deferred: as above

    kw = {"steps_per_period": int(settings.steps_per_period), "subharmonic": int(hb.nu if nu is None else nu),
          "segments": int(settings.segments)}
    base = {k: v for k, v in hb.parameters().items() if k != hb.parameter}
    return ShootingProblem(integrated_model(hb), hb.parameter, base, ShootingOptions(**kw))


def stored_shooting_problem(hb, header: dict) -> ShootingProblem:
    """A shooting branch's problem from its checkpoint record's ``header`` (:func:`shooting_problem` of its
    ``shooting`` entry: segments, steps and section, and its order ``nu``)."""
    d = header.get("shooting") or {}
    settings = ShootingSettings(int(d.get("segments", 1)), int(d.get("steps_per_period", 1024)))
    problem = shooting_problem(hb, settings, int(header.get("nu") or 1))
    k0 = int(d.get("start_step", 0))
    if not k0:
        return problem
    from contin.timedomain.shooting_section import resectioned  # deferred: the time domain, for shooting only

    return resectioned(problem, k0)


def _state(problem, u) -> np.ndarray:
    """The state at ``t = 0`` of the unknowns ``u`` (the first segment's start)."""
    return np.asarray(u, dtype=float)[:2 * problem.model.n_dof]


def _samples(problem, u, lam: float) -> np.ndarray:
    """``x`` on the step grid of one period, ``nu * steps_per_period`` samples, shape (N, n)."""
    n = problem.model.n_dof
    S, nu = problem.options.steps_per_period, problem.options.subharmonic
    if hasattr(problem, "step_states"):  # the segments integrated again: the step grid's own values
        return np.ascontiguousarray(problem.step_states(u, lam)[:, :n])
    from contin.timedomain.simulation import simulate  # deferred: the time domain, for shooting only

    z = _state(problem, u)
    run = simulate(problem.model, problem.params_at(lam), z[:n], z[n:], periods=nu, steps_per_period=S,
                   record_every=1, check_step=False)
    return np.asarray(run.x, dtype=float)[:S * nu]


def orbit_coefficients(x: np.ndarray, H: int) -> np.ndarray:
    """Fourier coefficients ``(a0, a1, b1, ..., aH, bH)`` per dof of one period's samples ``x`` (N, n), in the
    harmonic-balance layout (harmonic-major, shape (n (2H+1),)); exact for a series of at most ``N/2 - 1``
    harmonics."""
    N, n = x.shape
    X = np.fft.rfft(x, axis=0) / N
    H = min(int(H), (N - 1) // 2)
    U = np.zeros((2 * H + 1, n))
    U[0] = X[0].real
    U[1::2] = 2.0 * X[1:H + 1].real
    U[2::2] = -2.0 * X[1:H + 1].imag
    return U.reshape(-1)


def shooting_row(problem, u, lam: float, H: int, dof_names) -> tuple[np.ndarray, dict]:
    """Coefficients (``H`` harmonics) of the orbit of the shooting unknowns ``u`` and its sampled extremes.

    Returns
    -------
    coefficients : ndarray, shape (n (2H+1),)
    extremes : dict
        ``max_D``, ``min_D`` and ``amp_D = (max - min) / 2`` of each dof ``D`` over the samples.
    """
    x = _samples(problem, u, lam)
    out = {}
    for i, d in enumerate(dof_names):
        hi, lo = float(x[:, i].max()), float(x[:, i].min())
        out.update({f"amp_{d}": 0.5 * (hi - lo), f"max_{d}": hi, f"min_{d}": lo})
    return orbit_coefficients(x, H), out


def shooting_start(problem, hb, analysis: dict, lam0: float, u_hb=None) -> np.ndarray:
    """The first unknowns of a shooting branch at ``lam0``.

    ``start_from: simulation``: the state a time simulation settles on
    (``start_simulation``: its ``run_up``, then ``transient`` forcing periods, rounded up to whole orbit
    periods so that the state is at forcing phase zero); otherwise the state at ``t = 0`` of the
    harmonic-balance start ``u_hb`` (full coefficients).
    """
    from contin.stability.saltation import orbit_state  # deferred: the time domain, for shooting only
    from contin.timedomain.simulation import simulate  # deferred: as above

    n = problem.model.n_dof
    if analysis.get("start_from") == "simulation" and analysis.get("guess") is None:
        sim = dict(analysis.get("start_simulation") or {})
        S = int(sim.get("steps_per_period", problem.options.steps_per_period))
        nu = problem.options.subharmonic
        periods = nu * math.ceil(float(sim.get("transient", 500)) / nu)
        x0 = v0 = mode = None
        params = problem.params_at(lam0)
        for value in sim.get("run_up", ()):
            run = simulate(problem.model, {**params, problem.parameter: float(value)}, x0, v0, periods=periods,
                           steps_per_period=S, record_every=S, mode0=mode)
            x0, v0 = run.final_state[:n], run.final_state[n:]
        run = simulate(problem.model, params, x0, v0, periods=periods, steps_per_period=S, record_every=S)
        z = np.asarray(run.final_state, dtype=float)
    else:
        z = np.asarray(orbit_state(hb, u_hb, lam0, 0.0), dtype=float)
    return unknowns_from_state(problem, z, lam0)


def unknowns_from_state(problem, z, lam: float) -> np.ndarray:
    """The shooting unknowns of the orbit through the state ``z`` at ``t = 0`` (the segment starts)."""
    start = getattr(problem, "start_unknowns", None)  # multiple shooting: the segment starts
    return np.asarray(z, dtype=float) if start is None else np.asarray(start(z, lam), dtype=float)
