"""Bearing rotor (seed 001): the paper's four cases, from result files and independent time integration.

Each scene runs over a narrowed speed range (2.05..2.3, or 2.12..2.3 for
f0 = 0.2, which hold the harmonic branch's period doublings and the whole
1/2-subharmonic branch) to keep the suite short; the scenes span 1.6..2.6.
"""

from pathlib import Path

import numpy as np
import pytest

from contin.model.catalog import build_model
from contin.output.checkpoint import read_records
from contin.output.expansion import StoredExpansion
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.app.cli import main
from contin.models.bearing_rotor import stable_subharmonic_interval
from contin.timedomain.poincare import steady_state
from contin.output.results import read_csv

ROOT = Path(__file__).resolve().parents[2]
NARROW = ["--set", "analysis.range=[2.05, 2.3]", "--set", "analysis.start=2.05"]
HB_ONLY = ["--set", "analysis.method=hb"]


def _run(tmp_path_factory, scene, narrow=NARROW, outdir=False, code=0):
    out = tmp_path_factory.mktemp(scene)
    assert main(["run", str(ROOT / f"scenes/{scene}.yaml"), "-o", str(out), "-q", *narrow]) == code
    res = read_csv(out / "branches.csv"), read_csv(out / "special_points.csv")
    return (*res, out) if outdir else res


@pytest.fixture(scope="module")
def f05(tmp_path_factory):
    # harmonic balance alone (its subharmonic stops where the bearing starts to bounce: incomplete, exit 1)
    return _run(tmp_path_factory, "rotor_f0_05", NARROW + HB_ONLY, code=1)


@pytest.fixture(scope="module")
def f02(tmp_path_factory):
    # from w = 2.12: at 2.05 a time simulation from rest does not settle on the harmonic orbit
    return _run(tmp_path_factory, "rotor_f0_02", ["--set", "analysis.range=[2.12, 2.3]", "--set", "analysis.start=2.12",
                                                  *HB_ONLY], code=1)


def _harmonic(rows, sp):
    m = rows["nu"] == 1
    return rows["w"][m], rows["stable"][m], sp["w"][(sp["kind"] == "pd") & (sp["branch"] == rows["branch"][m][0])]


def test_f0_05_stable_forward_half_order_whirl_between_period_doublings(f05):
    rows, sp = f05
    lo, hi = stable_subharmonic_interval(rows, sp)
    nu2 = (rows["nu"] == 2) & rows["stable"] & (rows["whirl_fwd_half_disc"] > 1e-3)
    assert hi - lo > 0.04  # a finite speed interval of entrainment
    assert rows["whirl_fwd_half_disc"][nu2].min() > 0.3  # with a finite +w/2 forward whirl
    # the stable part ends at a fold (the jump) on the high-speed side
    nu2_branches = np.isin(sp["branch"], rows["branch"][rows["nu"] == 2])
    folds = sp["w"][(sp["kind"] == "fold") & nu2_branches]
    assert np.min(np.abs(folds - hi)) < 1e-9 and np.all((2.18 < folds) & (folds < 2.21))
    # and starts at a Neimark-Sacker point on the low-speed side (2.1498), stable from there up (the
    # unstable part beyond the fold comes back only to about 2.1856)
    ns = sp["w"][(sp["kind"] == "ns") & nu2_branches]
    w_ns = ns[(ns > 2.145) & (ns < 2.16)].max()
    above = (rows["nu"] == 2) & (rows["w"] > w_ns + 1e-6) & (rows["w"] < 2.185) & (rows["whirl_fwd_half_disc"] > 0.3)
    assert above.sum() > 10 and rows["stable"][above].all()
    # bounded by period-doubling points of the harmonic branch, which is unstable in between
    w1, st1, pd = _harmonic(rows, sp)
    assert pd.size >= 2 and pd.min() <= lo and hi <= pd.max()
    inside = (w1 > lo) & (w1 < hi)
    assert inside.any() and not st1[inside].any()
    # the harmonic solution has no w/2 component: the paper's zero-amplitude solution
    assert np.all(rows["whirl_fwd_half_disc"][rows["nu"] == 1] == 0)


