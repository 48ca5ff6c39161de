"""The pairing of two multiplier sets: least total distance, against scipy's assignment solver."""

import numpy as np
import pytest
from scipy.optimize import linear_sum_assignment

from contin.stability.multiplier_pairing import ENUMERATED, multiplier_distance, pair_multipliers


@pytest.mark.parametrize("k", range(1, ENUMERATED + 3))
def test_pairing_has_the_least_total_distance(k):
    rng = np.random.default_rng(k)
    for _ in range(20):
        a = rng.normal(size=k) + 1j * rng.normal(size=k)
        b = a[rng.permutation(k)] + 0.3 * (rng.normal(size=k) + 1j * rng.normal(size=k))
        D = np.abs(a[:, None] - b[None, :])
        r, c = linear_sum_assignment(D)
        idx = pair_multipliers(a, b)
        assert sorted(idx) == list(range(k))  # a permutation
        assert D[np.arange(k), idx].sum() == pytest.approx(D[r, c].sum(), rel=1e-14)
        assert multiplier_distance(a, b) == pytest.approx(D[np.arange(k), idx].max(), rel=1e-14)


def test_a_set_paired_with_itself_is_not_moved():
    mu = np.array([0.9 + 0.1j, 0.9 - 0.1j, -0.5, 0.2])
    assert list(pair_multipliers(mu, mu)) == [0, 1, 2, 3]
    assert multiplier_distance(mu, mu[::-1]) == 0.0
    assert list(pair_multipliers(mu, mu[:3])) == [-1, -1, -1, -1]  # sizes differ
