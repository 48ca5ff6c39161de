"""The memory and work a scene asks, estimated at check time (contin/scene/budget.py): sizes within the schema's
limits that cannot fit are refused by check_scene, naming the key and the numbers, before any array is made."""

import math
import tracemalloc

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from conftest import fuzz_examples
from contin.scene.build import build_model
from contin.scene.parse import SceneError, parse_scene
from contin.scene.registry import analysis, check_scene

try:
    import contin.scene.budget as budget
    from contin.scene.budget import Demand, Limits, check_demands, harmonic_balance_demands, time_text
    from contin.scene.files import size_text
except ImportError:  # a tree without the estimate: the scenes below pass its check, and these tests fail
    budget = None

GiB = 2**30
TiB = 2**40


@pytest.fixture
def machine(monkeypatch):
    """A machine with 24 GiB available: the limit is 80% of it, 19.2 GiB."""
    if budget is not None:
        monkeypatch.setattr(budget, "machine_memory", lambda: (24.0 * GiB, None, "available (MemAvailable)"))
    return 0.8 * 24 * GiB


CHAIN = "model: {{builtin: linear_chain, options: {{n: {n}}}, effects: [forcing]}}\n"
DUFFING = "model: {builtin: duffing, effects: [damping, cubic, forcing]}\n"


def _check(text: str):
    scene = parse_scene(text)
    return check_scene(scene, build_model(scene))


def _refused(text: str, key: str) -> str:
    with pytest.raises(SceneError) as exc:
        _check(text)
    assert exc.value.key == key, str(exc.value)
    return " ".join(str(exc.value).split())


def test_two_hundred_dofs_with_2000_harmonics_name_the_jacobian(machine):
    msg = _refused(CHAIN.format(n=200) + "analysis: {type: frequency_response, range: [0.5, 1.5], harmonics: 2000, "
                   "stability: none}\n", "analysis.harmonics")
    m = 200 * 4001
    assert f"200 dofs x 4001 coefficients need a {m} x {m} Jacobian of {8 * m * m / TiB:.3g} TiB" in msg
    assert "4.66 TiB" in msg and "80% of the 24 GiB available (MemAvailable) is 19.2 GiB" in msg


def test_a_further_start_names_its_own_key(machine):
    _refused(CHAIN.format(n=200) + "analysis: {type: frequency_response, range: [0.5, 1.5], harmonics: 3, "
             "stability: none, starts: [{start: 1.0, harmonics: 2000}]}\n", "analysis.starts[0].harmonics")


def test_monodromy_steps_of_1e12_say_their_memory_and_time(machine):
    msg = _refused(DUFFING + "analysis: {type: frequency_response, range: [0.5, 3], harmonics: 3, stability: floquet, "
                   "stability_options: {steps_per_period: 1000000000000}}\n",
                   "analysis.stability_options.steps_per_period")
    S = 10**12  # 2S samples of two 1 x 1 Jacobians and four state columns
    assert f"{8 * 2 * S * 6 / TiB:.3g} TiB" in msg and "87.3 TiB" in msg
    assert "at least 4.11 h" in msg  # 148 operations a step at 1e10 per second


def test_hills_method_on_a_large_problem_is_refused(machine):
    msg = _refused(CHAIN.format(n=200) + "analysis: {type: frequency_response, range: [0.5, 1.5], harmonics: 30, "
                   "stability: hill}\n", "analysis.stability")
    assert "eigenvectors of a 24400 x 24400 matrix" in msg and "stability: floquet" in msg