def test_f0_02_stable_interval_is_narrower(f05, f02):
    lo5, hi5 = stable_subharmonic_interval(*f05)
    lo2, hi2 = stable_subharmonic_interval(*f02)
    assert lo5 < lo2 < hi2 < hi5


def test_f0_02_harmonic_solution_is_stable_at_both_ends(f02):
    """The paper's Fig. 6: the zero-amplitude solution is unstable only between two period
    doublings (D-F) and stable beside them (A-D, F-G)."""
    w1, st1, pd = _harmonic(*f02)
    assert pd.size == 2 and 2.17 < pd.min() < pd.max() < 2.2
    assert st1[w1 < pd.min()].all() and st1[w1 > pd.max()].all()
    assert not st1[(w1 > pd.min()) & (w1 < pd.max())].any()


@pytest.mark.parametrize("w,entrained", [(2.16, True), (2.18, True), (2.21, False)])
def test_time_integration_confirms_entrainment(f05, w, entrained):
    rows, _ = f05
    model = build_model("bearing_rotor", {"f0": 0.5})
    rng = np.random.default_rng(1)
    # 800 revolutions: entrained at 2.16 and 2.18, |+w/2| within 8e-5 and 2.6e-4 of the branch's (4e-9 and
    # 8e-4 after 1500: at 2.18 the interpolation between the branch's points dominates)
    _, res = steady_state(model, {"w": w}, x0=1e-3 * rng.normal(size=4), v0=np.zeros(4), transient=800, record=40)
    assert (res.label == "period-2") == entrained, res.note
    if entrained:
        m = (rows["nu"] == 2) & rows["stable"]
        order = np.argsort(rows["w"][m])
        hb = np.interp(w, rows["w"][m][order], rows["whirl_fwd_half_disc"][m][order])
        assert abs(abs(res.whirl["+w/2"]) - hb) < 2e-3


@pytest.mark.parametrize("scene", ["rotor_f0_0", pytest.param("rotor_c2_5", marks=pytest.mark.slow)])
def test_no_period_doubling_and_no_subharmonic(tmp_path_factory, scene):
    """f0 = 0 and c2 = 5.0: the harmonic solution is stable, no pd, no nu = 2 branch.

    Time integration started on the harmonic orbit at w = 2.17 stays on it
    (period-1). (From rest, the f0 = 0 rotor at 2.17 settles instead on a
    motion with a +w/2 whirl that coexists with the stable harmonic orbit.)
    """
    # steps of 0.04 of the narrowed range: about 0.01 in w, as the scenes' 0.01 of their whole range
    rows, sp, out = _run(tmp_path_factory, scene, NARROW + ["--set", "analysis.continuation={ds: 0.04, ds_max: 0.04}"],
                         outdir=True)
    assert np.all(rows["nu"] == 1) and rows["stable"].all()
    assert not np.isin(sp["kind"], ["pd", "ns"]).any()
    params = {"f0": 0.0} if scene == "rotor_f0_0" else {"f0": 0.5, "c2": 5.0}
    model = build_model("bearing_rotor", params)
    records = read_records(out / "state.jsonl")
    point = min((r for r in records if r.get("type") == "point"), key=lambda r: abs(r["lam"] - 2.17))
    header = next(r for r in records if r["type"] == "branch" and r["branch"] == point["branch"])
    hb = HarmonicBalance(model, "w", HBOptions(harmonics=point["H"], samples=1024))
    u = StoredExpansion(hb)(header, point["u"], point["lam"])  # the kept dofs' coefficients, expanded
    x, xd, _ = hb.samples_of(u, point["lam"])
    _, res = steady_state(model, {"w": point["lam"]}, x0=x[0], v0=xd[0], transient=300, record=20)
    assert res.label == "period-1", res.note
