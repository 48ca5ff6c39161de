"""Per-point measures against closed forms."""

import numpy as np

from contin.hb.measures import point_measures


def test_measures_of_a_known_series():
    # x = 0.3 + 2 cos(theta) + 0.5 sin(3 theta): extrema from a dense grid, RMS by Parseval
    H = 4
    U = np.zeros((2 * H + 1, 1))
    U[0, 0], U[1, 0], U[6, 0] = 0.3, 2.0, 0.5
    m = point_measures(U.ravel(), 1, ["x"], harmonic_columns=5)
    th = np.linspace(0, 2 * np.pi, 2_000_001)
    x = 0.3 + 2 * np.cos(th) + 0.5 * np.sin(3 * th)
    assert abs(m["max_x"] - x.max()) < 1e-11 and abs(m["min_x"] - x.min()) < 1e-11
    assert abs(m["amp_x"] - 0.5 * (x.max() - x.min())) < 1e-11
    assert abs(m["rms_x"] - np.sqrt((4 + 0.25) / 2)) < 1e-14
    assert m["h0_x"] == 0.3 and m["h1_x"] == 2.0 and m["h3_x"] == 0.5 and m["h2_x"] == 0.0
    assert "h5_x" not in m  # capped at H
