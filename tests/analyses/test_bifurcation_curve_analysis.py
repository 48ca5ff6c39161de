"""The bifurcation_curve analysis: scenes end to end against closed forms, files, plots, bad input."""

import json
from pathlib import Path

import numpy as np
import pytest
from scipy.special import mathieu_a, mathieu_b

from contin.app.cli import main
from contin.output.results import read_csv

ROOT = Path(__file__).resolve().parents[2]
C, K, B3 = 0.1, 1.0, 0.75


def fold_forces(w):
    """Closed-form H = 1 folds of x'' + 0.1 x' + x + x^3 = F cos(w t) at frequency w (both branches)."""
    s = K - w * w
    disc = s * s - 3 * (C * w) ** 2
    X = np.array([(-2 * s + sg * np.sqrt(disc)) / (3 * B3) for sg in (1, -1)])
    return np.sqrt(((s + B3 * X) ** 2 + (C * w) ** 2) * X)


def run(scene, tmp_path, *sets):
    out = tmp_path / Path(scene).stem
    args = ["run", str(ROOT / "scenes" / scene), "-o", str(out), "-q"]
    for s in sets:
        args += ["--set", s]
    assert main(["check", str(ROOT / "scenes" / scene)]) == 0
    assert main(args) == 0
    return out


@pytest.fixture(scope="module")
def duffing_out(tmp_path_factory):
    return run("duffing_fold_curve.yaml", tmp_path_factory.mktemp("bc"))


def test_duffing_scene_curve_and_cusp_against_the_closed_form(duffing_out):
    rows = read_csv(duffing_out / "curves.csv")
    assert list(rows)[:5] == ["curve", "kind", "nu", "w", "F"] and "amp_x" in rows and "h1_x" in rows
    assert set(rows["kind"]) == {"fold"} and set(rows["curve"]) == {0}
    err = np.min(np.abs(np.stack([fold_forces(w) for w in rows["w"]]) - rows["F"][:, None]), axis=1)
    assert err.max() < 1e-9
    pts = read_csv(duffing_out / "curve_points.csv")
    (i,) = np.flatnonzero(pts["kind"] == "cusp")
    w_c = (np.sqrt(3) * C + np.sqrt(3 * C * C + 4 * K)) / 2
    assert pts["located"][i] and abs(pts["w"][i] - w_c) < 1e-8
    assert abs(pts["F"][i] - fold_forces(w_c)[0]) < 1e-8


def test_duffing_scene_one_parameter_folds_lie_on_the_curve(duffing_out):
    pts = read_csv(duffing_out / "one_parameter_points.csv")
    assert sorted(set(pts["F"])) == [0.2, 0.35, 0.5]
    assert np.all(pts["kind"] == "fold") and len(pts["kind"]) == 6 and np.all(pts["curve"] == 0)
    assert np.all(pts["located"]) and pts["distance"].max() < 1e-9
    # the one-parameter rows and special points of every run are there too
    sp = read_csv(duffing_out / "special_points.csv")
    assert set(sp["branch"]) == {0, 1, 2} and np.sum(sp["kind"] == "fold") == 6
    summary = json.loads((duffing_out / "summary.json").read_text())
    a = summary["analysis"]
    assert summary["status"] == "complete" and a["parameters"] == ["w", "F"]
    assert len(a["curves"]) == 1 and a["curves"][0]["special_points"]["cusp"] == 1
    # one side turns back at the cusp (the fold curve's extremum in F) and ends on the F bound it started from
    assert sorted(e["status"] for e in a["curves"][0]["ends"]) in (["range_end", "range_end"],
                                                                   ["range_end", "turned_back"])
    assert a["starts_on_earlier_curves"][0]["on_curve"] == 0  # the second fold is on the first curve
    assert a["max_distance_to_curves"] < 1e-9
    assert (duffing_out / "bifurcation_curves.png").stat().st_size > 20_000


def test_mathieu_scene_curves_are_the_transition_curves(tmp_path):
    out = run("mathieu_pd_curve.yaml", tmp_path)
    rows = read_csv(out / "curves.csv")
    assert set(rows["curve"]) == {0, 1} and set(rows["kind"]) == {"pd"}
    ref = np.minimum(np.abs(rows["delta"] - np.array([mathieu_a(1, 2 * e) / 4 for e in rows["eps"]])),
                     np.abs(rows["delta"] - np.array([mathieu_b(1, 2 * e) / 4 for e in rows["eps"]])))
    assert ref.max() < 1e-9
    assert np.all(rows["amp_x"] == 0.0)
    pts = read_csv(out / "one_parameter_points.csv")
    assert len(pts["kind"]) == 6 and pts["distance"].max() < 1e-9
    ends = read_csv(out / "curve_points.csv")
    landed = ends["kind"] == "end"
    assert np.any(ends["delta"][landed] == -0.2)  # a curve leaves the delta range: it ends on the bound


