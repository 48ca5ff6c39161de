"""Result: tables, coefficients and time histories against the closed form of a linear oscillator;
the same object from a call and from the files of `contin run`; exports."""

import sys

import numpy as np
import pytest

import contin
from contin.app.cli import main

M, C, K, F = 1.0, 0.1, 1.0, 0.5


@pytest.fixture(scope="module")
def linear(tmp_path_factory):
    """The built-in Duffing with g = 0: x'' + c x' + k x = F cos(w t), whose response is known exactly."""
    out = tmp_path_factory.mktemp("linear")
    system = contin.System.builtin("duffing", {"m": M, "c": C, "k": K, "g": 0.0, "F": F},
                                   effects=["damping", "cubic", "forcing"])
    return contin.frequency_response(system, parameter="w", range=[0.5, 1.5], harmonics=3, stability="hill",
                                     outdir=out, output={"exports": ["npz", "mat"]})


def test_time_history_is_the_closed_form_response(linear):
    b = linear.branches[0]
    assert linear.status == "complete" and b.name == "harmonic" and np.all(b.stable == 1)
    for i in (0, len(b) // 2, len(b) - 1):
        w = float(b.parameter[i])
        t, x, xdot = linear.time_history(b.rows[i], samples=64)
        z = F / (K - M * w ** 2 + 1j * C * w)  # x = Re(z e^{iwt})
        exact = np.real(z * np.exp(1j * w * t))
        assert np.abs(x[:, 0] - exact).max() < 1e-9 * abs(z)
        assert np.abs(xdot[:, 0] - np.real(1j * w * z * np.exp(1j * w * t))).max() < 1e-9 * w * abs(z)
        assert b["amp_x"][i] == pytest.approx(abs(z), rel=1e-9)
        U = linear.coefficients(b.rows[i])
        assert U.shape == (7, 1) and U[1, 0] == pytest.approx(z.real) and U[2, 0] == pytest.approx(-z.imag)


def test_files_of_the_command_line_load_into_the_same_result(linear, tmp_path):
    assert main(["run", "scenes/duffing.yaml", "-o", str(tmp_path), "-q", "--set", "model.parameters.g=0",
                 "--set", "analysis.range=[0.5, 1.5]", "--set", "analysis.harmonics=3",
                 "--set", "analysis.stability=hill"]) == 0
    cli = contin.load(tmp_path)
    assert len(cli.branches) == 1 and cli.parameter == "w"
    np.testing.assert_allclose(cli["amp_x"], linear["amp_x"], rtol=1e-12)
    np.testing.assert_allclose(cli.coefficients(), linear.coefficients(), atol=1e-14)
    assert "coefficients.csv" in cli.files and "results.npz" in cli.files


def test_exports_hold_the_tables_and_coefficients(linear):
    z = np.load(linear.outdir / "results.npz")
    np.testing.assert_array_equal(z["branches/amp_x"], linear["amp_x"])
    assert z["coefficients"].shape == (len(linear["w"]), 7, 1) and str(z["parameter"]) == "w"
    assert set(np.unique(z["branches/stable"])) <= {-1, 0, 1}
    assert not any(np.isnan(z[k]).any() for k in z.files if z[k].dtype.kind == "f")
    import scipy.io

    mat = scipy.io.loadmat(linear.outdir / "results.mat", squeeze_me=True, struct_as_record=False)
    np.testing.assert_array_equal(mat["branches"].w, linear["w"])
    text = (linear.outdir / "coefficients.csv").read_text().splitlines()
    assert text[0].startswith("row,branch,nu,w,base_frequency,a0_x,a1_x,b1_x") and len(text) == len(linear["w"]) + 1


def test_dataframe_needs_pandas_and_says_so(linear, monkeypatch):
    monkeypatch.setitem(sys.modules, "pandas", None)
    with pytest.raises(ImportError, match="pip install pandas"):
        linear.to_dataframe()


def test_missing_columns_and_rows_are_named(linear):
    with pytest.raises(KeyError, match="amp_x"):
        linear["amp_y"]
    with pytest.raises(IndexError, match="no stored coefficients"):
        linear.coefficients(10 ** 6)
    with pytest.raises(FileNotFoundError, match="summary.json"):
        contin.load(linear.outdir / "nowhere")
