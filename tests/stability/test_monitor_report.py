"""Where Hill's verdict was replaced: counted in points of the branch, with the parameter ranges named."""

import warnings

import numpy as np

from contin import ContinWarning
from contin.bifurcation.diagram import follow
from contin.engine.branch import BranchBuilder
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.model.catalog import build_model
from contin.stability.monitor import describe_ranges, replaced_ranges


def flagged_branch(lam, disagreement, fallback=None):
    """A branch at the parameter values ``lam`` whose points carry the given flags."""
    b = BranchBuilder("w", 1)
    fallback = [False] * len(lam) if fallback is None else fallback
    for i, (x, d, f) in enumerate(zip(lam, disagreement, fallback)):
        b.append_point(np.array([0.0]), x, np.array([0.0, 1.0]), float(i), 1, 0.1, 0.0,
                       {"disagreement": d, "hill_fallback": f})
    return b.branch


def test_ranges_are_runs_of_flagged_points_merged_where_a_fold_overlaps_them():
    lam = [0.5, 0.6, 0.7, 0.8, 0.9, 0.85, 0.75, 0.65, 1.2]
    flags = [True, True, False, True, True, True, False, True, True]
    count, ranges = replaced_ranges(flagged_branch(lam, flags))
    assert count == 7
    # 0.5-0.6; 0.8-0.9 turning back to 0.85; then 0.65 and 1.2 (a run across a jump: one range)
    assert ranges == [(0.5, 0.6), (0.65, 1.2)]
    assert describe_ranges("w", ranges) == "w in [0.5, 0.6], [0.65, 1.2]"
    # a point flagged in both columns counts once
    both = flagged_branch([1.0, 2.0, 3.0], [True, False, False], [True, False, True])
    assert replaced_ranges(both, ("disagreement", "hill_fallback")) == (2, [(1.0, 1.0), (3.0, 3.0)])
    assert describe_ranges("w", [(1.0, 1.0), (3.0, 3.0)]) == "w=1, 3"
    assert replaced_ranges(flagged_branch([1.0], [False])) == (0, [])


def test_the_report_counts_points_of_the_branch_not_evaluations():
    # before: "disagreed with the monodromy's at N point(s)" counted every evaluation (rejected steps and the
    # location of special points too): more "points" than the branch had
    m = build_model("mathieu", {"delta": 1.0, "eps": 0.3, "g": 0.0, "c": 0.02}, effects=("parametric", "damping"))
    hb = HarmonicBalance(m, "w", HBOptions(harmonics=1))  # too few harmonics: Hill is off near -1
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        diagram = follow(hb, np.zeros(hb.size), 1.6, (1.6, 1.85), {"ds": 0.05},
                         stability={"method": "both", "agreement": 1e-3, "unit_check": 0.3}, switch=(), max_depth=0,
                         parameter_name="w")
    br, mon = diagram.branches[0], diagram.monitors[0]
    count, ranges = replaced_ranges(br, "hill_fallback")
    assert 0 < count <= len(br) and count < len(mon.fallbacks)  # the monitor also saw steps the branch lost
    ours = [str(w.message) for w in record if issubclass(w.category, ContinWarning) and "near +-1" in str(w.message)]
    lo, hi = ranges[0]
    text = (f"Hill's multipliers disagreed with the monodromy's near +-1 (beyond agreement 0.001) at {count} of "
            f"the branch's {len(br)} points (w in [{lo:.6g}, {hi:.6g}])")
    assert len(ours) == 1 and ours[0].startswith(text), ours  # one warning of the kind for the branch
    assert text in br.message
    # the other kind, told apart, is counted the same way
    n, _ = replaced_ranges(br, "disagreement")
    assert n <= len(br) and f"on the stability at {n} of the branch's {len(br)} points" in br.message
