"""The ``backbone`` analysis: the belt's Fig. 8 scene, columns, start frequencies and bad input."""

from pathlib import Path

import numpy as np
import pytest
import scipy.linalg

from contin.app.cli import main
from contin.models.timing_belt import PAPER_MAGNET, galerkin_tensors
from contin.output.results import read_csv

ROOT = Path(__file__).resolve().parents[2]
SCENE = ROOT / "scenes" / "belt_backbone.yaml"


def linear_frequencies_by_hand():
    """Equilibrium of eq. 12 under the magnet and the eigenvalues about it, from the tensors of eq. 13."""
    T = galerkin_tensors(5, 0.005, 0.2, 0.4, PAPER_MAGNET)
    E = T["E"]
    Es = E + E.transpose(0, 2, 1, 3) + E.transpose(0, 2, 3, 1)
    Ds = T["D"] + T["D"].transpose(0, 2, 1)
    b = np.zeros(5)
    for _ in range(50):
        R = T["C"] @ b + np.einsum("ijk,j,k->i", T["D"], b, b) + np.einsum("ijkl,j,k,l->i", E, b, b, b) - T["F"]
        K = T["C"] + np.einsum("ijk,k->ij", Ds, b) + np.einsum("ijkl,k,l->ij", Es, b, b)
        b = b - np.linalg.solve(K, R)
    return np.sqrt(scipy.linalg.eigh(K, T["B"], eigvals_only=True))


def test_belt_backbone_scene(tmp_path):
    out = tmp_path / "bb"
    assert main(["check", str(SCENE)]) == 0
    assert main(["run", str(SCENE), "-o", str(out), "-q", "--set", "analysis.range=[0.01, 9]"]) == 0
    rows = read_csv(out / "branches.csv")
    sp = read_csv(out / "special_points.csv")
    omega = linear_frequencies_by_hand()
    for mode in (1, 2):
        sel = rows["mode"] == mode
        f = rows["frequency"][sel]
        assert f[0] == pytest.approx(omega[mode - 1], rel=1e-6)  # starts at the linear frequency
        np.testing.assert_allclose(rows["w_rms"][sel], rows["amplitude"][sel], rtol=1e-9)  # amplitude = w_rms
        assert np.abs(rows["unfolding"][sel]).max() < 1e-9
    assert rows["amplitude"].max() == pytest.approx(9.0)
    # mode 1 with the magnet: softening down to a minimum frequency, then hardening (Fig. 8)
    fmin = sp["frequency"][(sp["kind"] == "frequency_min") & (sp["mode"] == 1)]
    assert len(fmin) == 1 and 3.3 < fmin[0] < 3.6
    assert (out / "backbone.png").exists()


@pytest.mark.parametrize("override, key", [
    ("analysis.dof=v", "analysis.dof"),
    ("analysis.mode=9", "analysis.mode"),
    ("analysis.mode=0", "analysis.mode"),
    ("analysis.range=[0, 10]", "analysis.range"),
    ("analysis.amplitude=max", "analysis.amplitude"),
    ("model.effects=[rotor_mass, stretching, damping];model.parameters.zeta=0.01", "model"),
])
def test_backbone_bad_input_names_the_key(override, key, tmp_path, capsys):
    sets = [a for o in override.split(";") for a in ("--set", o)]
    assert main(["run", str(SCENE), "-o", str(tmp_path / "x"), "-q"] + sets) == 2
    assert key in capsys.readouterr().err
