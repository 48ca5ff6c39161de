"""Hard case 1 on the bearing rotor: the contact stiffness kbn from 1e3 to 1e6.

The harmonic orbit at f0 = 0.5, w = 2.0 (the bearing pressed on its casing,
in contact over the whole period) is followed in kbn from the paper's 12881
down to 1e3 and up to 1e6 by continuation, at H = 40 and 80, and each end is
checked against an independent time integration started on it (compiled RK4,
contact switches located). The contact is up to 1e6 times stiffer than the
shaft; the bearing's contact mode, sqrt(kbn/beta), moves from 230 to 7300
times the speed. Measured one-period errors (`python -m pytest -m hard
tests/hard/test_rotor_stiffness.py -s`):

======  =========  =========  =========  =========
H       kbn = 1e3  1e4        1e5        1e6
======  =========  =========  =========  =========
10      2.5e-2     3.7e-2     3.4e-2     3.3e-2
20      5.9e-3     1.6e-3     6.4e-3     5.5e-3
40      9.4e-9     8.9e-8     1.9e-7     4.2e-7
80      5.7e-12    5.6e-11    5.5e-10    5.2e-9
======  =========  =========  =========  =========

So the convergence in H stays spectral, but its constant grows about tenfold
per decade of kbn at H = 80 (the stiffer bearing follows the casing with a
sharper radial acceleration): for the same accuracy, H must grow by about ten
harmonics per decade of kbn beyond H = 40, and the samples only have to
resolve H (the law is smooth while in contact; N = 1024 here). Below H = 40
the truncated series dips out of the clearance and the error is set by that,
not by kbn.
"""

import numpy as np
import pytest

from contin.engine.branch import BranchStatus
from contin.model.catalog import build_model
from contin.engine.continuation import ContinuationOptions, continuation
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.engine.newton import solve_at_parameter
from contin.timedomain.simulation import simulate
from contin.stability import orbit_state

pytestmark = pytest.mark.hard

W = 2.0
KBN = (1e3, 1e4, 1e5, 1e6)


def _resize(u, H):
    U = u.reshape(-1, 4)
    V = np.zeros((2 * H + 1, 4))
    k = min(len(U), len(V))
    V[:k] = U[:k]
    return V.reshape(-1)


def _one_period_error(kbn, H, u):
    model = build_model("bearing_rotor", {"f0": 0.5, "w": W, "kbn": kbn})
    hb = HarmonicBalance(model, "w", HBOptions(harmonics=H, samples=1024))
    x, _, _ = hb.samples_of(u, W)
    assert np.hypot(x[:, 2], x[:, 3]).min() > model.parameters["delta"]  # in contact over the whole period
    z0 = orbit_state(hb, u, W, 0.0)
    run = simulate(model, {"w": W}, z0[:4], z0[4:], periods=1, steps_per_period=16384, record_every=64)
    return float(np.abs(run.x - orbit_state(hb, u, W, run.t)[:, :4]).max())


@pytest.fixture(scope="module")
def errors():
    model = build_model("bearing_rotor", {"f0": 0.5, "w": W})
    k0 = model.parameters["kbn"]
    u40 = model.start(HarmonicBalance(model, "w", HBOptions(harmonics=40, samples=1024)), W)
    out = {}
    for H in (40, 80):
        hb = HarmonicBalance(model, "kbn", HBOptions(harmonics=H, samples=1024))
        res = solve_at_parameter(hb, _resize(u40, H), k0, ContinuationOptions(newton_tol=1e-9, newton_max_iter=30))
        assert res.converged
        for kbn in KBN:
            opts = ContinuationOptions(ds=0.02, ds_max=0.5, newton_tol=1e-9, direction=1 if kbn > k0 else -1)
            br = continuation(hb, res.x, k0, tuple(sorted((k0, kbn))), opts, parameter_name="kbn")
            assert br.status is BranchStatus.RANGE_END and br.parameter[-1] == kbn, br.message
            assert np.all(np.isfinite(br.unknowns))
            out[H, kbn] = _one_period_error(kbn, H, br.unknowns[-1])
    print("one-period error of the HB orbit against RK4:", {k: f"{v:.1e}" for k, v in out.items()})
    return out


def test_stiff_contact_orbits_agree_with_simulation_from_1e3_to_1e6(errors):
    assert max(errors[40, k] for k in KBN) < 1e-6  # measured 9.4e-9 .. 4.2e-7
    assert max(errors[80, k] for k in KBN) < 1e-8  # measured 5.7e-12 .. 5.2e-9
    for k in KBN:
        assert errors[80, k] < 0.05 * errors[40, k]  # still spectral in H (measured 6e-4 at 1e3, 1.2e-2 at 1e6)


def test_the_error_at_fixed_harmonics_grows_with_the_stiffness(errors):
    """What the stiffness costs: at H = 80 the error grows with kbn, by about tenfold per decade."""
    e80 = [errors[80, k] for k in KBN]
    assert all(b > a for a, b in zip(e80, e80[1:]))
    assert e80[-1] > 100 * e80[0]  # measured 900x over three decades
