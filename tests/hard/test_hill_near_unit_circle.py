"""Hill's selection near -1 and +1 against the monodromy, and the automatic fallback.

The reference multipliers come from :func:`contin.stability.monodromy_reference`
(scipy's DOP853 on the variational equations at rtol 1e-11), an integration
independent of Hill's eigenproblem; the undamped Mathieu edges come from
scipy.special.mathieu_a/b.
"""

import json
import warnings

import numpy as np
import pytest
import yaml
from scipy.optimize import brentq
from scipy.special import mathieu_a, mathieu_b

from contin import ContinWarning
from contin.engine.branch import SpecialKind
from contin.model.catalog import build_model
from contin.app.cli import main
from contin.engine.continuation import continuation
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.stability import StabilityMethod, StabilityOptions, floquet_multipliers
from contin.stability.multiplier_pairing import multiplier_distance
from contin.bifurcation.diagram import follow

pytestmark = pytest.mark.hard
HILL = StabilityOptions(method="hill")
REF = StabilityOptions(method="floquet", integrator="dop853")


def mathieu(eps, c, H):
    m = build_model("mathieu", {"delta": 1.0, "eps": eps, "g": 0.0, "c": c},
                    effects=("parametric",) + (("damping",) if c else ()))
    return HarmonicBalance(m, "w", HBOptions(harmonics=H))


def test_damped_mathieu_multiplier_approaching_minus_one():
    hb = mathieu(0.3, 0.02, 8)
    u = np.zeros(hb.size)

    def excess(w):  # max |mu| - 1 from the reference monodromy alone
        return float(np.abs(floquet_multipliers(hb, u, w, REF).multipliers).max()) - 1.0

    w_pd = brentq(excess, 1.6, 1.95, xtol=1e-12)
    dist = []
    for dw in (1e-1, 1e-2, 1e-3, 1e-4):
        w = w_pd - dw
        hill = floquet_multipliers(hb, u, w, HILL)
        ref = floquet_multipliers(hb, u, w, REF)
        assert multiplier_distance(hill.multipliers, ref.multipliers) < 1e-8
        assert hill.stable and hill.n_minus == 0
        dist.append(float(np.abs(hill.multipliers + 1).min()))
    # past the collision of the pair the multiplier approaches -1 like the square root of the distance
    assert dist == sorted(dist, reverse=True) and dist[-1] < 0.02 * dist[0]
    # just past the boundary Hill finds the multiplier beyond -1, as the monodromy does
    past = floquet_multipliers(hb, u, w_pd + 1e-4, HILL)
    assert past.n_minus == 1 and past.critical("-1") is not None


def test_undamped_mathieu_double_multiplier_minus_one_on_scipy_edges():
    eps, hb = 0.3, mathieu(0.3, 0.0, 10)
    u = np.zeros(hb.size)
    for fun in (mathieu_a, mathieu_b):
        # x'' + (1 + eps cos w t) x = 0 with tau = w t / 2: a = 4/w^2, q = 2 eps / w^2, multiplier -1 on a_1, b_1
        w = brentq(lambda w: 4 / w**2 - fun(1, 2 * eps / w**2), 1.6, 2.4, xtol=1e-14)
        hill = floquet_multipliers(hb, u, w, HILL)
        ref = floquet_multipliers(hb, u, w, REF)
        # a double multiplier: an error e of either method moves it by ~sqrt(e)
        assert np.abs(hill.multipliers + 1).max() < 1e-5
        assert multiplier_distance(hill.multipliers, ref.multipliers) < 1e-4


def test_forced_duffing_multiplier_plus_one_at_the_folds():
    hb = HarmonicBalance(build_model("duffing", {"F": 0.5, "c": 0.1}), "w", HBOptions(harmonics=9))
    br = continuation(hb, hb.linear_solution(0.5), 0.5, (0.5, 3.0), parameter_name="w")
    folds = [sp for sp in br.special_points if sp.kind == SpecialKind.FOLD]
    assert len(folds) == 2
    for sp in folds:
        hill = floquet_multipliers(hb, sp.unknowns, sp.parameter, HILL)
        ref = floquet_multipliers(hb, sp.unknowns, sp.parameter, REF)
        assert np.abs(hill.multipliers - 1).min() < 1e-6
        # the monodromy integrates the exact variational equation along the H = 9 orbit, which is
        # not an exact orbit: at the HB fold its multiplier is off +1 by the truncation, 4e-6
        assert multiplier_distance(hill.multipliers, ref.multipliers) < 1e-5


def test_inaccurate_hill_near_minus_one_falls_back_to_the_monodromy():
    """One harmonic is too few for eps = 0.3: Hill's multipliers, 0.2 from -1, are off by
    8e-3 while the counts agree; checked within 0.3 of -1 with ``agreement = 1e-3``, the
    monodromy's are used."""
    hb = mathieu(0.3, 0.02, 1)
    u = np.zeros(hb.size)
    opts = StabilityOptions(method="both", agreement=1e-3, unit_check=0.3)
    res = floquet_multipliers(hb, u, 1.8, opts)
    ref = floquet_multipliers(hb, u, 1.8, REF)
    assert res.fallback and res.method is StabilityMethod.FLOQUET and res.gap > 1e-3
    assert multiplier_distance(res.multipliers, ref.multipliers) < 1e-6
    # the same point with enough harmonics: no fallback, Hill kept
    hb8 = mathieu(0.3, 0.02, 8)
    ok = floquet_multipliers(hb8, np.zeros(hb8.size), 1.8, opts)
    assert not ok.fallback and ok.method is StabilityMethod.HILL and ok.gap < 1e-8


@pytest.mark.filterwarnings("ignore:Hill.s multipliers disagreed with the monodromy.s on the stability")
def test_fallback_is_reported_in_the_branch_message_a_warning_and_summary(tmp_path):
    hb = mathieu(0.3, 0.02, 1)
    with pytest.warns(ContinWarning, match=r"disagreed with the monodromy's near \+-1 .* at \d+ of the branch's "
                                           r"\d+ points"):
        diagram = follow(hb, np.zeros(hb.size), 1.6, (1.6, 1.85), {"ds": 0.05},
                         stability={"method": "both", "agreement": 1e-3, "unit_check": 0.3}, switch=(), max_depth=0,
                         parameter_name="w")
    br = diagram.branches[0]
    assert "stability: Hill's multipliers disagreed with the monodromy's" in br.message
    assert br.info["stability"]["fallbacks"]
    scene = {
        "model": {"builtin": "mathieu", "parameters": {"delta": 1.0, "eps": 0.3, "c": 0.02, "g": 0.0, "w": 1.6},
                  "effects": ["parametric", "damping"]},
        "analysis": {"type": "frequency_response", "parameter": "w", "range": [1.6, 1.85], "harmonics": 1,
                     "stability": "both", "stability_options": {"agreement": 1e-3, "unit_check": 0.3}, "continuation": {"ds": 0.05}},
        "output": {"measure": "max_multiplier"},
    }
    path = tmp_path / "mathieu_h1.yaml"
    path.write_text(yaml.safe_dump(scene))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ContinWarning)
        assert main(["run", str(path), "-o", str(tmp_path / "out"), "-q"]) == 0
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    (b,) = summary["analysis"]["branches"]
    st = b["stability"]
    assert st["fallbacks"] > 0 and st["hill_monodromy_gap"] > 1e-3
    assert "monodromy's multipliers were used" in st["message"] and 1.6 <= st["first_fallback_at"] <= 1.85
    assert "stability: Hill's multipliers disagreed" in b["message"]
