"""Branch points told from folds and corners: the rank of [Ju Jlam] at the located point."""

import math

import numpy as np
import pytest

from contin.engine.branch import BranchStatus, SpecialKind
from contin.engine.continuation import ContinuationOptions, continuation
from contin.engine.events import FunctionEvent, PointInfo
from contin.engine.location import BP_DIP, FOLD_NEAR, branch_point_artefact, kernel_singular_values


class Fold:
    """R = u^2 + lam: one fold at (u, lam) = (0, 0), no branch point ([Ju Jlam] = [2u, 1] has full rank)."""

    def residual(self, u, lam):
        return np.array([u[0] ** 2 + lam])

    def linearize(self, u, lam):
        return self.residual(u, lam), np.array([[2.0 * u[0]]]), np.array([1.0])


class Corner:
    """u - |lam - 1| (two unknowns, the second u2 = u): a corner at lam = 1, where the bordered sign flips."""

    def residual(self, u, lam):
        return np.array([u[0] - abs(lam - 1.0), u[1] - u[0]])

    def linearize(self, u, lam):
        return self.residual(u, lam), np.array([[1.0, 0.0], [-1.0, 1.0]]), np.array([-math.copysign(1.0, lam - 1.0), 0.0])


class Pitchfork:
    """R = lam u - u^3: the trivial branch meets u^2 = lam at (0, 0), a simple branch point."""

    def residual(self, u, lam):
        return np.array([lam * u[0] - u[0] ** 3])

    def linearize(self, u, lam):
        return self.residual(u, lam), np.array([[lam - 3.0 * u[0] ** 2]]), np.array([u[0]])


def _info(Ju, Jlam, lam=0.0):
    Ju = np.atleast_2d(np.asarray(Ju, float))
    return PointInfo(u=np.zeros(Ju.shape[0]), lam=lam, tangent=np.zeros(Ju.shape[0] + 1), Ju=Ju,
                     Jlam=np.asarray(Jlam, float), det_sign=1)


def test_kernel_singular_values_are_those_of_the_scaled_matrix():
    Ju, Jl = np.array([[2.0, 0.0], [0.0, 3.0]]), np.array([0.0, 4.0])
    expected = np.linalg.svd(np.array([[2.0, 0.0, 0.0], [0.0, 3.0, 8.0]]), compute_uv=False)
    np.testing.assert_allclose(kernel_singular_values(_info(Ju, Jl), 1.0, 2.0), expected, rtol=1e-14)


def test_a_branch_point_keeps_its_rank_drop_and_a_fold_does_not():
    # pitchfork lam u - u^3 at (0, 0): [Ju Jlam] = [0, 0], against [+-0.1, 0] at the step's ends
    reason, data = branch_point_artefact(_info([[0.0]], [0.0]), _info([[-0.1]], [0.0], -0.1), _info([[0.1]], [0.0], 0.1),
                                         1.0, 1.0)
    assert reason is None and data["kernel_dip"] == 0.0
    # u^2 + lam at u = 0.05, between u = 0.1 and u = 0: [2u, 1] keeps norm ~1 across
    reason, data = branch_point_artefact(_info([[0.1]], [1.0]), _info([[0.2]], [1.0]), _info([[0.0]], [1.0]), 1.0, 1.0)
    assert data["kernel_dip"] == pytest.approx(math.sqrt(1.01) / math.sqrt(1.04), rel=1e-12) and data["kernel_dip"] > BP_DIP
    assert data["fold_ratio"] == pytest.approx(0.1 / math.sqrt(1.01), rel=1e-12) and data["fold_ratio"] < FOLD_NEAR
    assert reason is not None and "full rank" in reason and "a fold beside it" in reason


def test_a_sign_flip_without_a_rank_drop_is_an_orientation_and_a_lone_crossing_is_kept():
    # u - lam: neither Ju = 1 nor [1, -1] is singular anywhere
    regular = _info([[1.0]], [-1.0])
    reason, data = branch_point_artefact(regular, regular, regular, 1.0, 1.0, bordered=True)
    assert data["kernel_dip"] == pytest.approx(1.0) and "orientation flipped" in reason
    # a multiplier crossing +1 there: the Jacobian tells nothing against it, so it stays
    assert branch_point_artefact(regular, regular, regular, 1.0, 1.0)[0] is None


