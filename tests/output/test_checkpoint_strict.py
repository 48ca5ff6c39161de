"""``state.jsonl`` is strict JSON both ways: values that are not finite are written tagged and read back exactly,
the tokens ``NaN`` and ``Infinity`` are refused, and an engine state whose steps are not positive finite
numbers is refused before a resume would run with it (issue 32: such a state made the resumed run hang)."""

import json
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from conftest import no_hang

from contin.output.checkpoint import CheckpointError, decode, encode, read_records

FLOATS = st.floats(allow_nan=True, allow_infinity=True)


def strict(text: str):
    def refuse(token):
        raise ValueError(f"{token} is not JSON")
    return json.loads(text, parse_constant=refuse)


def same(a, b) -> bool:
    if isinstance(a, np.ndarray):
        return isinstance(b, np.ndarray) and a.shape == b.shape and a.dtype.kind == b.dtype.kind and bool(
            np.all((a == b) | (np.isnan(a) & np.isnan(b)) if a.dtype.kind in "fc" else a == b))
    if isinstance(a, float):
        return isinstance(b, float) and (a == b or (math.isnan(a) and math.isnan(b)))
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(same(a[k], b[k]) for k in a)
    if isinstance(a, list):
        return len(a) == len(b) and all(same(x, y) for x, y in zip(a, b))
    return a == b


@settings(max_examples=40, deadline=None)
@given(scalars=st.lists(FLOATS, max_size=4), array=st.lists(FLOATS, min_size=1, max_size=6),
       z=st.complex_numbers(allow_nan=True, allow_infinity=True))
def test_values_that_are_not_finite_round_trip_through_strict_json(scalars, array, z):
    state = {"ds_free": 0.1, "event_cap": math.inf, "jac_norm_start": math.nan, "scalars": scalars,
             "x": np.array(array), "grid": np.array([array, array]), "multipliers": np.array([z, 1 + 0j]),
             "z": z, "flags": np.array([True, False])}
    text = json.dumps(encode(state), allow_nan=False)  # raised ValueError on inf before
    back = decode(strict(text))
    assert same(state["x"], back["x"]) and same(state["grid"], back["grid"])
    assert same(state["multipliers"], back["multipliers"]) and back["flags"].dtype == bool
    assert back["event_cap"] == math.inf and math.isnan(back["jac_norm_start"])
    assert same(scalars, back["scalars"])
    assert (back["z"].real == z.real or math.isnan(z.real)) and (back["z"].imag == z.imag or math.isnan(z.imag))


@pytest.mark.parametrize("token", ["Infinity", "-Infinity", "NaN"])
def test_a_line_holding_a_token_json_does_not_have_is_refused(tmp_path, token):
    path = tmp_path / "state.jsonl"
    path.write_text('{"type": "branch", "branch": 0}\n'
                    f'{{"type": "point", "row": 0, "branch": 0, "lam": {token}, "u": [1.0], "tangent": [1.0]}}\n')
    with pytest.raises(CheckpointError, match=rf"state.jsonl line 2: strict JSON .* found the token {token}"):
        read_records(path)


def test_a_tag_that_is_no_number_is_refused():
    with pytest.raises(CheckpointError, match="inf, -inf or nan, found 'lots'"):
        decode({"__float__": "lots"})


def test_a_checkpoint_that_is_a_pipe_is_refused(tmp_path):
    import os

    target = tmp_path / "elsewhere.jsonl"
    target.write_text('{"type": "branch", "branch": 0}\n')
    (tmp_path / "state.jsonl").symlink_to(target)  # read (kept as links by data-management tools), never written
    assert read_records(tmp_path / "state.jsonl") == [{"type": "branch", "branch": 0}]
    os.mkfifo(tmp_path / "pipe.jsonl")
    with no_hang(20), pytest.raises(OSError, match="named pipe"):  # reading it would block
        read_records(tmp_path / "pipe.jsonl")


@pytest.fixture(scope="module")
def engine_records(tmp_path_factory):
    """The records of a cheap run up to its last engine state (as a run killed there leaves them)."""
    from pathlib import Path

    from contin.app.cli import main

    out = tmp_path_factory.mktemp("checkpoint") / "run"
    scene = str(Path(__file__).resolve().parents[2] / "scenes" / "duffing.yaml")
    assert main(["run", scene, "-o", str(out), "-q", "--set", "analysis.harmonics=1", "--set", "output.plots=false",
                 "--set", "analysis.stability=none", "--set", "analysis.range=[0.5, 1.0]"]) == 0
    records = read_records(out / "state.jsonl")
    last = max(i for i, r in enumerate(records) if r["type"] == "engine")
    return records[:last + 1]


NOT_A_STEP = st.one_of(st.floats(max_value=0.0), st.sampled_from([math.inf, -math.inf, math.nan]), st.none(),
                       st.booleans(), st.text(max_size=3), st.lists(st.floats(0.1, 1.0), max_size=2))


@settings(max_examples=25, deadline=None)
@given(key=st.sampled_from(["ds", "ds_free", "sl", "recent"]), value=NOT_A_STEP)
def test_an_engine_state_whose_steps_are_not_positive_and_finite_is_refused(engine_records, key, value):
    import copy

    from contin.output.checkpoint import rebuild_branches, resumable_prefix

    records = copy.deepcopy(engine_records)
    state = records[-1]["state"]
    if key == "recent":
        if isinstance(value, list):
            return  # a list of positive steps is a valid history
        state["recent"] = [0.01, value]
    else:
        state[key] = value
    prefix, _, _ = resumable_prefix(records, 1 << 62)
    with pytest.raises(CheckpointError, match=rf"engine state of branch 0: steps that are positive finite numbers, "
                                              rf"found {key}"):
        rebuild_branches(prefix, "w")
    state[key] = engine_records[-1]["state"][key]  # the state as it was is taken up
    assert rebuild_branches(resumable_prefix(records, 1 << 62)[0], "w")[0].info["restart"]["ds"] > 0


@pytest.mark.parametrize("change, found", [(None, None), ({"step": 0.0}, "step = 0.0"), ({"step": math.nan}, "step"),
                                           ({"lu_u": [1.0, 2.0]}, "lu_u")])
def test_a_natural_step_state_is_checked_against_its_branch(engine_records, change, found):
    """The state a circle branch in natural steps writes (contin.bifurcation.circle_natural): taken up when it
    fits its branch, else refused naming what does not fit."""
    import copy

    from contin.output.checkpoint import rebuild_branches, resumable_prefix

    records = copy.deepcopy(engine_records)
    old = records[-1]["state"]
    m = 3  # the branch's unknowns: H = 1, one dof
    natural = {"step": -0.01, "largest": 1.0, "failures": 0, "lu_u": list(np.linspace(0.0, 1.0, m)), "lu_lam": 0.7}
    records[-1]["state"] = {"points": old["points"], "natural": {**natural, **(change or {})}, "monitors": []}
    prefix, _, _ = resumable_prefix(records, 1 << 62)
    if found is None:
        assert rebuild_branches(prefix, "w")[0].info["restart"]["natural"]["step"] == -0.01
        return
    with pytest.raises(CheckpointError, match=rf"natural-step state of branch 0 does not fit .*{found}"):
        rebuild_branches(prefix, "w")
