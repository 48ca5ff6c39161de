"""Homotopy starts for stiff problems (the clearance-bearing rotor)."""

import numpy as np
import pytest

from contin.hb import aft
from contin.model.catalog import build_model
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.engine.newton import solve_at_parameter
from contin.bifurcation.start import HomotopyFailed, homotopy_start


def rotor_problem(H=20, N=512):
    return HarmonicBalance(build_model("bearing_rotor", {"w": 2.0}), "w", HBOptions(harmonics=H, samples=N))


def contact_guess(hb):
    u = np.zeros(hb.size)
    u[:4] = [0.0, 0.5, 0.0, 0.2]  # disc and bearing pushed along the static force f0 (+y)
    return u


def test_plain_newton_fails_where_the_homotopy_succeeds():
    hb = rotor_problem()
    direct = solve_at_parameter(hb, hb.linear_solution(2.0), 2.0)
    assert not direct.converged  # stiff contact and a singular out-of-contact stiffness
    u = homotopy_start(hb, 2.0, "kbn", 20.0, contact_guess(hb))
    assert np.abs(hb.residual(u, 2.0)).max() < 1e-9
    x, _ = aft.synthesize(u.reshape(-1, 4).copy(), 512)
    r2 = np.hypot(x[:, 2], x[:, 3])
    assert r2.max() > 0.1  # the bearing presses on its casing
    # the disc whirls with the unbalance: amplitude close to the static-contact estimate
    assert 0.6 < np.ptp(x[:, 0]) / 2 < 0.9


def test_homotopy_elsewhere_then_continued_to_the_start():
    hb = rotor_problem()
    u = homotopy_start(hb, 1.9, "kbn", 20.0, contact_guess(hb), at=2.0)
    assert np.abs(hb.residual(u, 1.9)).max() < 1e-9


def test_failure_names_the_stage():
    hb = rotor_problem()
    with pytest.raises(HomotopyFailed, match=r"soft problem \(kbn=20, w=2\) did not converge"):
        homotopy_start(hb, 2.0, "kbn", 20.0, np.full(hb.size, 1e3))
