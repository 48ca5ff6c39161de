"""The whirl radii of a torus from its circle's trajectories (contin.timedomain.circle_measures.circle_whirl)
against a torus written in closed form: z = F e^{i theta1} + P e^{i theta2} + C e^{-i (theta1 - theta2)}
+ B e^{-i theta1}, the forward forced, self-excited, backward combination and backward forced whirls."""

import math

import numpy as np
import pytest

import contin.timedomain.circle_measures as circle_measures


def _torus(B=0.02):
    N, S, r = 15, 64, 0.3719
    F, P, C, B = 0.8 * np.exp(0.3j), 0.37 * np.exp(-1.1j), 0.05 * np.exp(2.0j), 0.02
    theta1 = 2 * math.pi * np.arange(S) / S
    theta2 = 2 * math.pi * np.arange(N)[:, None] / N + r * theta1[None, :]  # (N, S): the sheared grid
    z = (F * np.exp(1j * theta1) + P * np.exp(1j * theta2) + C * np.exp(-1j * (theta1 - theta2))
         + B * np.exp(-1j * theta1))
    X = np.zeros((N, S, 4))  # (x, y, x', y'): the velocities play no part
    X[:, :, 0], X[:, :, 1] = z.real, z.imag
    return X, theta1, r, (F, P, C, B)


def test_the_whirl_radii_of_a_torus_in_closed_form(monkeypatch):
    X, theta1, r, (F, P, C, B) = _torus()
    monkeypatch.setattr(circle_measures, "circle_surface", lambda problem, u, lam: (X, theta1, r))
    got = circle_measures.circle_whirl(None, None, 1.0, 0, 1)
    assert got["forced"] == pytest.approx(abs(F), rel=1e-13)
    assert got["self_excited"] == pytest.approx(abs(P), rel=1e-13)
    assert got["combination"] == pytest.approx(abs(C), rel=1e-12)
    assert got["ratio"] == r
    # the same torus whirling the other way (y -> -y): its forward lines are now the backward ones
    X[:, :, 1] *= -1.0
    got = circle_measures.circle_whirl(None, None, 1.0, 0, 1)
    assert got["forced"] == pytest.approx(B, rel=1e-12) and got["self_excited"] < 1e-14


class _Circle:
    """What circle_measures reads of a circle problem besides its trajectories."""

    n = 2

    @staticmethod
    def frequency_at(lam):
        return lam


def test_a_circle_rows_whirl_columns_in_closed_form(monkeypatch):
    X, theta1, r, (F, P, C, B) = _torus(B=0.02 * np.exp(0.7j))
    monkeypatch.setattr(circle_measures, "circle_surface", lambda problem, u, lam: (X, theta1, r))
    out = circle_measures.circle_measures(_Circle(), None, 1.9, ["x1", "y1"], 3, {"disc": (0, 1)})
    assert out["whirl_fwd_1_disc"] == pytest.approx(abs(F), rel=1e-13)
    assert out["whirl_bwd_1_disc"] == pytest.approx(abs(B), rel=1e-12)
    assert out["whirl_fwd_free_disc"] == pytest.approx(abs(P), rel=1e-13)
    assert out["whirl_bwd_comb_disc"] == pytest.approx(abs(C), rel=1e-12)
    assert out["whirl_fwd_half_disc"] == out["whirl_bwd_half_disc"] == 0.0  # no line at w/2 on a torus
    assert out["frequency2"] == pytest.approx(r * 1.9)
