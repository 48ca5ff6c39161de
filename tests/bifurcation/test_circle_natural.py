"""A circle branch in natural steps stored as a branch (contin.bifurcation.circle_natural): the forced van der Pol
oscillator's circle stepped down to the arclength branch's end, stopped where it collapses at the
Neimark-Sacker point, capped, and interrupted and taken up again from its checkpoint to the same circles."""

import json

import numpy as np
import pytest

from contin.bifurcation.circle_natural import follow_circle_steps
from contin.bifurcation.torus_branch import TorusContinuation, TorusSettings
from contin.engine.branch import BranchStatus, SpecialKind
from contin.engine.options import ContinuationOptions
from contin.output.checkpoint import decode, encode
from van_der_pol_model import W_NS, vdp_circle_branch

DOWN = ContinuationOptions(ds=0.005, ds_max=0.005, ds_min=1e-5, direction=-1, newton_tol=1e-10)


@pytest.fixture(scope="module")
def circle():
    """A circle of 21 points at w = 0.94 and the arclength branch from the Neimark-Sacker point down to 0.92."""
    prob, br = vdp_circle_branch(0.92)
    i = int(np.argmin(np.abs(br.parameter - 0.94)))
    return prob, prob.solve(br.unknowns[i], 0.94, tol=1e-11, max_iter=8), br


def test_steps_down_are_a_branch_that_ends_on_the_arclength_branchs_circle(circle):
    prob, u, br = circle
    seen, states = [], []
    nat = follow_circle_steps(prob, u, 0.94, (0.92, 0.96), DOWN, callback=lambda b, i: seen.append(i),
                              checkpoint=lambda b, st: states.append(st))
    assert nat.status is BranchStatus.RANGE_END and nat.message == "reached w=0.92"
    assert nat.info["continuation"] == "natural" and nat.info["lam_range"] == (0.92, 0.96)
    assert seen == list(range(len(nat))) and len(states) == len(nat) + 1 and "points" not in states[-1]
    assert nat.parameter[0] == 0.94 and nat.parameter[-1] == pytest.approx(0.92, abs=1e-14)
    assert np.all(np.diff(nat.parameter) < 0) and np.all(np.diff(nat.arclength) > 0)
    for k in range(len(nat)):
        assert np.abs(prob.residual(nat.unknowns[k], nat.parameter[k])).max() < 1e-9
        assert np.linalg.norm(nat.tangents[k]) == pytest.approx(1.0)
        assert nat.tangents[k][-1] < 0  # along the steps
    spread = np.ptp(prob.blocks(nat.unknowns[-1])[0], axis=0).max()
    assert nat.point_data["circle_spread"][-1] == pytest.approx(spread)
    np.testing.assert_allclose(nat.unknowns[-1], br.unknowns[-1], atol=1e-7)  # the engine's circle at 0.92


def test_steps_up_end_at_the_neimark_sacker_point_with_an_ns_point(circle):
    prob, u, _ = circle
    up = ContinuationOptions(ds=0.004, ds_max=0.004, ds_min=1e-5, newton_tol=1e-10)
    nat = follow_circle_steps(prob, u, 0.94, (0.92, 0.96), up)
    assert nat.status is BranchStatus.BOUNDARY and "collapses onto a periodic orbit" in nat.message
    ns = [sp for sp in nat.special_points if sp.kind is SpecialKind.NS]
    assert len(ns) == 1 and W_NS - 1e-4 < ns[0].parameter < W_NS + 1e-4
    assert W_NS - 1e-4 < nat.parameter[-1] < W_NS