@pytest.mark.parametrize("analysis, key, fragment", [
    # record x samples: 100000 revolutions of 2**20 samples of x and v, 6.4 TB
    ("{type: simulate, values: [1.0], steps_per_period: 1048576, samples_per_period: 1048576, record: 100000}",
     "analysis.record", "100000 recorded revolutions x 1048576 samples of 1 dof"),
    ("{type: simulate, values: [1.0], transient: 1.0e12}", "analysis.transient",
     "1000000000100 revolutions of 4096 RK4 steps of 1 dof"),
    ("{type: frequency_response, range: [0.5, 3], start_from: simulation, start_simulation: {transient: 1.0e12}}",
     "analysis.start_simulation.transient", "the start from a simulation: 1000000000000 revolutions"),
    ("{type: frequency_response, range: [0.5, 3], switch: [ns], torus: {harmonics: 400, harmonics2: 400}}",
     "analysis.torus", "tori of 1 dof with harmonics (400, 400) have 641602 unknowns"),
])
def test_time_domain_and_torus_sizes_are_refused(machine, analysis, key, fragment):
    msg = _refused(DUFFING + f"analysis: {analysis}\n", key)
    assert fragment in msg


def test_an_frf_of_a_million_points_is_refused(machine):
    msg = _refused(CHAIN.format(n=60) + "analysis: {type: frf, range: [0, 2], points: 1000000, force: x1}\n",
                   "analysis.points")
    assert "1000000 frequencies of 60 dofs" in msg and f"{1e6 * (32 * 3600 + 6200) / GiB:.3g} GiB" in msg


def test_the_modes_of_many_values_are_refused(machine):
    msg = _refused(CHAIN.format(n=200) + "analysis: {type: modes, parameter: k1, range: [1, 2], points: 100000}\n",
                   "analysis.points")
    assert "the modes of 200 dofs at 100000 values" in msg


def test_a_scene_within_the_limit_passes_and_its_estimate_bounds_the_problem_it_builds(machine):
    text = ("model: {builtin: timing_belt, parameters: {terms: 20, p_d: 2}, effects: [rotor_mass, stretching, magnet, "
            "periodic_load, damping]}\nanalysis: {type: frequency_response, parameter: w, range: [0.5, 8.0], "
            "harmonics: 30, stability: none}\n")
    scene = parse_scene(text)
    model = build_model(scene)
    groups = budget.check_resources(scene, analysis(scene.analysis["type"]).demands(scene, model))
    estimate = sum(d.nbytes for d in groups[0])
    from contin.analyses.frequency_response import build_problem

    tracemalloc.start()
    try:
        hb = build_problem(scene, model)
        hb.linearize(np.zeros(hb.size), 1.0)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert hb.size == 20 * 61 and peak < estimate


def test_the_arrays_held_together_are_summed():
    a = Demand("analysis.harmonics", "a Jacobian", 6e9)
    b = Demand("analysis.stability", "Hill's matrices", 5e9)
    check_demands([[a], [b]], Limits(10e9))  # one after the other: each fits
    with pytest.raises(SceneError, match=r"together 10.2 GiB: a Jacobian: 5.59 GiB; Hill's matrices: 4.66 GiB") as exc:
        check_demands([[a, b]], Limits(10e9, "10 GB for the test"))
    assert exc.value.key == "analysis.harmonics" and "10 GB for the test" in str(exc.value)


def test_work_beyond_a_day_is_refused_even_when_it_fits():
    d = Demand("analysis.transient", "a long simulation", 1.0, operations=1e16)
    with pytest.raises(SceneError, match=r"work of at most 1 day for one computation .*\(at least 11.6 days at 1e\+10"):
        check_demands([[d]], Limits(1e9))


def test_the_estimate_of_a_harmonic_balance_is_its_arrays():
    jac, aft = harmonic_balance_demands(200, 2000, 4001, "analysis.harmonics")
    m = 200 * 4001
    assert jac.nbytes == budget.JACOBIAN_COPIES * 8 * m * m
    assert aft.nbytes == 2 * 8 * 4001 * (200 + 2 * 200 * 200)
    assert jac.operations >= 2 / 3 * m**3
    (cond, _) = harmonic_balance_demands(200, 10, 201, "analysis.harmonics", n_engine=2)
    assert cond.nbytes == budget.JACOBIAN_COPIES * 8 * 42 * 42 and "2 dofs (condensed from 200)" in cond.what


