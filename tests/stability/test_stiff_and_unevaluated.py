"""Stiff orbits and points without a stability verdict.

- The monodromy takes the RK4 steps the stiffest mode along the orbit needs
  (up to ``StabilityOptions.max_steps_per_period``), so a stiff point gets a
  verdict: checked against the adaptive DOP853 integration of the same
  variational equations (:func:`monodromy_orbit_ivp`).
- The step count it asks for holds: any count at least as large passes.
- Where no verdict can be made, the monitor keeps the point with finite
  placeholders (``evaluated`` False) and the branch goes on; the events take
  such a point as giving no information.
"""

import warnings

import numpy as np
import pytest

from contin import ContinWarning
import contin.stability.floquet as floquet_module
import contin.stability.rk4_step_limit as rk4_step_limit_module
import contin.stability.verdict as verdict_module
from contin.engine.branch import BranchStatus
from contin.engine.continuation import ContinuationOptions, continuation
from contin.model.elements import GapForce
from contin.engine.events import PointInfo
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.model.base import Monomial
from contin.models.polynomial import polynomial_model
from contin.stability import (
    FloquetResult,
    StabilityMonitor,
    StabilityOptions,
    classify_multipliers,
    floquet_multipliers,
    monodromy_orbit_ivp,
    monodromy_rk4,
    multiplier_distance,
    stability_events,
)
from contin.stability.events import MultiplierCrossingEvent, StabilityChangeEvent
from contin.bifurcation.start import simulation_start

KEYS = set(FloquetResult(np.ones(2, complex), np.zeros(2, complex), True, 0, 0, 0, 0, 1.0, "hill", 1.0).monitor_data())


@pytest.mark.parametrize("value", [4, 100.0, True])
def test_max_steps_per_period_is_validated(value):
    with pytest.raises(ValueError, match=r"StabilityOptions\.max_steps_per_period must be an integer >= 8"):
        StabilityOptions(max_steps_per_period=value)
    assert StabilityOptions(max_steps_per_period=np.int64(64)).max_steps_per_period == 64


# ---------------------------------------------------------------------------
# a Duffing oscillator with a light mass on a stiff spring
# ---------------------------------------------------------------------------


@pytest.fixture(scope="module")
def stiff_duffing():
    """x'' + 0.1 x' + x + x^3 + k (x - y) = 0.5 cos(w t), m y'' + cy y' + k (y - x) = 0, k = 100, m = 0.01.

    The attached mass adds a mode at sqrt(k (1 + 1/m)) = 100.5 rad/s along
    the whole orbit: RK4 needs about 100.5 T / 2.78 = 227 / w steps per
    period. The Duffing part keeps its folds and its unstable middle branch
    (one real multiplier beyond +1), so the verdicts are not trivial. H = 9.
    """
    # the spring as polynomial terms: a matrix entry is a product of parameters, not a sum
    spring = [{"dof": "x", "coef": "k", "x": {"x": 1}}, {"dof": "x", "coef": "-k", "x": {"y": 1}},
              {"dof": "y", "coef": "k", "x": {"y": 1}}, {"dof": "y", "coef": "-k", "x": {"x": 1}}]
    model = polynomial_model(
        ["x", "y"], {"c": 0.1, "F": 0.5, "w": 1.0, "k": 100.0, "m": 0.01, "cy": 0.1},
        mass=[[1.0, 0.0], [0.0, "m"]], damping=[["c", 0.0], [0.0, "cy"]], stiffness=[[1.0, 0.0], [0.0, 0.0]],
        nonlinear=[{"dof": "x", "coef": 1.0, "x": {"x": 3}}] + spring, forcing=[{"dof": "x", "amplitude": "F"}])
    hb = HarmonicBalance(model, "w", HBOptions(harmonics=9))
    br = continuation(hb, hb.linear_solution(1.0), 1.0, (1.0, 2.0), ContinuationOptions(max_points=300))
    s_lo, s_hi = sorted(p.s for p in br.points_of_kind("fold"))
    middle = int(np.argmin(np.abs(br.arclength - 0.5 * (s_lo + s_hi))))
    return hb, br, middle