def test_a_cap_on_points_and_a_start_that_is_no_circle(circle):
    prob, u, _ = circle
    capped = follow_circle_steps(prob, u, 0.94, (0.92, 0.96), DOWN.replace(max_points=3))
    assert capped.status is BranchStatus.MAX_POINTS and len(capped) == 3
    U, rho = prob.blocks(u)
    bad = prob.unknowns(np.full_like(U, 50.0), rho)  # every point at one far state
    failed = follow_circle_steps(prob, bad, 0.94, (0.92, 0.96), DOWN.replace(newton_max_iter=3), solve_start=True)
    assert failed.status is BranchStatus.START_FAILED and len(failed) == 0 and "no circle at w=0.94" in failed.message


class _Killed(Exception):
    pass


def test_an_interrupted_branch_goes_on_to_the_same_circles(circle):
    prob, u, _ = circle
    ref = follow_circle_steps(prob, u, 0.94, (0.92, 0.96), DOWN)
    held = {}

    def checkpoint(branch, state):  # killed right after the third circle's state is written
        if state.get("points") == 3:
            held.update(branch=branch, state=decode(json.loads(json.dumps(encode(state)))))  # as the file holds it
            raise _Killed

    with pytest.raises(_Killed):
        follow_circle_steps(prob, u, 0.94, (0.92, 0.96), DOWN, checkpoint=checkpoint)
    cut = held["branch"]
    cut.status, cut.info["restart"] = BranchStatus.INTERRUPTED, held["state"]
    assert len(cut) == 3 and held["state"]["natural"]["lu_u"] is not None  # the chord factorisation is rebuilt
    again = follow_circle_steps(prob, u, 0.94, (0.92, 0.96), DOWN, previous=cut)
    assert again.status is BranchStatus.RANGE_END and len(again) == len(ref)
    np.testing.assert_array_equal(again.parameter, ref.parameter)
    np.testing.assert_array_equal(again.unknowns, ref.unknowns)
    assert follow_circle_steps(prob, u, 0.94, (0.92, 0.96), DOWN, previous=ref) is ref  # finished: as it is


def test_the_settings_name_the_way_a_circle_branch_is_followed():
    assert TorusSettings().continuation is TorusContinuation.ARCLENGTH
    assert TorusSettings.from_dict({"continuation": "natural"}, 5).continuation is TorusContinuation.NATURAL
    with pytest.raises(ValueError, match=r"TorusSettings.continuation must be one of \['arclength', 'natural'\]"):
        TorusSettings(continuation="parameter")


def test_a_change_of_stability_between_two_circles_is_a_special_point(circle):
    """Where two neighbouring circles' verdicts differ (here a monitor that says so below w = 0.931), an unlocated
    ``stability`` point brackets the change."""
    prob, u, _ = circle

    def verdict(x, lam, Ju=None, Jlam=None):
        return {"evaluated": True, "stable": bool(lam > 0.931), "n_unstable": int(lam <= 0.931),
                "max_multiplier": 1.0}

    nat = follow_circle_steps(prob, u, 0.94, (0.92, 0.96), DOWN, monitors=[verdict])
    (sp,) = nat.special_points
    assert sp.kind is SpecialKind.STABILITY and not sp.located and sp.data == {"from": "stable", "to": "unstable"}
    a, b = sp.interval
    assert b < 0.931 < a and a - b <= 0.005 + 1e-12 and sp.index == int(np.flatnonzero(nat.parameter == a)[0])
    assert "a step across a fold of tori" in sp.message


def test_a_start_at_the_end_of_the_range_is_one_circle_and_a_missing_state_is_refused(circle):
    prob, u, _ = circle
    one = follow_circle_steps(prob, u, 0.94, (0.94, 0.96), DOWN)
    assert one.status is BranchStatus.RANGE_END and len(one) == 1 and one.message == "reached w=0.94"
    cut = follow_circle_steps(prob, u, 0.94, (0.92, 0.96), DOWN.replace(max_points=2))
    cut.status = BranchStatus.INTERRUPTED  # as if killed, but no state kept
    with pytest.raises(ValueError, match="a circle branch without the state of its last circle"):
        follow_circle_steps(prob, u, 0.94, (0.92, 0.96), DOWN, previous=cut)
