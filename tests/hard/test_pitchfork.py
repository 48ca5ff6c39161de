"""Branch points of a symmetric system: the pitchforks of the parametrically excited
Duffing oscillator ``x'' + (delta + eps cos(w t)) x + x^3 = 0``.

Its trivial solution ``x = 0`` exists for every ``w``; described with period
``2T`` (``nu = 2``) it loses stability across the principal tongue, whose edges
are pitchforks (the symmetry ``x -> -x``, ``t -> t + T`` maps each bifurcating
orbit onto its twin). With ``t = 2 tau / w`` the linearisation is Mathieu's
equation ``x'' + (a - 2 q cos 2 tau) x = 0``, ``a = 4 delta / w^2``,
``q = -2 eps / w^2``: the edges are ``a = b_1(|q|)`` and ``a = a_1(|q|)``
(scipy.special.mathieu_b / mathieu_a).
"""

import numpy as np
import pytest
from scipy.optimize import brentq
from scipy.special import mathieu_a, mathieu_b

from contin.engine.branch import BranchStatus, SpecialKind
from contin.model.catalog import build_model
from contin.engine.continuation import connection_report, continuation
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.bifurcation.diagram import follow

pytestmark = pytest.mark.hard
DELTA, EPS = 1.0, 0.3
RANGE = (1.5, 2.5)


def tongue_edges():
    def edge(fun):
        return lambda w: 4 * DELTA / w**2 - fun(1, 2 * EPS / w**2)

    return sorted(brentq(edge(f), 1.6, 2.4, xtol=1e-14) for f in (mathieu_a, mathieu_b))


def problem():
    m = build_model("mathieu", {"delta": DELTA, "eps": EPS, "g": 1.0, "c": 0.0}, effects=("parametric", "cubic"))
    return HarmonicBalance(m, "w", HBOptions(harmonics=5, subharmonic=2))


def test_both_pitchforks_detected_and_the_trivial_branch_kept():
    hb = problem()
    br = continuation(hb, np.zeros(hb.size), RANGE[0], RANGE, {"ds": 0.05}, parameter_name="w")
    assert br.status == BranchStatus.RANGE_END
    bps = sorted(sp.parameter for sp in br.special_points if sp.kind == SpecialKind.BP)
    np.testing.assert_allclose(bps, tongue_edges(), atol=1e-8)
    # no switching was asked for: the branch stays on x = 0 through both branch points
    assert np.abs(br.unknowns).max() == 0.0
    assert np.all(np.diff(br.parameter) > 0)
    assert connection_report(hb, br)["ok"]


def test_switching_when_asked_follows_the_bifurcating_orbit():
    hb = problem()
    diagram = follow(hb, np.zeros(hb.size), RANGE[0], RANGE, {"ds": 0.05}, stability={"method": "none"},
                     switch=("bp",), max_depth=1, parameter_name="w")
    edges = tongue_edges()
    children = diagram.branches[1:]
    assert children
    for child in children:
        origin = child.info["origin"]
        assert origin["kind"] == "bp" and min(abs(origin["parameter"] - e) for e in edges) < 1e-8
        amp = np.abs(child.unknowns).max(axis=1)
        assert amp.max() > 0.1  # a non-trivial orbit
        # hardening: the bifurcated orbits exist above the lower edge only
        assert child.parameter.min() > edges[0] - 1e-6
        assert connection_report(diagram.problems[diagram.branches.index(child)], child)["ok"]
