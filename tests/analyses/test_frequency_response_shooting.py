"""``frequency_response`` by shooting (``analysis.method``): its keys, its rows, its switch and its resume.

Truth from outside the code: the damped Mathieu equation's period doublings
from scipy's DOP853 monodromy (Liouville's determinant), each nu = 2 row's
orbit closing after two forcing periods (and not after one) under DOP853,
and the Duffing folds of the converged harmonic balance (H = 25).
"""

import json
import signal

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from contin.app.cli import main
from contin.app.runner import run_scene
from contin.output.results import read_csv
from contin.scene.parse import SceneError, parse_scene
from mathieu_reference import damped_mathieu_pd

MATHIEU = """\
model:
  builtin: mathieu
  parameters: {eps: 0.4, c: 0.1, g: 1.0, w: 1.0}
  effects: [damping, parametric, cubic]
analysis:
  type: frequency_response
  parameter: delta
  range: [-0.2, 0.7]
  harmonics: 6
  method: shooting
  shooting: {steps_per_period: 256}
  stability: floquet
  switch: [pd]
  continuation: {ds: 0.02, ds_max: 0.05}
output: {measure: amp_x, plots: false}
"""

DUFFING = """\
model:
  builtin: duffing
  parameters: {m: 1, c: 0.1, k: 1, g: 1, F: 0.5}
  effects: [damping, cubic, forcing]
analysis:
  type: frequency_response
  parameter: w
  range: [2.6, 1.2]
  harmonics: %d
  method: %s
  shooting: {steps_per_period: 256}
  stability: both
output: {measure: amp_x, plots: false}
"""


# ------------------------------------------------------------------ the keys
@pytest.mark.parametrize("change,match", [
    ("  method: rk4\n", r"analysis.method.*one of 'hb', 'shooting', 'auto'"),
    ("  shooting: {segmets: 2}\n", r"analysis.shooting.segmets.*a key among segments, steps_per_period"),
    ("  shooting: {steps_per_period: 3}\n", r"analysis.shooting.steps_per_period.*an integer from 16"),
    ("  shooting: {segments: 0}\n", r"analysis.shooting.segments.*an integer from 1"),
    ("  shooting: {steps_per_period: 256, segments: 3}\n", r"analysis.shooting.segments.*a divisor of"),
    ("  shooting: 12\n", r"analysis.shooting.*a mapping"),
    ("  starts: [{start: 0.5, method: fd}]\n", r"analysis.starts\[0\].method.*one of 'hb', 'shooting', 'auto'"),
    ("  starts: [{start: 0.5, shooting: {steps: 9}}]\n", r"analysis.starts\[0\].shooting.steps"),
])
def test_method_keys_are_checked_naming_the_key(tmp_path, change, match):
    text = MATHIEU.replace("  method: shooting\n  shooting: {steps_per_period: 256}\n", change)
    with pytest.raises(SceneError, match=match):
        run_scene(parse_scene(text), tmp_path / "out", progress=False)


def test_a_guess_of_coefficients_is_refused_with_shooting(tmp_path):
    with pytest.raises(SceneError, match=r"analysis.guess.*no guess with method: shooting"):
        run_scene(parse_scene(MATHIEU.replace("  harmonics: 6\n", "  harmonics: 6\n  guess: [%s]\n" % ", ".join(["0"] * 13))),
                  tmp_path / "out", progress=False)


# ------------------------------------------------------------------ a branch and its switch
@pytest.fixture(scope="module")
def mathieu_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("mathieu")
    summary = run_scene(parse_scene(MATHIEU), out, progress=False)
    return out, summary


def test_shooting_locates_the_flows_period_doublings_and_switches_onto_nu_2(mathieu_run):
    out, s = mathieu_run
    assert s["status"] == "complete"
    branches = s["analysis"]["branches"]
    assert [b["method"] for b in branches] == ["shooting"] * 3 and [b["nu"] for b in branches] == [1, 2, 2]
    sp = read_csv(out / "special_points.csv")
    pds = [float(w) for b, k, w in zip(sp["branch"], sp["kind"], sp["delta"]) if int(b) == 0 and k == "pd"]
    # RK4 with 256 steps a period: its error ~ h^4 on the multipliers
    np.testing.assert_allclose(pds, [damped_mathieu_pd(0.0, 0.2), damped_mathieu_pd(0.3, 0.6)], atol=1e-6)
    rows = read_csv(out / "branches.csv")
    trivial = np.asarray(rows["branch"]) == 0
    assert np.abs(rows["amp_x"][trivial]).max() < 1e-12  # the trivial orbit's columns are zero
    # each branch switched at a pd starts at it
    origins = sorted(b["origin"]["parameter"] for b in branches[1:])
    np.testing.assert_allclose(origins, sorted(pds), atol=1e-12)


