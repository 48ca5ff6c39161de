"""A start on a torus (``solution: torus``): the invariant circle a time simulation settles on.

The simulation runs ``start_simulation.transient`` forcing periods (after its
``run_up``), then records the state once a forcing period for
:data:`RECORD_PER_POINT` periods per point of the circle (at least
:data:`MIN_RECORD`); :func:`contin.timedomain.circle_fit.fit_circle` fits the
circle of ``torus.points`` points and its rotation number to those
sections, and the fit is the first guess (and the phase condition's
anchor) of the circle the branch starts from, corrected at the start.
"""

from __future__ import annotations

import math

import numpy as np

from contin.bifurcation.torus_branch import TorusSettings
from contin.scene.schema import SceneError, is_int, is_number

__all__ = ["MAX_MISFIT", "MIN_RECORD", "RECORD_PER_POINT", "check_torus_start", "circle_from_simulation",
           "torus_keys_ok"]

#: recorded forcing periods per point of the circle, and at least
RECORD_PER_POINT = 20
MIN_RECORD = 400
#: a fit further than this (relative RMS) from the sections is no torus to start from
MAX_MISFIT = 0.05


def torus_keys_ok(v) -> bool:
    """Whether ``v`` is a valid ``analysis.torus`` mapping (its keys and their values' types and ranges)."""
    if not isinstance(v, dict) or set(v) - {"harmonics", "harmonics2", "samples", "samples2", "stability", "periods",
                                           "steps_per_period", "locking_tol", "points", "continuation"}:
        return False
    if v.get("continuation", "arclength") not in ("arclength", "natural"):
        return False
    if v.get("points") is not None and not (is_int(v["points"]) and 3 <= v["points"] <= 999 and v["points"] % 2):
        return False
    ints = all(v.get(k) is None or (is_int(v[k]) and 1 <= v[k] <= 2**16)
               for k in ("harmonics", "harmonics2", "samples", "samples2"))
    return (ints and v.get("stability", "simulation") in ("simulation", "none")
            and (v.get("periods") is None or (is_number(v["periods"]) and v["periods"] > 0))
            and (v.get("steps_per_period") is None or (is_int(v["steps_per_period"]) and 4 <= v["steps_per_period"] <= 2**20))
            and (v.get("locking_tol") is None or (is_number(v["locking_tol"]) and 0 < v["locking_tol"] < 0.25)))


def check_torus_start(a: dict, key: str, method: str) -> None:
    """What a torus start needs, checked before anything is written: a simulation to start from and the
    integrated flow (raises :class:`SceneError` naming the key)."""
    if a.get("solution") != "torus":
        return
    if a.get("start_from") != "simulation":
        raise SceneError(f"{key}.start_from", "simulation with solution: torus (the circle is fitted to the "
                                               "sections of a time simulation)", a.get("start_from"))
    if method == "hb":
        raise SceneError(f"{key}.method", "shooting or auto with solution: torus (the torus is an invariant "
                                          "circle of the integrated flow)", "hb")
    if a.get("switch"):
        raise SceneError(f"{key}.switch", "no switch with solution: torus (no bifurcations are sought on a torus)",
                         a.get("switch"))


def circle_from_simulation(shooting, analysis: dict, lam0: float, harmonics: int):
    """The circle problem and its first unknowns at ``lam0`` from a simulation (module docstring).

    Parameters
    ----------
    shooting : ShootingProblem
        The start's shooting problem (model, parameter, other values, steps a period).
    analysis : dict
        The start's analysis keys (``start_simulation``, ``torus``).
    lam0 : float
    harmonics : int
        The periodic branch's ``H`` (for :class:`TorusSettings`).

    Returns
    -------
    problem : InvariantCircleProblem
        Anchored at the fit, its ``winding`` that of the fit's strongest line.
    u0 : ndarray, shape (problem.size,)

    Raises
    ------
    ArithmeticError
        If the sections are no circle (the fit's misfit above :data:`MAX_MISFIT`).
    """
    from contin.timedomain.circle_fit import fit_circle  # deferred: the time domain
    from contin.timedomain.circle_measures import strongest_winding  # deferred: as above
    from contin.timedomain.invariant_circle import CircleOptions, InvariantCircleProblem  # deferred: as above
    from contin.timedomain.simulation import simulate  # deferred: as above

    points = TorusSettings.from_dict(analysis.get("torus") or {}, harmonics).points
    sim = dict(analysis.get("start_simulation") or {})
    S = int(sim.get("steps_per_period", shooting.options.steps_per_period))
    transient = math.ceil(float(sim.get("transient", 500)))
    record = max(MIN_RECORD, RECORD_PER_POINT * points)
    params = shooting.params_at(lam0)
    x0 = v0 = None
    for value in sim.get("run_up", ()):
        run = simulate(shooting.model, {**params, shooting.parameter: float(value)}, x0, v0, periods=transient,
                       steps_per_period=S, record_every=S)
        x0, v0 = run.final_state[:shooting.n], run.final_state[shooting.n:]
    run = simulate(shooting.model, params, x0, v0, periods=transient + record, steps_per_period=S,
                   record_every=S, record_from=transient)
    sections = np.asarray(run.section, dtype=float)[-record:]
    fit = fit_circle(sections, points)
    if fit.misfit > MAX_MISFIT:
        raise ArithmeticError(f"the simulation's {record} sections after {transient} revolutions are no circle of "
                              f"{points} points (the fit's misfit {fit.misfit:.3g} > {MAX_MISFIT}): not settled on "
                              "a torus, not quasi-periodic, or a circle that needs more points (torus.points)")
    problem = InvariantCircleProblem(shooting.model, shooting.parameter, shooting.base,
                                     CircleOptions(points=points, steps_per_period=shooting.options.steps_per_period))
    problem.set_anchor(fit.points)
    u0 = problem.unknowns(fit.points, fit.rho)
    problem.winding = strongest_winding(problem, u0, lam0)
    return problem, u0