@pytest.mark.slow  # the curves against the transition curves: test_mathieu_scene_curves_are_the_transition_curves
def test_shooting_reference_finds_the_transition_curves_and_the_curves(tmp_path):
    """Period doublings of the integrated flow (contin.timedomain.shooting) at eps = 0.2, 0.6: scipy's curves, on the HB curves."""
    out = run("mathieu_pd_curve.yaml", tmp_path, "analysis.overlay=[]", "analysis.shooting=[0.2, 0.6]",
              "analysis.shooting_points=21", "analysis.shooting_options={steps_per_period: 1024}")
    pts = read_csv(out / "shooting_points.csv")
    assert len(pts["eps"]) == 4 and np.all(pts["located"])
    for e in (0.2, 0.6):
        got = np.sort(pts["delta"][pts["eps"] == e])
        np.testing.assert_allclose(got, sorted([mathieu_b(1, 2 * e) / 4, mathieu_a(1, 2 * e) / 4]), atol=1e-9)
    assert pts["distance"].max() < 1e-8  # the harmonic-balance curves pass through them
    sh = json.loads((out / "summary.json").read_text())["analysis"]["shooting"]
    assert [r["status"] for r in sh["runs"]] == ["complete", "complete"]
    assert sh["options"]["steps_per_period"] == 1024 and sh["max_distance_to_curves"] < 1e-8


@pytest.mark.parametrize("override,key,message", [
    (["analysis.shooting=[0.2]"], "analysis.shooting", "period-doubling curves to check ('pd' in analysis.curves)"),
    (["analysis.shooting=[0.2]", "analysis.curves=[pd]", "analysis.shooting_options={steps: 8}"],
     "analysis.shooting_options", "unknown option 'steps' of"),
    (["analysis.shooting=[0.2]", "analysis.curves=[pd]", "analysis.shooting_options={start_step: 8}"],
     "analysis.shooting_options.start_step", "a key a scene sets (its orbits are shot from forcing phase zero)"),
    (["analysis.shooting_points=2"], "analysis.shooting_points", "an integer from 3 to 10000"),
])
def test_bad_shooting_input_names_the_key(override, key, message, tmp_path, capsys):
    sets = [x for o in override for x in ("--set", o)]
    code = main(["run", str(ROOT / "scenes/duffing_fold_curve.yaml"), "-o", str(tmp_path / "x"), "-q"] + sets)
    assert code == 2
    err = " ".join(capsys.readouterr().err.split())  # the message is wrapped for the terminal
    assert key in err and message in err, err


@pytest.mark.parametrize("scene", ["rotor_entrainment_f0.yaml", "rotor_entrainment_c2.yaml"])
def test_rotor_scenes_check(scene, capsys):
    assert main(["check", str(ROOT / "scenes" / scene)]) == 0
    out = capsys.readouterr().out
    assert "curves: pd in (w," in out and "unknowns: 324" in out


BAD = [
    ("analysis.second_parameter=G", "analysis.second_parameter", "expected a parameter of the model"),
    ("analysis.second_parameter=w", "analysis.second_parameter", "a parameter other than analysis.parameter"),
    ("analysis.second_range=[0.6, 1.0]", "analysis.second_range", "a range containing the model's F = 0.5"),
    ("analysis.overlay=[a]", "analysis.overlay", "a list of values of the second parameter"),
    ("analysis.curves=[hopf]", "analysis.curves", "a list of curve kinds among 'fold', 'pd'"),
    ("analysis.curve_options={detekt: [cusp]}", "analysis.curve_options", "unknown option 'detekt'"),
    ("analysis.curve_continuation={ds_maxx: 1}", "analysis.curve_continuation", "did you mean 'ds_max'"),
    ("analysis.pd_test=stability", "analysis.pd_test", "a stability method (analysis.stability)"),
    ("analysis.crossings=sampled", "analysis.crossings", "'exact'"),
]


@pytest.mark.parametrize("override,key,message", BAD)
def test_bad_input_names_the_key(override, key, message, tmp_path, capsys):
    sets = ["--set", override] + (["--set", "analysis.curves=[pd]"] if "pd_test" in override else [])
    code = main(["run", str(ROOT / "scenes/duffing_fold_curve.yaml"), "-o", str(tmp_path / "x"), "-q"] + sets)
    assert code == 2
    err = " ".join(capsys.readouterr().err.split())  # the message is wrapped for the terminal
    assert key in err and message in err, err
    assert not (tmp_path / "x" / "curves.csv").exists()
