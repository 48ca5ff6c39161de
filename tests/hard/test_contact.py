"""Stiff contact and grazing: the one-sided clearance oscillator
``x'' + 0.05 x' + x + kc (x - 0.5)_+ = 0.03 cos(w t)``.

Below ``w ~ 0.98`` the response stays inside the clearance (linear); beyond,
it hits the stop. The branch is traced through the contact onset (a corner
of the HB branch: the Jacobian jumps when the orbit grazes the stop) for
``kc`` = 1e3 ... 1e6, and compared with an independent event-located
integration (:func:`hardcases.clearance_orbit`).

How the discretisation must grow with the stiffness (measured on this
oscillator at ``w = 1``, in contact): the displacement converges like an
impact oscillator's, the stop acting as a rigid one (the velocity all but
jumps): with ``kc = 1e3`` the error of the extremes is 9.6e-4, 3.2e-4 and
8.8e-5 for ``H = 10, 20, 40`` (``N = 25.6 H``), about ``H^-1.7``. The
penetration shrinks like ``v / sqrt(kc)`` (8.6e-4, 1.9e-4, 3.7e-5, 1.8e-5 of
the clearance for ``kc = 1e3 ... 1e6``) and the contact lasts
``pi / sqrt(kc)`` of a time unit, so resolving the contact itself (its force
history) needs ``N`` of order ``2 sqrt(kc)`` samples per period and ``H`` of
the same order; the displacement does not: ``H = 20``, ``N = 512`` trace the
onset for every ``kc`` here.
"""

import math

import numpy as np
import pytest
from hardcases import clearance_orbit, clearance_oscillator, hb_state

from contin.engine.branch import BranchStatus, SpecialKind
from contin.engine.continuation import connection_report, continuation
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.hb.measures import point_measures

pytestmark = pytest.mark.hard
G = 0.5


def trace(kc, H, N, w_end=1.0, **opts):
    hb = HarmonicBalance(clearance_oscillator(kc), "w", HBOptions(harmonics=H, samples=N))
    br = continuation(hb, hb.linear_solution(0.5), 0.5, (0.5, w_end), dict(max_points=2000, **opts), parameter_name="w")
    return hb, br


_TRACES = {}


def traced(kc):
    """``trace(kc, 20, 512)`` to w = 1, computed once for the onset and the grazing tests (they only read it)."""
    if kc not in _TRACES:
        _TRACES[kc] = trace(kc, 20, 512)
    return _TRACES[kc]


def extremes(u, samples=20000):
    pm = point_measures(u, 1, ["x"], 1, samples=samples)
    return pm["max_x"], pm["min_x"]


def test_displacement_converges_with_h_against_event_located_integration():
    kc, w = 1e3, 1.0
    errs = []
    for H, N in ((10, 256), (20, 512), (40, 1024)):
        hb, br = trace(kc, H, N, w_end=w)
        assert br.status == BranchStatus.RANGE_END
        u = br.unknowns[-1]
        _, xmax, xmin, defect = clearance_orbit(w, kc, z0=hb_state(u, w, H))
        assert defect < 1e-9
        hi, lo = extremes(u)
        errs.append(max(abs(hi - xmax), abs(lo - xmin)))
    assert errs[0] > errs[1] > errs[2]
    assert errs[-1] < 1e-4 and errs[0] / errs[-1] > 5


# 1e4 and 1e5 are slow: 1e3 and 1e6, the two ends of the stiffness range, stand in for them by default
@pytest.mark.parametrize("kc", [1e3, pytest.param(1e4, marks=pytest.mark.slow),
                                pytest.param(1e5, marks=pytest.mark.slow), 1e6])
