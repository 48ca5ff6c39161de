"""The analysis calls: the scene's keys, the scene's checks, the same results as `contin run`, no global change."""

import signal

import numpy as np
import pytest
import yaml

import contin
from contin.scene.schema import SceneError


def test_frf_call_is_the_closed_form_receptance():
    chain = contin.System.from_scene("scenes/two_dof_frf.yaml")
    r = contin.frf(chain, range=[0.1, 2.0], points=40, force="x1")
    assert r.status == "complete" and "frf" in r.tables
    p = chain.parameters
    M = np.diag([p["m1"], p["m2"]])
    K = np.array([[p["k1"] + p["k2"], -p["k2"]], [-p["k2"], p["k2"] + p["k3"]]])
    t = r.tables["frf"]
    w = t[next(k for k in t if k in ("w", "frequency"))]
    amp = t[next(k for k in t if k.startswith("amp") and k.endswith("x1"))]
    exact = [abs(np.linalg.solve(K - wi ** 2 * M, [1.0, 0.0])[0]) for wi in w]
    np.testing.assert_allclose(amp, exact, rtol=1e-9)


def test_run_takes_a_dict_with_overrides_and_a_path():
    data = yaml.safe_load(open("scenes/two_dof_modes.yaml"))
    a = contin.run(data, overrides=["output.plots=false"])
    b = contin.run("scenes/two_dof_modes.yaml", overrides=["output.plots=false"])
    np.testing.assert_array_equal(a.tables["modes"]["omega2"], b.tables["modes"]["omega2"])


def test_type_keyword_and_bad_output_keys_are_refused():
    with pytest.raises(SceneError, match=r"analysis\.type"):
        contin.modes("duffing", type="static")
    with pytest.raises(SceneError, match=r"output\.formats"):
        contin.modes("duffing", output={"formats": ["bmp"]})


def test_nothing_global_changes_and_figures_go_where_outdir_says(tmp_path):
    from threadpoolctl import threadpool_info

    handler = signal.getsignal(signal.SIGINT)
    threads = [p["num_threads"] for p in threadpool_info()]
    r = contin.modes(contin.System.from_scene("scenes/two_dof_modes.yaml"), output={"plots": True},
                     outdir=tmp_path / "modes")
    assert signal.getsignal(signal.SIGINT) is handler
    assert [p["num_threads"] for p in threadpool_info()] == threads
    assert r.outdir == tmp_path / "modes" and any(f.endswith(".png") for f in r.files)
    held = contin.modes(contin.System.from_scene("scenes/two_dof_modes.yaml"))  # in memory: no directory at all
    assert held.outdir is None and held.files == [] and held.tables["modes"].keys() == r.tables["modes"].keys()


def test_a_wrong_keyword_is_a_type_error_naming_it_before_anything_runs(tmp_path):
    # before: a SceneError in scene words ("analysis.harmonics: expected one of the keys ...")
    with pytest.raises(TypeError, match=r"^modes\(\) got an unexpected keyword argument 'harmonics'; its keywords "
                                        r"are outdir, output, progress and the keys of a modes scene's analysis"):
        contin.modes("duffing", harmonics=5, outdir=tmp_path / "r")
    with pytest.raises(TypeError, match=r"'Range' \(did you mean 'range'\?\)"):
        contin.frf("duffing", Range=[0, 1], outdir=tmp_path / "r")
    assert not (tmp_path / "r").exists()