def test_a_stiff_orbit_takes_the_steps_its_stiffest_mode_needs(stiff_duffing):
    """16 steps per period are far too few for the 100.5 rad/s mode: the monodromy refines them itself, and
    the verdict is that of the adaptive integration (one multiplier beyond +1 on the middle branch, none
    below the folds); the slow multipliers agree to 1e-5 (measured 4e-7).

    The steps taken: at least RK4's limit 227/w, at most that for the bound of the eigenvalue used (105.6,
    with the damping of the stiff mode), the 5% margin and the rounding to a fast FFT length (< 7%).
    """
    hb, br, middle = stiff_duffing
    opts = StabilityOptions(method="floquet", steps_per_period=16)
    for i, counts in ((middle, (1, 0, 0)), (0, (0, 0, 0))):
        u, w = br.point(i)
        res = floquet_multipliers(hb, u, w, opts)
        ref = monodromy_orbit_ivp(hb, u, w, rtol=1e-9, atol=1e-10)
        assert res.counts == classify_multipliers(ref.multipliers) == counts
        assert multiplier_distance(res.multipliers, ref.multipliers) < 1e-5
        mon = StabilityMonitor(hb, opts)
        data = mon(u, w)
        assert data["evaluated"] is True and set(data) == KEYS and not mon.unevaluated
        assert (data["n_plus"], data["n_minus"], data["n_complex"]) == counts
        with pytest.raises(rk4_step_limit_module.RK4StepError, match="too large for the stiffest mode"):
            monodromy_rk4(hb, u, w, 16)
        mono = monodromy_rk4(hb, u, w, 16, max_steps=opts.max_steps_per_period)
        assert 227 / w < mono.steps <= 1.07 * 1.05 * 105.6 * 2 * np.pi / 2.78 / w + 1, mono.steps


def test_beyond_the_cap_the_adaptive_integration_gives_the_verdict(stiff_duffing, monkeypatch):
    """At most 128 steps where about 160 are needed: the adaptive DOP853 integration of the same variational
    equations (at the options' rtol) makes the monodromy, within its estimated cost."""
    hb, br, middle = stiff_duffing
    calls = []

    def spy(*args, **kwargs):
        calls.append(kwargs)
        return monodromy_orbit_ivp(*args, **kwargs)

    monkeypatch.setattr(floquet_module, "monodromy_orbit_ivp", spy)
    monkeypatch.setattr(floquet_module, "IVP_FALLBACK_EVALUATIONS", 10 ** 6)
    opts = StabilityOptions(method="floquet", steps_per_period=16, max_steps_per_period=128, rtol=1e-9)
    u, w = br.point(middle)
    res = floquet_multipliers(hb, u, w, opts)
    assert calls == [{"rtol": 1e-9, "atol": pytest.approx(1e-10), "samples": 32}]
    assert res.counts == (1, 0, 0)
    big = res.multipliers[np.argmax(np.abs(res.multipliers))]
    ref = floquet_multipliers(hb, u, w, StabilityOptions(method="floquet", steps_per_period=512))
    assert abs(big - ref.multipliers[np.argmax(np.abs(ref.multipliers))]) < 1e-5


def test_a_point_without_a_verdict_is_kept_and_the_branch_goes_on(stiff_duffing, monkeypatch):
    """At most 160 steps, and no adaptive integration: the points below w = 1.05 * 105.6 * 2 pi / 2.78 / 160
    = 1.57 get no verdict (105.6: the bound of the stiff mode's eigenvalue, 100.5, with its damping). The
    monitor keeps them with finite placeholders, warns once, lists them, and the branch runs on to the end
    of its range, up over the upper fold, down the unstable middle branch (verdicts down to 1.57), past the
    lower fold where nothing is evaluated, and up the lower branch (verdicts again above 1.57). Across that
    stretch the change of n_plus is the fold's: no branch point is reported."""
    hb, br, _ = stiff_duffing
    monkeypatch.setattr(floquet_module, "IVP_FALLBACK_EVALUATIONS", 0)
    opts = StabilityOptions(method="floquet", steps_per_period=16, max_steps_per_period=160)
    u, w = br.point(0)
    with pytest.raises(ArithmeticError, match=r"beyond max_steps_per_period = 160; raise max_steps_per_period to "
                                              r">= \d+ \(the adaptive integration would take about"):
        floquet_multipliers(hb, u, w, opts)
    mon = StabilityMonitor(hb, opts)
    with pytest.warns(ContinWarning, match="no stability verdict at w=1 .*max_steps_per_period"):
        data = mon(u, w)
    assert set(data) == KEYS and data["evaluated"] is False and data["stable"] is False
    assert all(np.all(np.isfinite(np.asarray(v))) for v in data.values())
    assert (data["n_unstable"], data["n_plus"], data["n_minus"], data["n_complex"]) == (-1, -1, -1, -1)
    assert data["max_multiplier"] == 0.0 and np.array_equal(data["multipliers"], np.zeros(4))
    assert not (data["ambiguous"] or data["confirmed"] or data["disagreement"] or data["marginal_disagreement"]
                or data["hill_fallback"])
    assert mon.unevaluated == [(w, mon.unevaluated[0][1])] and "max_steps_per_period = 160" in mon.unevaluated[0][1]
    assert mon.statistics()["unevaluated"] == [[w, mon.unevaluated[0][1]]]
    # along the branch
    mon = StabilityMonitor(hb, opts)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        run = continuation(hb, u, w, (1.0, 2.0), ContinuationOptions(max_points=300), parameter_name="w",
                           monitors=[mon], events=stability_events(mon))
    assert sum("no stability verdict" in str(c.message) for c in caught) == 1
    assert run.status is BranchStatus.RANGE_END, run.message
    evaluated = run.point_data["evaluated"]
    assert not evaluated[run.parameter < 1.55].any() and evaluated[run.parameter > 1.6].all()
    assert (run.point_data["n_unstable"][~evaluated] == -1).all()
    assert (run.point_data["n_unstable"][evaluated] >= 0).all()
    changes = np.flatnonzero(np.diff(evaluated.astype(int)))
    assert len(changes) == 3 and evaluated[-1]  # no verdict, verdicts, none (lower fold), verdicts
    assert [p.kind.value for p in run.special_points] == ["start", "fold", "fold", "end"]
    stats = mon.statistics()["unevaluated"]
    assert {lam for lam, _ in stats} >= set(run.parameter[~evaluated])
    assert all(lam < 1.57 and "max_steps_per_period = 160" in why for lam, why in stats)
    # the verdicts made are those of a branch with verdicts everywhere
    for i in (int(np.flatnonzero(run.point_data["n_unstable"] == 1)[0]), len(run) - 1):
        full = floquet_multipliers(hb, *run.point(i), StabilityOptions(method="floquet", steps_per_period=512))
        assert run.point_data["n_unstable"][i] == full.n_unstable


