"""A torus' rows from its invariant circle (contin.timedomain.circle_measures) against long simulations.

The bearing rotor at f0 = 0.5 whirls quasi-periodically where its harmonic
solution is unstable and no subharmonic is stable (the paper's Fig. 3, the
simulations of docs/tutorials/rotor.md): its self-excited forward whirl
beside the forced whirl at w. At three such speeds the circle is fitted to a
simulation's sections (contin.timedomain.circle_fit), solved by Newton, and its
second frequency and the disc's forced, free and combination lines in x are
compared with the spectral lines of 3000 further revolutions of the same
simulation (contin.timedomain.spectral_lines), to 1e-3 relative. The circle has
corners where the bearing's contact arcs open along it, so it needs many
points: 61 at w = 1.9 and 2.3, 121 at w = 1.94 (61 points are 1.7e-3 off there).
"""

import numpy as np
import pytest

from contin.engine.newton import solve_at_parameter
from contin.model.catalog import build_model
from contin.timedomain.circle_fit import fit_circle
from contin.timedomain.circle_measures import circle_measures, strongest_winding
from contin.timedomain.invariant_circle import CircleOptions, InvariantCircleProblem
from contin.timedomain.simulation import simulate
from contin.timedomain.spectral_lines import spectral_lines


@pytest.mark.slow
@pytest.mark.parametrize("w, points", [(1.9, 61), (1.94, 121), (2.3, 61)])
def test_the_rotors_self_excited_whirl_from_its_circle_matches_a_long_simulations_lines(w, points):
    model = build_model("bearing_rotor", {"f0": 0.5})
    n = model.n_dof
    run = simulate(model, {"w": w}, np.array([0.5, 0.0, 0.0, 0.0]), np.zeros(n), periods=2000 + 20 * points,
                   steps_per_period=4096, record_every=4096, record_from=2000)
    fit = fit_circle(run.section[-20 * points:], points)
    problem = InvariantCircleProblem(model, "w", options=CircleOptions(points=points, steps_per_period=4096))
    problem.set_anchor(fit.points)
    got = solve_at_parameter(problem, problem.unknowns(fit.points, fit.rho), w)
    assert got.converged, got.message
    problem.winding = strongest_winding(problem, got.x, w)
    rows = circle_measures(problem, got.x, w, model.dof_names, 2)

    z = run.final_state
    long = simulate(model, {"w": w}, z[:n], z[n:], periods=3000, steps_per_period=4096, record_every=64)
    lines = spectral_lines(long.t, long.x[:, 0], count=8, floor=1e-3)
    w2 = rows["frequency2"]
    assert 0.3 * w < w2 < 0.7 * w  # the self-excited whirl near w/2, not a mirror of it
    for name, f in (("forced", w), ("free", w2), ("comb", w - w2)):
        line = min(lines, key=lambda ln: abs(ln.frequency - f))
        assert line.frequency == pytest.approx(f, rel=1e-4), name
        assert rows[f"{name}_x1"] == pytest.approx(line.amplitude, rel=1e-3), name
