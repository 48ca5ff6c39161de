"""The period doublings of the damped Mathieu equation by scipy (DOP853 and Brent): a reference independent of contin."""

import math

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq


def damped_mathieu_pd(lo, hi, c=0.1, eps=0.4):
    """delta where x'' + c x' + (delta + eps cos t) x = 0 has the multiplier -1: 1 + tr Phi + exp(-2 pi c) = 0."""
    def trace(delta):
        def rhs(t, y):
            return np.concatenate([y[2:], -(delta + eps * np.cos(t)) * y[:2] - c * y[2:]])

        y = solve_ivp(rhs, (0, 2 * np.pi), [1.0, 0.0, 0.0, 1.0], method="DOP853", rtol=1e-13, atol=1e-14).y[:, -1]
        return y[0] + y[3]

    return brentq(lambda d: 1 + trace(d) + math.exp(-2 * math.pi * c), lo, hi, xtol=1e-13)