# ---------------------------------------------------------------------------
# the advice of a refused step holds
# ---------------------------------------------------------------------------


def test_the_step_count_asked_for_holds_on_a_contact_orbit():
    """x'' + 0.1 x' + x + 1000 (x -+ 0.5)_+- = 0.3 cos(1.3 t): four switches, a 31.6 rad/s mode in contact.

    Refused at any count below it, the count asked for and every larger one
    pass the check (the steps of each segment between switches are at most
    T/S, and the bound is taken at every node), and the refinement takes
    exactly it.
    """
    model = polynomial_model(["x"], {"c": 0.1, "F": 0.3, "w": 1.0}, mass=[[1.0]], damping=[["c"]],
                             stiffness=[[1.0]], forcing=[{"dof": "x", "amplitude": "F"}])
    model.forces.append(GapForce(0, Monomial(0.5), Monomial(1000.0), sides="both"))
    hb = HarmonicBalance(model, "w", HBOptions(harmonics=40, samples=512))
    w = 1.3
    u = simulation_start(hb, w, transient=60, steps_per_period=1024)
    asked = set()
    for start in (41, 47, 53):
        with pytest.raises(rk4_step_limit_module.RK4StepError, match="use steps_per_period >= ") as info:
            monodromy_rk4(hb, u, w, start)
        asked.add(info.value.needed)
        assert rk4_step_limit_module.fast_steps(info.value.needed) == info.value.needed
        refined = monodromy_rk4(hb, u, w, start, max_steps=10 ** 4)
        assert len(refined.switches) == 4 and refined.steps >= info.value.needed
    assert len(asked) == 1  # the same orbit asks for the same count whatever the count refused
    (needed,) = asked
    for S in (needed, needed + 1, needed + 7, needed + 31, 2 * needed + 3):
        assert np.isfinite(monodromy_rk4(hb, u, w, S).matrix).all()


# ---------------------------------------------------------------------------
# the events across a point without a verdict
# ---------------------------------------------------------------------------


class _Line:
    def linearize(self, u, lam):
        return np.array([u[0] - lam]), np.array([[1.0]]), np.array([-1.0])


class _Problem:
    """What the monitor reads of a harmonic-balance problem where it has no verdict yet: one dof."""

    parameter = "lam"
    condensed = False  # the periodic-problem protocol: the problem in every dof is itself

    @property
    def full(self):
        return self

    class model:
        @staticmethod
        def linear(p):
            return np.eye(1), np.zeros((1, 1)), np.eye(1)

    @staticmethod
    def params_at(lam):
        return np.array([lam])


class _WindowMonitor(StabilityMonitor):
    """Closed-form multipliers, with no verdict for ``lo < lam < hi``."""

    def __init__(self, multipliers, lo, hi):
        super().__init__(_Problem(), StabilityOptions(method="floquet"))
        self.multipliers, self.lo, self.hi = multipliers, lo, hi

    def analyze(self, u, lam):
        if self.lo < lam < self.hi:
            raise ArithmeticError("nothing to evaluate here")
        return verdict_module.monodromy_result(self.multipliers(lam), 1.0, self.options)


def _crossing_at(lam_c):
    """One real multiplier through +1 at ``lam_c`` (the ``+1`` event, kind ``bp`` on a line), one inside."""
    return lambda lam: np.array([1.0 + 0.5 * (lam - lam_c), 0.3], dtype=complex)


