"""The ``static`` analysis: restoring-force curves of the belt, Table 1 through a scene, folds (snap-through)."""

from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import fsolve

from contin.app.cli import main
from contin.models.timing_belt import PAPER_MAGNET, galerkin_tensors, load_shape
from contin.output.results import read_csv
from contin.scene.parse import SceneError, parse_scene

ROOT = Path(__file__).resolve().parents[2]
SCENE = ROOT / "scenes" / "belt_static.yaml"


def run(tmp_path, *sets, name="static"):
    out = tmp_path / name
    args = ["run", str(SCENE), "-o", str(out), "-q"]
    for s in sets:
        args += ["--set", s]
    assert main(["check", str(SCENE)] + [a for s in sets for a in ("--set", s)]) == 0
    assert main(args) == 0
    return read_csv(out / "branches.csv"), read_csv(out / "special_points.csv"), out


def test_table_1_column_through_the_static_scene(tmp_path):
    rows, sp, out = run(tmp_path, "model.effects=[rotor_mass, stretching, static_load]", "analysis.range=[0, 30]",
                        "analysis.both_ways=false")
    T = galerkin_tensors(5, 0.005, 0.2, 0.4)
    G = load_shape(5, 0.2, 0.4)
    b = np.column_stack([rows[f"b{j}"] for j in range(1, 6)])
    for bj, p in zip(b, rows["p_s"]):  # every stored equilibrium satisfies eq. 12 written with the full tensors
        res = T["C"] @ bj + np.einsum("ijkl,j,k,l->i", T["E"], bj, bj, bj) - p * G
        assert np.abs(res).max() < 1e-9
    assert rows["p_s"][-1] == 30.0 and round(rows["w"][-1], 4) == 3.7643  # Table 1, n = 5
    assert np.all(rows["stable"]) and np.all(np.diff(rows["w"]) > 0)
    assert (out / "static.png").exists()
    assert list(sp["kind"]) == ["end"]


def fold_reference(p_guess, w_guess_b):
    """Limit load of eq. 12 (paper magnet, beta = 0.2) solved independently: R(b, p) = 0 and det dR/db = 0."""
    T = galerkin_tensors(5, 0.005, 0.2, 0.4, PAPER_MAGNET)
    G = load_shape(5, 0.2, 0.4)

    def R(b, p):
        return T["C"] @ b + np.einsum("ijk,j,k->i", T["D"], b, b) + np.einsum("ijkl,j,k,l->i", T["E"], b, b, b) \
            - T["F"] - p * G

    def K(b):
        E = T["E"]
        return T["C"] + 2 * np.einsum("ijk,k->ij", 0.5 * (T["D"] + T["D"].transpose(0, 2, 1)), b) \
            + np.einsum("ijkl,k,l->ij", E + E.transpose(0, 2, 1, 3) + E.transpose(0, 2, 3, 1), b, b)

    def eqs(z):
        b, p = z[:5], z[5]
        return np.concatenate([R(b, p), [np.linalg.det(K(b)) / 1e4]])

    z = fsolve(eqs, np.concatenate([w_guess_b, [p_guess]]), xtol=1e-13)
    assert np.abs(eqs(z)).max() < 1e-8
    return z[5]


def test_snap_through_folds_under_a_load_against_the_magnet(tmp_path):
    rows, sp, _ = run(tmp_path, "analysis.range=[-100, 0]", "analysis.start=0", name="snap")
    folds = sp["kind"] == "fold"
    assert folds.sum() == 2
    for i in np.flatnonzero(folds):
        b = np.array([sp[f"b{j}"][i] for j in range(1, 6)])
        ref = fold_reference(sp["p_s"][i], b)
        assert sp["p_s"][i] == pytest.approx(ref, abs=1e-7)
        assert abs(sp["lowest_eigenvalue"][i]) < 1e-6  # the tangent stiffness is singular there
    p1, p2 = np.sort(sp["p_s"][folds])
    assert -73 < p1 < -71 and -68 < p2 < -66  # near p_s = -71.85 and -67.07
    # the middle part between the folds is statically unstable, the outer parts stable
    assert not np.all(rows["stable"]) and rows["stable"][0] and rows["stable"][-1]
    assert np.all(rows["n_unstable"][~rows["stable"].astype(bool)] == 1)


def test_static_scene_errors_name_the_key(tmp_path):
    text = SCENE.read_text()
    with pytest.raises(SceneError, match="analysis.range"):
        parse_scene(text.replace("range: [-100, 60]", "range: [5]"))
    with pytest.raises(SceneError, match="analysis.parameter .*required"):
        parse_scene(text.replace("  parameter: p_s\n", ""))
    bad = tmp_path / "bad.yaml"
    bad.write_text(text.replace("parameter: p_s", "parameter: p_x"))
    assert main(["run", str(bad), "-o", str(tmp_path / "b"), "-q"]) == 2
    bad.write_text(text.replace("measure: w", "measure: v"))
    assert main(["run", str(bad), "-o", str(tmp_path / "c"), "-q"]) == 2
    mathieu = tmp_path / "mathieu.yaml"
    mathieu.write_text("model: {builtin: mathieu}\nanalysis: {type: static, parameter: delta, range: [0, 1]}\n")
    assert main(["run", str(mathieu), "-o", str(tmp_path / "m"), "-q"]) == 2