@pytest.mark.parametrize("field, value", [("memory", 0), ("memory", math.inf), ("seconds", -1.0), ("rate", True),
                                          ("basis", 3)])
def test_limits_are_validated_naming_the_field(field, value):
    kw = {"memory": 1e9, field: value}
    with pytest.raises(ValueError, match=f"Limits.{field}: expected"):
        Limits(**kw)


def test_the_machine_limit_is_a_share_of_what_is_available(monkeypatch):
    monkeypatch.setattr(budget, "machine_memory", lambda: (10.0 * GiB, None, "available (MemAvailable)"))
    lim = Limits.of_machine()
    assert lim.memory == 8 * GiB and lim.basis == "80% of the 10 GiB available (MemAvailable) is 8 GiB"
    monkeypatch.setattr(budget, "machine_memory", lambda: (10.0 * GiB, 1.0 * GiB, "available (MemAvailable)"))
    lim = Limits.of_machine()  # a hard limit (cgroup, ulimit -v) is never exceeded, floor or not
    assert lim.memory == 0.8 * GiB and "allowed to this process" in lim.basis
    monkeypatch.setattr(budget, "machine_memory", lambda: (0.1 * GiB, None, "available (MemAvailable)"))
    monkeypatch.setattr(budget, "_physical", lambda: 64.0 * GiB)
    assert Limits.of_machine().memory == budget.MEMORY_FLOOR  # a busy moment does not refuse small scenes


def test_this_machine_has_a_positive_limit():
    avail, hard, where = budget.machine_memory()
    assert avail > 0 and (hard is None or hard >= 0) and where
    assert Limits.of_machine().memory > 0
    assert size_text(4.66 * TiB) == "4.66 TiB" and time_text(14800) == "4.11 h"


_CHAINS = {}


def _chain(n):
    if n not in _CHAINS:
        _CHAINS[n] = build_model(parse_scene(CHAIN.format(n=n) + "analysis: {type: frequency_response, "
                                                                  "range: [0.5, 1.5]}\n"))
    return _CHAINS[n]


@settings(max_examples=fuzz_examples(40), deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(n=st.sampled_from([1, 3, 40, 200]), H=st.integers(1, 2000), samples=st.none() | st.integers(3, 2**20),
       stability=st.sampled_from(["none", "hill", "floquet", "both"]),
       steps=st.none() | st.integers(8, 10**13))
def test_any_sizes_are_accepted_within_the_limit_or_refused_naming_a_key(monkeypatch, n, H, samples, stability, steps):
    limit = 0.8 * 256 * 2**20
    if budget is not None:
        monkeypatch.setattr(budget, "machine_memory", lambda: (24.0 * GiB, 256.0 * 2**20, "test"))
    samples = None if samples is None else max(samples, 2 * H + 1)
    opts = "" if steps is None else f", stability_options: {{steps_per_period: {steps}}}"
    text = (f"analysis: {{type: frequency_response, range: [0.5, 1.5], harmonics: {H}, stability: {stability}"
            f"{'' if samples is None else f', samples: {samples}'}{opts}}}\n")
    scene = parse_scene(CHAIN.format(n=n) + text)
    model = _chain(n)
    try:
        check_scene(scene, model)
    except SceneError as exc:
        assert exc.key in ("analysis.harmonics", "analysis.samples", "analysis.stability",
                           "analysis.stability_options.steps_per_period"), str(exc)
        assert " in all" in str(exc) or "together" in str(exc)
        return
    for group in analysis(scene.analysis["type"]).demands(scene, model):
        assert sum(d.nbytes for d in group) <= limit
        assert all(d.operations <= budget.MAX_SECONDS * budget.OPERATIONS_PER_SECOND for d in group)
