"""Quasi-periodic branches of the forced van der Pol oscillator against averaging and time simulation.

x'' - mu (1 - x^2) x' + x = F cos(w t), mu = 0.1, F = 0.15 (scenes/van_der_pol.yaml): the 1:1 entrained
response loses stability at a Neimark-Sacker point on each side of w = 1; the torus branches start there.
References: :mod:`vdp_reference` (first-order averaging, written independently of contin) and an
independent scipy integration analysed by contin's spectral-line estimator.
"""

import math

import numpy as np
import pytest

from contin.bifurcation.diagram import follow
from contin.bifurcation.torus_branch import TorusSettings
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.hb.torus import TorusOptions
from contin.timedomain.spectral_lines import spectral_lines
from contin.timedomain.torus_check import check_torus
from van_der_pol_model import F, MU, vdp_model
from vdp_reference import locking_boundaries, simulated_lines, slow_limit_cycle



@pytest.fixture(scope="module")
def diagram():
    hb = HarmonicBalance(vdp_model(), "w", HBOptions(5))
    settings = TorusSettings(TorusOptions(12, 12), stability="none")
    return follow(hb, hb.linear_solution(0.9), 0.9, (0.9, 0.97), {"ds": 0.02}, stability={"method": "hill"},
                  switch=("ns",), torus=settings)


def _point(d, w):
    br, qp = d.branches[1], d.problems[1]
    i = int(np.argmin(np.abs(br.parameter - w)))
    return qp, br.unknowns[i], float(br.parameter[i])


def test_neimark_sacker_point_is_the_averaged_hopf_boundary(diagram):
    ns = [sp for sp in diagram.branches[0].special_points if sp.kind.value == "ns"]
    ref = locking_boundaries(MU, F)
    assert ref.low_kind.name.lower() == "hopf" and len(ns) == 1
    # first-order averaging: the error is O(mu^2) in the frequency
    assert abs(ns[0].parameter - ref.low) < 0.1 * MU ** 2


def test_torus_branch_starts_at_the_ns_point_and_covers_the_range(diagram):
    br = diagram.branches[1]
    assert br.info["origin"]["kind"] == "ns"
    assert br.status.value == "range_end" and br.parameter.min() == pytest.approx(0.9)
    qp = diagram.problems[1]
    for u, lam in zip(br.unknowns, br.parameter):
        assert np.abs(qp.residual(u, lam)).max() < 1e-8


@pytest.mark.parametrize("w", [0.93, 0.9])
def test_torus_against_first_order_averaging(diagram, w):
    qp, u, lam = _point(diagram, w)
    cyc = slow_limit_cycle(MU, F, lam)
    amp = qp.amplitudes(u)[:, 0]
    free = cyc.line(cyc.free_order)
    # second frequency and the forced and self-excited lines, to the order of the averaging: O(mu) in the
    # amplitudes; the frequency to O(mu^2) plus the averaged detuning's own (w - 1)^2 / (2 w) (vdp_reference)
    assert u[-1] == pytest.approx(cyc.free_frequency, abs=MU ** 2 + (lam - 1) ** 2 / (2 * lam))
    assert amp[qp.basis.pair(1, 0)[0]] == pytest.approx(math.hypot(cyc.mean_a, cyc.mean_b), rel=MU)
    assert amp[qp.basis.pair(0, 1)[0]] == pytest.approx(free.amplitude, rel=MU)


def test_torus_against_time_simulation(diagram):
    qp, u, lam = _point(diagram, 0.93)
    x0, v0 = qp.state_at(u, lam, np.zeros(1))
    # started on the torus: a record of 300 periods resolves lines 0.06 apart by 20 bins
    t, x = simulated_lines(MU, F, lam, periods=300, samples_per_period=12, initial=(x0[0, 0], v0[0, 0]))
    lines = spectral_lines(t, x, count=6, floor=1e-4)
    w2 = min(lines, key=lambda ln: abs(ln.frequency - u[-1])).frequency
    assert w2 == pytest.approx(u[-1], rel=1e-8)  # measured 1e-11 at H1 = H2 = 12
    amp = qp.amplitudes(u)[:, 0]
    for k1, k2 in ((1, 0), (0, 1), (-1, 2)):
        f = k1 * lam + k2 * u[-1]
        line = min(lines, key=lambda ln: abs(ln.frequency - abs(f)))
        assert line.amplitude == pytest.approx(amp[qp.basis.pair(k1, k2)[0]], rel=1e-6), (k1, k2)


def test_torus_is_stable_by_simulation_where_the_periodic_solution_is_not(diagram):
    qp, u, lam = _point(diagram, 0.93)
    v = check_torus(qp, u, lam, periods=150, steps_per_period=128)
    assert v.stable is True and v.multiplier == pytest.approx(1.0, abs=0.02)
    per = diagram.branches[0]
    i = int(np.argmin(np.abs(per.parameter - lam)))
    assert not per.point_data["stable"][i]
