"""Tests of contin.engine.state: what a checkpoint holds is exactly what a restart reads."""

import json

import numpy as np

from contin.engine.continuation import ContinuationOptions, continuation
from contin.engine.events import FunctionEvent
from contin.engine.state import HOLDER, RESTART_KEYS, STATE_ARRAYS, STATE_SCALARS, Position


class Ends:
    """u - lam = 0 up to lam = 0.7, no solution beyond."""

    def linearize(self, u, lam):
        if lam > 0.7:
            raise ArithmeticError("outside the domain")
        return np.array([u[0] - lam]), np.array([[1.0]]), np.array([-1.0])


def edge():
    return FunctionEvent(lambda p: float(p.lam > 0.7), integer_valued=True, kind="grazing", name="edge",
                         distance=lambda p: 0.7 - p.lam, barrier=True)


def states_of_a_run():
    states = []
    continuation(Ends(), [0.0], 0.0, (0.0, 1.0), ContinuationOptions(ds=0.05, ds_max=0.2), events=[edge()],
                 checkpoint=lambda branch, state: states.append((len(branch), state)))
    return states


def test_every_value_has_one_holder_and_the_keys_are_the_restart_keys():
    assert set(HOLDER) == set(STATE_ARRAYS + STATE_SCALARS)
    assert len(RESTART_KEYS) == len(set(RESTART_KEYS))
    states = states_of_a_run()
    *steps, final = states
    assert steps and all(tuple(s) == RESTART_KEYS for _, s in steps)
    assert all(s["points"] == n for n, s in steps)
    assert set(final[1]) == {"monitors"}  # the branch ended: only the monitors' final states


def test_a_state_is_plain_values_and_arrays():
    for _, state in states_of_a_run()[:-1]:
        for name in STATE_ARRAYS:
            assert isinstance(state[name], np.ndarray)
        plain = {k: v for k, v in state.items() if not isinstance(v, np.ndarray) and k not in ("tests",)}
        json.dumps(plain)  # JSON-able but for the arrays
    # the barrier located from the near side is in the state of the point stored at it
    assert any(s["barrier"] is not None and s["barrier"]["event"] == 2 for _, s in states_of_a_run()[:-1])


def test_a_position_starts_empty():
    pos = Position()
    assert pos.x is None and pos.prev_info is None and pos.t_start is None and pos.max_dist == 0.0
