"""Two sets of Floquet multipliers compared: their distance, and where the next crossing of the circle is predicted.

Multipliers of two points (or of two methods at one point) are paired by
the assignment that moves them least (:func:`pair_multipliers`).
:func:`multiplier_distance` is the largest distance after that pairing;
:func:`multiplier_step_limit` extrapolates each multiplier's distance to the
unit circle, and the distances between multipliers near it, to the arclength
at which the stability is predicted to change: the step limit of the
stability events.
"""

from __future__ import annotations

import functools
import itertools
import math

import numpy as np

from contin.engine.events import OVERSHOOT, predicted_zero

__all__ = ["multiplier_distance", "multiplier_step_limit", "pair_multipliers", "COLLISION_NEAR", "COLLISION_STEP"]


#: up to this many multipliers the pairing of least total distance is found among all permutations (720 at
#: most, one vectorised sum); beyond, by ``scipy.optimize.linear_sum_assignment``, whose package is slow to
#: import next to a small run (docs/benchmarks.md, a small run as a whole process)
ENUMERATED = 6


@functools.lru_cache(maxsize=None)
def _permutations(k: int) -> np.ndarray:
    return np.array(list(itertools.permutations(range(k))), dtype=np.intp).reshape(-1, k)


def _assignment(D: np.ndarray):
    """Rows and columns of the assignment of least total cost in the square cost matrix ``D`` (k, k), as
    ``scipy.optimize.linear_sum_assignment`` returns them."""
    k = D.shape[0]
    if k <= ENUMERATED:
        perms = _permutations(k)
        return np.arange(k), perms[int(np.argmin(D[np.arange(k), perms].sum(axis=1)))]
    from scipy.optimize import linear_sum_assignment

    return linear_sum_assignment(D)


def pair_multipliers(mu_a: np.ndarray, mu_b: np.ndarray) -> np.ndarray:
    """Index into ``mu_b`` of the partner of each multiplier of ``mu_a`` (closest overall pairing)."""
    if mu_a.shape != mu_b.shape:
        return np.full(mu_a.shape, -1)
    D = np.abs(mu_a[:, None] - mu_b[None, :])
    r, c = _assignment(D)
    out = np.empty(mu_a.size, dtype=int)
    out[r] = c
    return out


def multiplier_distance(a: np.ndarray, b: np.ndarray) -> float:
    """Largest distance between two multiplier sets after optimal pairing.

    Parameters
    ----------
    a, b : ndarray, shape (k,) complex

    Returns
    -------
    float
        ``max_i |a_i - b_pi(i)|`` for the pairing ``pi`` minimising the sum
        of distances (``inf`` if the sizes differ).
    """
    a = np.asarray(a, dtype=complex)
    b = np.asarray(b, dtype=complex)
    if a.shape != b.shape:
        return float("inf")
    if a.size == 0:
        return 0.0
    D = np.abs(a[:, None] - b[None, :])
    r, c = _assignment(D)
    return float(D[r, c].max())


#: Multipliers this close to the unit circle (in modulus) can be pushed across it by a collision.
COLLISION_NEAR = 0.05
#: Steps across a predicted collision of multipliers near the circle (scaled arclength): the
#: narrowest window of instability after one that the steps resolve.
COLLISION_STEP = 1e-3


def multiplier_step_limit(mu_a: np.ndarray, mu_b: np.ndarray, h: float, threshold: float = 1.0) -> float:
    """Predicted arclength beyond ``b`` to the next change of stability.

    Two ways a multiplier crosses the unit circle between two points:

    - it moves across it: each multiplier's distance to the circle,
      ``|mu| - threshold``, is extrapolated linearly from the two points;
    - two multipliers near the circle collide (a complex pair on the real
      axis, two pairs meeting on the circle) and split off it, one outwards:
      a period-doubling or Neimark-Sacker window that can be narrower than
      the step, with the multipliers inside the circle at both ends. The
      distance between any two multipliers within ``COLLISION_NEAR`` of the
      circle is extrapolated the same way.

    Multipliers are paired between the two points by the assignment that
    moves them least.

    Parameters
    ----------
    mu_a, mu_b : ndarray, shape (k,) complex
        Multipliers at the two points, ``h`` apart.
    h : float
    threshold : float
        ``1 + tolerance``.

    Returns
    -------
    float
        The longest next step: ``OVERSHOOT`` times the nearest predicted
        crossing (it then falls inside the step); half the way to the
        nearest predicted collision, but at least ``COLLISION_STEP``; ``inf``
        when nothing approaches.
    """
    pair = pair_multipliers(mu_b, mu_a)
    if (pair < 0).any():
        return math.inf
    mu_a = mu_a[pair]  # aligned with mu_b
    limit = OVERSHOOT * min((predicted_zero(abs(p) - threshold, abs(q) - threshold, h) for p, q in zip(mu_a, mu_b)),
                            default=math.inf)
    near = np.flatnonzero(np.abs(np.abs(mu_b) - 1.0) < COLLISION_NEAR)
    meet = math.inf
    for k, i in enumerate(near):
        for j in near[k + 1:]:
            meet = min(meet, predicted_zero(abs(mu_a[i] - mu_a[j]), abs(mu_b[i] - mu_b[j]), h))
    # the window a collision opens can be narrower than any overshoot: approach the meeting
    # point halving the way each step, then pass it in steps of COLLISION_STEP
    if math.isfinite(meet):
        limit = min(limit, max(0.5 * meet, COLLISION_STEP))
    return limit
