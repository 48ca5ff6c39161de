"""How a torus branch's end is told (locking, collapse, other failures) and its settings checked."""

from types import SimpleNamespace

import numpy as np
import pytest

from contin.bifurcation.torus_branch import TorusSettings, classify_end
from contin.engine.branch import BranchStatus, SpecialKind


class FakeTorus:
    """What classify_end asks of a torus problem: one dof, the pinned line at coefficient 1."""

    n = 1
    pin = (1, 0)

    def base_frequency(self, p):
        return float(p)

    def params_at(self, lam):
        return lam


class FakeBranch(SimpleNamespace):
    def __len__(self):
        return len(self.parameter)


def branch(lams, w2, amp, status=BranchStatus.STEP_TOO_SMALL):
    U = [np.array([0.0, a, 0.0, v]) for a, v in zip(amp, w2)]
    return FakeBranch(unknowns=U, parameter=np.array(lams), status=status, message="step size fell",
                           special_points=[], arclength=np.arange(len(lams), dtype=float), parameter_name="w", info={})


def test_a_branch_stopping_at_ratio_one_half_locks():
    br = branch([1.9, 2.0, 2.1], [1.07, 1.05, 1.0512], [0.1, 0.15, 0.16])  # ratio 0.5006 at the end
    classify_end(br, FakeTorus(), TorusSettings())
    assert br.status is BranchStatus.BOUNDARY and "end" not in br.info
    sp = br.special_points[-1]
    assert sp.kind is SpecialKind.LOCKING and sp.data["rational"] == "1/2" and sp.parameter == 2.1
    assert br.message.startswith("the torus locks: w2/(w/nu) = 0.500571 approaches 1/2 at w=2.1")
    assert br.message.endswith("the engine stopped there: step size fell")
    classify_end(br, FakeTorus(), TorusSettings())  # a resumed branch: told again, not doubled
    assert len(br.special_points) == 1


def test_a_branch_shrinking_to_nothing_ends_at_a_neimark_sacker_point():
    br = branch([1.0, 1.1, 1.2], [0.73, 0.74, 0.75], [0.2, 0.05, 1e-4])
    classify_end(br, FakeTorus(), TorusSettings())
    assert br.status is BranchStatus.BOUNDARY and br.special_points[-1].kind is SpecialKind.NS
    assert "shrinks onto the periodic branch" in br.message
    assert br.info["end"] == "collapse"  # the torus's end as asked: not a shortfall


def test_other_ends_keep_the_engines_status():
    br = branch([1.0, 1.1], [0.66, 0.68], [0.2, 0.2])  # ratio 0.618: no p/q with q <= 4 within 0.02
    classify_end(br, FakeTorus(), TorusSettings())
    assert br.status is BranchStatus.STEP_TOO_SMALL and not br.special_points
    done = branch([1.0, 1.1], [0.5, 0.55], [0.2, 0.2], status=BranchStatus.RANGE_END)  # ratio 1/2 at a range end
    classify_end(done, FakeTorus(), TorusSettings())
    assert done.status is BranchStatus.RANGE_END and not done.special_points


@pytest.mark.parametrize("kw,pattern", [
    ({"stability": "hill"}, "stability must be 'simulation' or 'none'"),
    ({"periods": 0}, "periods must be > 0"),
    ({"steps_per_period": 2}, "steps_per_period must be an integer >= 4"),
    ({"locking_tol": 0.3}, r"locking_tol must be in \(0, 0.25\)"),
])
def test_settings_are_checked(kw, pattern):
    with pytest.raises(ValueError, match=pattern):
        TorusSettings(**kw)
