"""A simulation start after a run-up reaches the orbit a slow sweep reaches (the Duffing hysteresis)."""

import numpy as np

from contin.bifurcation.start import simulation_start
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.model.catalog import build_model


def _amplitude(u, hb):
    U = u.reshape(2 * hb.H + 1, hb.n)
    return float(np.hypot(U[1, 0], U[2, 0]))


def test_run_up_lands_on_the_upper_branch_where_rest_lands_on_the_lower():
    # x'' + 0.1 x' + x + x^3 = 0.5 cos(w t): both branches are stable at w = 1.8 (folds at 1.4387 and 2.2119)
    hb = HarmonicBalance(build_model("duffing", {"F": 0.5}), "w", HBOptions(harmonics=5), {"w": 1.8})
    low = simulation_start(hb, 1.8, transient=150, steps_per_period=256)
    high = simulation_start(hb, 1.8, transient=150, steps_per_period=256, run_up=[1.2, 1.4, 1.6, 1.7])
    assert _amplitude(low, hb) < 0.5 < 1.5 < _amplitude(high, hb)
    for u in (low, high):
        assert np.abs(hb.residual(u, 1.8)).max() < 1e-9