def test_stiff_contact_traced_through_onset(kc):
    H = 20
    hb, br = traced(kc)
    assert br.status == BranchStatus.RANGE_END, br.message
    assert np.all(np.isfinite(br.unknowns))
    mx = np.array([extremes(u, 4096)[0] for u in br.unknowns])
    inside = mx < G
    assert inside[0] and not inside[-1]
    # the onset is a corner of the branch, recorded where the orbit grazes the stop
    kinks = [sp for sp in br.special_points if sp.kind == SpecialKind.KINK]
    assert kinks
    onset = br.parameter[np.flatnonzero(~inside)[0]]
    assert min(abs(sp.parameter - onset) for sp in kinks) < 0.02
    assert connection_report(hb, br, midpoint=False)["ok"]
    # in contact the stop acts as a rigid one: the penetration is bounded by the energy balance
    # (1/2) kc pen^2 <= (1/2) v^2 at the impact, v <= the orbit's largest speed
    u, w = br.unknowns[-1], br.parameter[-1]
    k = np.arange(1, H + 1)
    theta = np.outer(np.linspace(0, 2 * np.pi, 4096, endpoint=False), k)
    v = w * (-np.sin(theta) * k * u[1::2] + np.cos(theta) * k * u[2::2]).sum(axis=1)  # u = [a0, a1, b1, ...]
    pen = mx[-1] - G
    assert 0 < pen <= 1.2 * np.abs(v).max() / math.sqrt(kc)


@pytest.mark.parametrize("kc", [20.0, 1e3, 1e4, 1e6])
def test_grazing_does_not_stall_the_branch_or_collapse_the_step(kc):
    """The response grazes the stop at w ~ 0.98, inside the range; the step stays far above ds_min.

    Against ds_min = 1e-8, measured smallest steps: 0.02, 0.014, 6.6e-4, 4.3e-6 for
    kc = 20, 1e3, 1e4, 1e6 (the correctors give up after three updates without progress,
    so at the stiffest corner the step shrinks more before it passes, in fewer updates).
    """
    hb, br = traced(kc)
    assert br.status == BranchStatus.RANGE_END, br.message
    steps = br.step_sizes[1:-1]  # the last one lands on the range end
    steps = steps[steps > 0]  # a step across a corner at fixed w has no pseudo-arclength
    assert steps.min() > 1e2 * br.info["options"]["ds_min"]
    assert br.info["n_rejected_steps"] <= 60
    # the stiff stops make the grazing a corner of the branch; the soft one (kc = 20) need not
    assert kc < 100 or any(sp.kind == SpecialKind.KINK for sp in br.special_points)
    assert connection_report(hb, br, midpoint=False)["ok"]


def peak_folds(kcs):
    """The fold of the impacting resonance (the jump down), traced to w = 1.3, for each stiffness."""
    folds = []
    for kc in kcs:
        hb, br = trace(kc, 20, 512, w_end=1.3)
        assert br.status == BranchStatus.RANGE_END, br.message
        f = [sp.parameter for sp in br.special_points if sp.kind == SpecialKind.FOLD]
        assert len(f) == 1, f
        folds.append(f[0])
        assert connection_report(hb, br, midpoint=False)["ok"]
    return np.array(folds)


@pytest.mark.slow  # the stiff stop is traced through onset at 1e3 and 1e6 by default
def test_peak_fold_moves_up_ever_less_as_the_stop_stiffens():
    """The convergence below (to the rigid-stop limit) at the softer stops kc = 1e2, 1e3, 1e4, at a third of
    its cost: measured folds 1.12086, 1.14286, 1.14872 (steps 0.022, 0.0059)."""
    folds = peak_folds((1e2, 1e3, 1e4))
    steps = np.diff(folds)
    assert np.all(steps > 0) and steps[0] > steps[1]


@pytest.mark.slow  # by default: the stiff stop traced through onset at 1e3 and 1e6 (no fold there)
def test_peak_fold_converges_as_the_stop_stiffens():
    """Through the impacting resonance to w = 1.3: one fold (the jump down) whose location
    converges as kc grows to the rigid-stop limit (measured 1.1429, 1.1487, ..., 1.1503)."""
    folds = peak_folds((1e3, 1e4, 1e5, 1e6))
    steps = np.abs(np.diff(folds))
    assert np.all(np.diff(folds) > 0) and steps[0] > steps[1] > steps[2] and steps[-1] < 1e-3