def test_a_branch_point_test_turning_beside_a_fold_is_dropped_with_its_reason():
    """A +1 crossing located a little off the fold (as a truncated series' multiplier is) is no branch point."""
    ev = FunctionEvent(lambda p: float(np.sign(p.u[0] - 0.05)), name="stability +1 (bp)", kind="bp",
                       integer_valued=True)
    br = continuation(Fold(), [-0.3], -0.09, (-1.0, 0.5), ContinuationOptions(ds=0.05, ds_max=0.05, scaling="none"),
                      events=[ev])
    folds = [sp for sp in br.special_points if sp.kind is SpecialKind.FOLD]
    assert len(folds) == 1 and abs(folds[0].parameter) < 1e-8
    assert not [sp for sp in br.special_points if sp.kind is SpecialKind.BP]
    (dropped,) = br.info["dropped_points"]
    assert dropped["kind"] == "bp" and dropped["event"] == "stability +1 (bp)"
    assert dropped["parameter"] == pytest.approx(-0.05 ** 2, abs=1e-9)
    assert "a fold beside it" in dropped["reason"] and dropped["kernel_dip"] > BP_DIP


def test_the_sign_flip_after_a_corner_is_no_branch_point():
    br = continuation(Corner(), [1.0, 1.0], 0.0, (0.0, 2.0), ContinuationOptions(ds=0.05, ds_max=0.1, scaling="none"))
    assert br.status is BranchStatus.RANGE_END
    kinds = [sp.kind for sp in br.special_points]
    assert SpecialKind.KINK in kinds and SpecialKind.BP not in kinds
    assert br.info["dropped_points"] and all("orientation flipped" in d["reason"] for d in br.info["dropped_points"])


def test_a_genuine_branch_point_is_kept_with_its_kernel():
    br = continuation(Pitchfork(), [0.0], -0.5, (-0.5, 0.5), ContinuationOptions(ds=0.07, ds_max=0.07, scaling="none"))
    (bp,) = [sp for sp in br.special_points if sp.kind is SpecialKind.BP]
    assert abs(bp.parameter) < 1e-8 and bp.located
    assert bp.data["kernel_dip"] < 1e-6 and "dropped_points" not in br.info


class CostlyCubic:
    """``x^3 - x = lam``, ``z = sin x - x^2 / 5``, declared with a linearisation costing ten residuals (a lazy
    Jacobian, as shooting's); its linearisations counted."""

    jacobian_cost = 10.0

    def __init__(self):
        self.linearisations = 0

    def residual(self, u, lam):
        x, z = u
        return np.array([x**3 - x - lam, z - math.sin(x) + 0.2 * x * x])

    def linearize(self, u, lam):
        self.linearisations += 1
        x = u[0]
        return self.residual(u, lam), np.array([[3 * x * x - 1, 0.0], [-math.cos(x) + 0.4 * x, 1.0]]), np.array([-1.0, 0.0])


def _locate_z(light: bool):
    z_star = math.sin(0.5) - 0.05
    ev = FunctionEvent(lambda p: p.u[1] - z_star, name="z")
    ev.needs_linearisation = not light
    prob = CostlyCubic()
    x0 = 1.324717957244746  # x^3 - x = 1
    made = []
    br = continuation(prob, [x0, math.sin(x0) - 0.2 * x0 * x0], 1.0, (-1.0, 1.0),
                      ContinuationOptions(direction=-1, ds=0.2, ds_max=0.2), events=[ev],
                      callback=lambda b, i: made.append(prob.linearisations) or True)
    (sp,) = [p for p in br.special_points if p.event == "z"]
    return sp, int(np.diff(made)[sp.index])  # the linearisations made on the step that located it


def test_an_event_that_reads_no_linearisation_is_located_without_one():
    """z crossing its value at x = 1/2 (lam = -3/8) on the lower half of the S-curve: located to its closed form
    whether the points on the arc are linearised or not; without, in fewer linearisations (the lazy Newton
    solves evaluate the Jacobian only where their chord steps stall, and the located point's own)."""
    (light, n_light), (eager, n_eager) = _locate_z(True), _locate_z(False)
    for sp in (light, eager):
        assert sp.located and sp.parameter == pytest.approx(-0.375, abs=1e-10)
        assert sp.unknowns[0] == pytest.approx(0.5, abs=1e-9)
    assert n_light < n_eager  # measured 8 against 12