def _run(mon, events):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ContinWarning)
        return continuation(_Line(), [0.0], 0.0, (0.0, 1.0), ContinuationOptions(ds=0.05, ds_max=0.05),
                            monitors=[mon], events=events)


def test_a_change_across_a_point_without_a_verdict_is_located_once():
    """Stored points at lam = k 0.05 / sqrt 2; the one at 0.495 has no verdict, the multiplier crosses at 0.52.

    The held count makes the change trigger once, between 0.495 and 0.530,
    where it is located as without the gap; the step limit ignores the point.
    """
    for events in (lambda m: stability_events(m), lambda m: [StabilityChangeEvent(m)]):
        mon = _WindowMonitor(_crossing_at(0.52), 0.48, 0.50)
        br = _run(mon, events(mon))
        assert br.status is BranchStatus.RANGE_END, br.message
        gap = np.flatnonzero(~br.point_data["evaluated"])
        assert br.parameter[gap] == pytest.approx([0.495], abs=1e-3)
        assert br.point_data["n_plus"][gap[0] - 1] == 0 and br.point_data["n_plus"][gap[0] + 1] == 1
        changes = [p for p in br.special_points if p.kind.value in ("bp", "stability")]
        assert len(changes) == 1
        (p,) = changes
        assert p.located and p.parameter == pytest.approx(0.52 + 2e-6, abs=1e-9)
        assert p.interval == pytest.approx((br.parameter[gap[0]], br.parameter[gap[0] + 1]))
        assert mon.statistics()["unevaluated"] == [[br.parameter[gap[0]], "ArithmeticError: nothing to evaluate here"]]


@pytest.mark.parametrize("lo, hi, far", [(0.465, 0.5, "0.5079529871"), (0.47259764805718, 0.47259764805719,
                                                                           "0.4725976481")])
def test_a_change_before_a_point_without_a_verdict_is_bracketed_not_located(lo, hi, far):
    """The multiplier crosses at 0.47: the step limit puts the next point just beyond, at 0.4726, which has
    no verdict; the next verdict is at 0.508. One change, unlocated, between the verdict at 0.4596 and the
    nearest solved point beyond: the location stops where it meets no verdict (a window of them), or
    bisects onto the point without one (that point alone)."""
    mon = _WindowMonitor(_crossing_at(0.47), lo, hi)
    br = _run(mon, stability_events(mon))
    assert br.status is BranchStatus.RANGE_END, br.message
    (gap,) = np.flatnonzero(~br.point_data["evaluated"])
    assert br.parameter[gap] == pytest.approx(0.4725976481)
    (p,) = [p for p in br.special_points if p.kind.value == "bp"]
    assert not p.located
    assert p.message.split(": ", 1)[1].startswith(f"the change lies between 0.4596194078 and {far}")
    assert "(no stability verdict at 0.4725976481)" in p.message


def test_no_change_into_or_out_of_a_point_without_a_verdict():
    """Stable on both sides of a run of points without a verdict: nothing is reported, and the first
    point of a branch without a verdict starts no change either."""
    for lo, hi in ((0.3, 0.6), (-1.0, 0.2)):
        mon = _WindowMonitor(lambda lam: np.array([0.5, 0.3], dtype=complex), lo, hi)
        br = _run(mon, stability_events(mon) + [StabilityChangeEvent(mon)])
        assert br.status is BranchStatus.RANGE_END and (~br.point_data["evaluated"]).sum() >= 3
        assert [p.kind.value for p in br.special_points] == ["start", "end"]


def test_step_limits_ignore_points_without_a_verdict():
    """The predicted crossing comes from evaluated points only: none when the newer point has no verdict,
    from the last evaluated point before an older one without."""
    mon = _WindowMonitor(_crossing_at(1.0), 0.4, 0.6)
    ev = MultiplierCrossingEvent(mon, "+1")
    pts = []
    for s, lam in ((0.0, 0.0), (0.3, 0.3), (0.5, 0.5), (0.7, 0.7)):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ContinWarning)
            data = mon(np.array([lam]), lam)
        pts.append(PointInfo(np.array([lam]), lam, np.ones(2), None, None, 1, data, s=s))
        ev.test(pts[-1])
        if len(pts) == 3:
            assert ev.step_limit(pts[1], pts[2], 0.2) == np.inf
    # from 0.3 to 0.7: |mu| - threshold goes from -0.35 to -0.15, zero 0.3 further
    assert ev.step_limit(pts[2], pts[3], 0.2) == pytest.approx(1.25 * (0.3 + 2e-6), rel=1e-9)
    assert verdict_module.unevaluated_data(4)["multipliers"].shape == (4,)