def test_a_nu_2_row_is_an_orbit_of_twice_the_period_with_its_columns(mathieu_run):
    out, _ = mathieu_run
    rows = read_csv(out / "branches.csv")
    j = int(np.flatnonzero((np.asarray(rows["nu"]) == 2) & (np.asarray(rows["amp_x"]) > 0.3))[0])
    delta = float(rows["delta"][j])
    # the row's coefficients: h1 is the w/2 component; rebuild the orbit from the state in state.jsonl
    from contin.output.checkpoint import read_records

    u = next(np.asarray(r["u"], float) for r in read_records(out / "state.jsonl")
             if r["type"] == "point" and r["row"] == j)
    z = u[:2]  # the state at t = 0: the first segment's start

    def rhs(t, y):
        return [y[1], -0.1 * y[1] - (delta + 0.4 * np.cos(t)) * y[0] - y[0] ** 3]

    sol = solve_ivp(rhs, (0, 4 * np.pi), z, method="DOP853", rtol=1e-12, atol=1e-13, dense_output=True)
    assert np.abs(sol.y[:, -1] - z).max() < 1e-6 and np.abs(sol.sol(2 * np.pi) - z).max() > 1e-3
    x = sol.sol(np.linspace(0, 4 * np.pi, 4097)[:-1])[0]
    assert float(rows["max_x"][j]) == pytest.approx(x.max(), abs=1e-5)
    assert float(rows["amp_x"][j]) == pytest.approx(0.5 * (x.max() - x.min()), abs=1e-5)
    # the w/2 amplitude of the orbit: its first harmonic of the period-2 orbit
    c = np.fft.rfft(x) / x.size
    assert float(rows["h1_x"][j]) == pytest.approx(2 * abs(c[1]), abs=1e-5)


def test_an_interrupted_shooting_run_resumes_to_the_uninterrupted_one(tmp_path, mathieu_run, monkeypatch):
    from contin.app.progress import Progress

    ref, _ = mathieu_run
    scene = tmp_path / "mathieu.yaml"
    scene.write_text(MATHIEU)
    update, calls = Progress.update, []

    def ctrl_c(self, text, **kwargs):
        calls.append(text)
        if len(calls) == 30:  # inside the first switched branch
            signal.raise_signal(signal.SIGINT)
        update(self, text, **kwargs)

    monkeypatch.setattr(Progress, "update", ctrl_c)
    out = tmp_path / "run"
    assert main(["run", str(scene), "-o", str(out), "-q"]) == 130
    monkeypatch.setattr(Progress, "update", update)
    assert main(["run", str(scene), "-o", str(out), "-q", "--resume"]) == 0
    a, b = read_csv(ref / "branches.csv"), read_csv(out / "branches.csv")
    assert list(a) == list(b) and len(a["branch"]) == len(b["branch"])
    for col in a:
        if a[col].dtype.kind == "f":
            np.testing.assert_allclose(b[col], a[col], rtol=1e-9, atol=1e-12, err_msg=col)
        else:
            np.testing.assert_array_equal(b[col], a[col], err_msg=col)
    sa, sb = read_csv(ref / "special_points.csv"), read_csv(out / "special_points.csv")
    assert list(sa["kind"]) == list(sb["kind"])
    np.testing.assert_allclose(sb["delta"], sa["delta"], rtol=1e-9)
    s = json.loads((out / "summary.json").read_text())
    assert s["status"] == "complete" and [x["points"] for x in s["analysis"]["branches"]] == [23, 20, 25]


@pytest.mark.slow  # two frequency responses over the jump region (~6 s)
def test_shooting_folds_of_duffing_are_those_of_the_converged_harmonic_balance(tmp_path):
    folds = {}
    for method, H in (("shooting", 9), ("hb", 25)):
        out = tmp_path / method
        s = run_scene(parse_scene(DUFFING % (H, method)), out, progress=False)
        assert s["status"] == "complete" and s["analysis"]["branches"][0]["method"] == method
        sp = read_csv(out / "special_points.csv")
        folds[method] = sorted(float(w) for k, w in zip(sp["kind"], sp["w"]) if k == "fold")
    assert len(folds["hb"]) == 2
    np.testing.assert_allclose(folds["shooting"], folds["hb"], rtol=1e-6)


@pytest.mark.parametrize("value, expected", [(3, r"expected a divisor of steps_per_period \(2048\), found 3"),
                                             (0, "expected an integer from 1 to 1024, found 0")])
def test_shooting_segments_are_refused_naming_the_key_once(value, expected):
    from contin.analyses.shooting_rows import ShootingSettings
    from contin.scene.parse import SceneError

    with pytest.raises(SceneError, match=r"analysis\.starts\[0\]\.shooting\.segments: " + expected) as info:
        ShootingSettings.from_dict({"segments": value, "steps_per_period": 2048}, "analysis.starts[0].shooting")
    assert "expected expected" not in str(info.value)
