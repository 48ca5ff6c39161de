"""Folds close together: two folds merging at a cusp as the forcing decreases.

Duffing ``x'' + 0.1 x' + x + x^3 = F cos(w t)`` with ``H = 1``, against the folds
of the closed-form amplitude equation (:func:`hardcases.duffing_folds`). At the
cusp ``F_c = 0.0515845...`` the two folds (vertical tangents of the response
curve) merge at ``w_c = 1.0903455...``; just above ``F_c`` they are
``~(F - F_c)^(3/2)`` apart in ``w`` (9e-8 at ``F = 1.0001 F_c``), below it there
are none.
"""

import numpy as np
import pytest
from hardcases import duffing_cusp, duffing_folds

from contin.engine.branch import BranchStatus, SpecialKind
from contin.model.catalog import build_model
from contin.engine.continuation import connection_report, continuation
from contin.hb.problem import HarmonicBalance, HBOptions

pytestmark = pytest.mark.hard
C = 0.1


def trace(F):
    hb = HarmonicBalance(build_model("duffing", {"F": F, "c": C}), "w", HBOptions(harmonics=1))
    br = continuation(hb, hb.linear_solution(0.5), 0.5, (0.5, 3.0), parameter_name="w")
    return hb, br


def test_cusp_closed_form():
    wc, Fc, rho = duffing_cusp(C)
    # on the cusp the cubic in rho = A^2 has a triple root: G = G' = G'' = 0
    a = 1 - wc**2
    G1 = 27 / 16 * rho**2 + 3 * a * rho + a * a + (C * wc) ** 2
    G2 = 27 / 8 * rho + 3 * a
    assert abs(G1) < 1e-14 and abs(G2) < 1e-14
    assert duffing_folds(Fc * (1 + 1e-6), C) and not duffing_folds(Fc * (1 - 1e-6), C)


@pytest.mark.parametrize("rel", [1e-1, 1e-2, 1e-3, 1e-4])
def test_both_folds_found_above_the_cusp(rel):
    F = duffing_cusp(C)[1] * (1 + rel)
    want = duffing_folds(F, C)
    assert len(want) == 2
    hb, br = trace(F)
    assert br.status == BranchStatus.RANGE_END
    got = sorted(sp.parameter for sp in br.special_points if sp.kind == SpecialKind.FOLD)
    assert len(got) == 2, f"folds {got}, expected {want}"
    # located to 1e-9 in w, far below their separation (9e-8 at rel = 1e-4)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-9)
    assert not [sp for sp in br.special_points if sp.kind == SpecialKind.BP]
    assert connection_report(hb, br)["ok"]


@pytest.mark.parametrize("rel", [-1e-4, -1e-2])
def test_no_fold_below_the_cusp(rel):
    F = duffing_cusp(C)[1] * (1 + rel)
    assert duffing_folds(F, C) == []
    _, br = trace(F)
    assert br.status == BranchStatus.RANGE_END
    assert not [sp for sp in br.special_points if sp.kind in (SpecialKind.FOLD, SpecialKind.BP)]
    # a single-valued response curve: w increases monotonically along the branch
    assert np.all(np.diff(br.parameter) > 0)
