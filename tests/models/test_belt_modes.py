"""Timing belt, Fig. 2: natural frequencies from the generic ``modes`` analysis, against closed forms.

A string with a point mass beta at xi1 (tension and length normalised so that the bare string's
frequencies are j pi) has the exact frequency equation

    cot(w xi1) + cot(w (1 - xi1)) = beta w

(continuity at xi1 and the jump of the slope, -beta w^2 w(xi1)). Galerkin on sin(j pi xi) is a
Rayleigh-Ritz method: its frequencies lie above the exact ones and come down as n grows.
"""

from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import brentq

from contin.app.cli import main
from contin.output.results import read_csv

ROOT = Path(__file__).resolve().parents[2]
XI1 = 0.4


def exact_root(beta, lo, hi):
    f = lambda w: 1 / np.tan(w * XI1) + 1 / np.tan(w * (1 - XI1)) - beta * w  # noqa: E731
    return brentq(f, lo, hi, xtol=1e-14)


@pytest.fixture(scope="module")
def modes(tmp_path_factory):
    out = {}
    for n in (5, 20):
        d = tmp_path_factory.mktemp(f"belt_modes_{n}")
        assert main(["run", str(ROOT / "scenes/belt_modes.yaml"), "-o", str(d), "-q",
                     "--set", f"model.parameters.terms={n}", "--set", "analysis.values=[0, 0.2, 10]",
                     "--set", "analysis.range=null"]) == 0
        out[n] = read_csv(d / "modes.csv")
    return out


def omega(rows, beta, mode):
    m = (rows["beta"] == beta) & (rows["mode"] == mode)
    return float(rows["omega"][m][0])


def test_bare_string_and_the_node_of_mode_five(modes):
    rows = modes[5]
    for j in range(1, 6):
        assert abs(omega(rows, 0.0, j) - j * np.pi) < 1e-12
    # xi1 = 0.4 is a node of sin(5 pi xi): that mode does not feel the rotor
    for beta in (0.2, 10.0):
        assert np.isclose(rows["omega"][(rows["beta"] == beta)], 5 * np.pi, atol=1e-10).any()


@pytest.mark.parametrize("beta,rel5", [(0.2, 0.005), (10.0, 0.05)])
def test_first_mode_is_a_rayleigh_ritz_bound_that_converges(modes, beta, rel5):
    """n = 5 is 0.4 % high at beta = 0.2 and 4 % at beta = 10 (the sine basis cannot bend at the mass)."""
    exact = exact_root(beta, 1e-6, np.pi / (1 - XI1) - 1e-9)  # below the first pole of the cot sum
    w5, w20 = omega(modes[5], beta, 1), omega(modes[20], beta, 1)
    assert exact < w20 < w5  # upper bounds, decreasing with n
    assert (w20 - exact) < 0.5 * (w5 - exact)
    assert (w5 - exact) / exact < rel5
