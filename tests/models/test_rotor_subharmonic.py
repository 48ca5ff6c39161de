"""Bearing rotor, f0 = 0.5: the 1/2-subharmonic branch against independent time integration."""

from pathlib import Path

import numpy as np
import pytest

from contin.catalog import build_model
from contin.cli import main
from contin.poincare import steady_state
from contin.results import read_csv

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def diagram(tmp_path_factory):
    out = tmp_path_factory.mktemp("rotor_nu2")
    assert main(["run", str(ROOT / "scenes/rotor_subharmonic.yaml"), "-o", str(out), "-q"]) == 0
    return read_csv(out / "branches.csv"), read_csv(out / "special_points.csv")


def test_stable_forward_half_order_whirl_over_a_speed_interval(diagram):
    rows, sp = diagram
    assert np.all(rows["nu"] == 2)
    stable = rows["stable"]
    w, r = rows["w"][stable], rows["whirl_fwd_half_disc"][stable]
    assert w.max() - w.min() > 0.04  # a finite speed interval of entrainment
    assert r.min() > 0.3  # with a finite +w/2 forward whirl
    # the stable part ends at a fold (the jump) on the high-speed side
    folds = sp["w"][sp["kind"] == "fold"]
    assert len(folds) == 1 and w.max() <= folds[0] + 1e-9 and 2.18 < folds[0] < 2.21
    # and loses stability by a Neimark-Sacker bifurcation on the low-speed side
    ns = sp["w"][sp["kind"] == "ns"]
    assert ns.size and abs(ns.max() - w.min()) < 5e-3


@pytest.mark.parametrize("w,entrained", [(2.16, True), (2.18, True), (2.21, False)])
def test_time_integration_confirms_entrainment(diagram, w, entrained):
    rows, _ = diagram
    model = build_model("bearing_rotor", {"f0": 0.5})
    rng = np.random.default_rng(1)
    _, res = steady_state(model, {"w": w}, x0=1e-3 * rng.normal(size=4), v0=np.zeros(4), transient=1500, record=40)
    assert (res.label == "period-2") == entrained, res.note
    if entrained:
        hb = np.interp(w, *zip(*sorted((a, b) for a, b, s in zip(rows["w"], rows["whirl_fwd_half_disc"],
                                                                         rows["stable"]) if s)))
        assert abs(abs(res.whirl["+w/2"]) - hb) < 2e-3
