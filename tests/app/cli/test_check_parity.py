"""`contin check` refuses what `contin run` refuses, with the same message, and `contin run` refuses it before
writing anything.

Each case is a shipped scene with ``--set`` overrides that make it wrong: a physically meaningless value, a
name that Unicode normalisation would merge with another, an output key for a column that does not exist, or
a setting that an analysis used to refuse only after its run had started (continuation and stability
options, start, guess, samples, parameter, measure, ...). Each of them once passed `contin check` and made
`contin run` exit 2 after it had written a ``summary.json`` saying ``running``, or result files.
"""

from pathlib import Path

import pytest

from contin.app.cli import main

ROOT = Path(__file__).resolve().parents[3]
SCENES = ROOT / "scenes"

#: (id, scene, overrides, key named by the message, text of the message)
CASES = [
    # physically meaningless values of built-in models
    ("builtin-negative-mass", "duffing.yaml", ["model.parameters.m=-1"], "model.parameters.m", "a number > 0 (a mass)"),
    ("builtin-zero-mass", "duffing.yaml", ["model.parameters.m=0"], "model.parameters.m", "a number > 0 (a mass)"),
    ("builtin-negative-damping", "duffing.yaml", ["model.parameters.c=-0.1"], "model.parameters.c", ">= 0"),
    ("chain-negative-mass", "two_dof_modes.yaml", ["model.parameters.m2=-2"], "model.parameters.m2", "> 0"),
    ("chain-negative-spring", "two_dof_frf.yaml", ["model.parameters.k3=-2"], "model.parameters.k3", ">= 0"),
    ("rotor-negative-contact-stiffness", "rotor_harmonic.yaml", ["model.parameters.kbn=-1"],
     "model.parameters.kbn", "the contact stiffness"),
    ("rotor-zero-bearing-mass", "rotor_harmonic.yaml", ["model.parameters.beta=0"], "model.parameters.beta", "> 0"),
    ("belt-negative-rotor-mass", "belt_static.yaml", ["model.parameters.beta=-0.2"], "model.parameters.beta",
     ">= 0"),
    # ... of custom models
    ("custom-negative-mass", "gap_oscillator.yaml", ["model.parameters.m=-1"], "model.mass[0][0]",
     "a positive mass on the diagonal"),
    ("custom-zero-mass", "absorber_exercise_frf.yaml", ["model.mass=[[m1, 0], [0, 0]]"], "model.mass[1][1]",
     "a positive mass on the diagonal"),
    ("custom-asymmetric-mass", "absorber_exercise_frf.yaml", ["model.mass=[[m1, 1], [0, m2]]"], "model.mass",
     "a symmetric matrix"),
    ("custom-indefinite-mass", "absorber_exercise_frf.yaml", ["model.mass=[[m1, 50], [50, m2]]"], "model.mass",
     "a positive definite matrix"),
    ("custom-negative-contact-stiffness", "gap_oscillator.yaml", ["model.parameters.kc=-20"],
     "model.forces[0].stiffness", "a contact stiffness >= 0"),
    ("custom-negative-contact-damping", "gap_oscillator.yaml", ["model.forces=[{type: gap, dof: x, clearance: g, "
     "stiffness: kc, damping: -1}]"], "model.forces[0].damping", "a contact damping >= 0"),
    ("custom-negative-frequency", "gap_oscillator.yaml", ["model.parameters.w=-0.5"], "model.parameters.w",
     "the excitation frequency"),
    # a negative frequency in a range
    ("negative-frequency-range", "duffing.yaml", ["analysis.range=[-1, 2]"], "analysis.range",
     "values of w, each a number >= 0"),
    ("negative-frequency-start", "duffing.yaml", ["analysis.range=[2, -1]"], "analysis.range", ">= 0"),
    ("negative-frequency-custom", "custom_duffing.yaml", ["analysis.range=[0.5, -3]"], "analysis.range", ">= 0"),
    ("negative-frequency-of-the-curves", "duffing_fold_curve.yaml", ["analysis.range=[-0.5, 3]"],
     "analysis.range", ">= 0"),
    ("negative-mass-in-a-modes-range", "two_dof_modes.yaml", ["analysis.parameter=m1", "analysis.range=[-1, 1]"],
     "analysis.range", "values of m1, each a number > 0"),
    ("negative-frequency-simulated", "rotor_simulate.yaml", ["analysis.values=[-2.0]"], "analysis.values",
     ">= 0 (the rotor speed)"),
    ("zero-frequency-simulated", "rotor_simulate.yaml", ["analysis.values=[0]"], "analysis.values",
     "a forcing frequency w > 0"),
    ("negative-damping-in-a-static-range", "belt_static.yaml", ["analysis.parameter=zeta",
                                                               "analysis.range=[-1, 1]"], "analysis.range",
     "modal damping ratio"),
    # Unicode look-alikes (the ligature fi, a fullwidth x)
    ("nfkc-parameter", "custom_duffing.yaml", ["model.parameters.ﬁ=1"], "model.parameters.ﬁ",
     "reads as 'fi'"),
    ("nfkc-expression", "custom_duffing.yaml", ['model.forces=[{dof: x, expr: "g*ｘ**3"}]'],
     "model.forces[0].expr", "write 'g*x**3'"),
    ("nfkc-dof", "custom_duffing.yaml", ["model.dofs=[ｘ]"], "model.dofs[0]", "reads as 'x'"),
    ("nfkc-label", "duffing.yaml", ["output.labels={ａｍｐ_x: A}"], "output.labels.ａｍｐ_x", "write 'amp_x'"),
    ("nfkc-parameter-name", "duffing.yaml", ["analysis.parameter=ｗ"], "analysis.parameter", "write 'w'"),
    # output.measure typos and labels or units of columns that do not exist, for every analysis
    ("measure-frequency-response", "duffing.yaml", ["output.measure=ampx"], "output.measure", "amp_x"),
    ("label-frequency-response", "duffing.yaml", ["output.labels={nope: A}"], "output.labels.nope", "a column"),
    ("measure-static", "belt_static.yaml", ["output.measure=ampw"], "output.measure", "amp_w"),
    ("unit-static", "belt_static.yaml", ["output.units={pss: m}"], "output.units.pss", "p_s"),
    ("measure-modes", "two_dof_modes.yaml", ["output.measure=omgea"], "output.measure", "omega"),
    ("label-modes", "two_dof_modes.yaml", ["output.labels={nope: A}"], "output.labels.nope", "a column"),
    ("measure-frf", "two_dof_frf.yaml", ["output.measure=amp_x3"], "output.measure", "amp_x1"),
    ("label-frf", "two_dof_frf.yaml", ["output.labels={W: A}"], "output.labels.W", "a column"),
    ("measure-simulate", "rotor_simulate.yaml", ["output.measure=amp_z1"], "output.measure", "amp_x1"),
    ("label-simulate", "rotor_simulate.yaml", ["output.labels={wrong: A}"], "output.labels.wrong", "a column"),
    ("measure-backbone", "belt_backbone.yaml", ["output.measure=frequncy"], "output.measure", "frequency"),
    ("label-backbone", "belt_backbone.yaml", ["output.labels={amplitdue: A}"], "output.labels.amplitdue",
     "amplitude"),
    ("measure-bifurcation-curve", "duffing_fold_curve.yaml", ["output.measure=amp_y"], "output.measure", "amp_x"),
    ("label-bifurcation-curve", "duffing_fold_curve.yaml", ["output.labels={FF: A}"], "output.labels.FF", "F"),
    ("measure-convergence", "convergence_duffing.yaml", ["output.measure=ampx"], "output.measure", "amp_x"),
    # settings that were refused only after the run had started
    ("static-parameter", "belt_static.yaml", ["analysis.parameter=p_ss"], "analysis.parameter",
     "a parameter of the model"),
    ("static-start", "belt_static.yaml", ["analysis.start=100"], "analysis.start", "inside range"),
    ("static-continuation", "belt_static.yaml", ["analysis.continuation={ds: -1}"], "analysis.continuation",
     "valid continuation options"),
    ("static-measure", "belt_static.yaml", ["analysis.measure=ww"], "analysis.measure",
     "a dof or linear observable"),
    ("backbone-continuation", "belt_backbone.yaml", ["analysis.continuation={stepsize: 1}"],
     "analysis.continuation", "valid continuation options"),
    ("backbone-samples", "belt_backbone.yaml", ["analysis.samples=4"], "analysis", "discretisation"),
    ("backbone-dof", "belt_backbone.yaml", ["analysis.dof=b9"], "analysis.dof", "a backbone the model can have"),
    ("modes-parameter", "two_dof_modes.yaml", ["analysis.parameter=m3", "analysis.values=[1]"],
     "analysis.parameter", "a parameter of the model"),
    ("modes-guess", "two_dof_modes.yaml", ["analysis.guess=[0.0]"], "analysis.guess", "2 numbers"),
    ("modes-reference", "two_dof_modes.yaml", ["analysis.reference=x3"], "analysis.reference", "one of the dofs"),
    ("frf-force", "two_dof_frf.yaml", ["analysis.force=x3"], "analysis.force", "dof names"),
    ("frf-frequency", "two_dof_frf.yaml", ["analysis.frequency=ww"], "analysis.frequency", "a parameter of the model"),
    ("frf-nonlinear-model", "duffing.yaml", ["analysis={type: frf, range: [0, 2]}"], "model", "a linear model"),
    ("simulate-parameter", "rotor_simulate.yaml", ["analysis.parameter=ww"], "analysis.parameter",
     "a parameter of the model"),
    ("simulate-initial", "rotor_simulate.yaml", ["analysis.initial=[0, 0]"], "analysis.initial", "2n = 8 numbers"),
    ("simulate-dofs", "rotor_simulate.yaml", ["analysis.dofs=[x1, z1]"], "analysis.dofs", "names among the dofs"),
    ("simulate-step", "rotor_simulate.yaml", ["analysis.steps_per_period=64", "analysis.samples_per_period=8"],
     "analysis.steps_per_period", "steps per period"),
    ("curve-parameter", "duffing_fold_curve.yaml", ["analysis.parameter=ww"], "analysis.parameter",
     "a parameter of the model"),
    ("curve-second-parameter", "duffing_fold_curve.yaml", ["analysis.second_parameter=FF"],
     "analysis.second_parameter", "a parameter of the model"),
    ("curve-start", "duffing_fold_curve.yaml", ["analysis.start=5"], "analysis.start", "inside range"),
    ("curve-guess", "duffing_fold_curve.yaml", ["analysis.guess=[1, 2]"], "analysis.guess", "3 numbers"),
    ("curve-samples", "duffing_fold_curve.yaml", ["analysis.harmonics=3", "analysis.samples=5"], "analysis",
     "discretisation"),
    ("curve-continuation", "duffing_fold_curve.yaml", ["analysis.continuation={ds_max: -1}"],
     "analysis.continuation", "ds_max"),
    ("curve-curve-continuation", "duffing_fold_curve.yaml", ["analysis.curve_continuation={nope: 1}"],
     "analysis.curve_continuation", "valid ContinuationOptions fields"),
    ("curve-stability-options", "duffing_fold_curve.yaml", ["analysis.stability=hill",
                                                           "analysis.stability_options={nope: 1}"],
     "analysis.stability_options", "valid stability options"),
    ("curve-start-simulation", "duffing_fold_curve.yaml", ["analysis.start_from=simulation",
                                                          "analysis.start_simulation={transients: 10}"],
     "analysis.start_simulation", "transient"),
    ("frequency-response-start-simulation", "duffing.yaml", ["analysis.start_from=simulation",
                                                            "analysis.start_simulation={steps: 10}"],
     "analysis.start_simulation", "steps_per_period"),
    ("frequency-response-stability-options", "duffing.yaml", ["analysis.stability_options={nope: 1}"],
     "analysis.stability_options", "valid stability options"),
    ("frequency-response-continuation", "duffing.yaml", ["analysis.continuation={ds: 0}"],
     "analysis.continuation", "valid continuation options"),
    ("frequency-response-guess", "duffing.yaml", ["analysis.guess=[1]"], "analysis.guess", "19 numbers"),
    ("frequency-response-start", "duffing.yaml", ["analysis.start=5"], "analysis.start", "inside range"),
    ("frequency-response-samples", "duffing.yaml", ["analysis.samples=5"], "analysis", "discretisation"),
    ("frequency-response-parameter", "duffing.yaml", ["analysis.parameter=ww"], "analysis.parameter",
     "a parameter of the model"),
    ("convergence-setting", "convergence_duffing.yaml", ["analysis.base.samples=8"], "analysis.vary",
     "settings the base analysis accepts"),
    ("convergence-quantity-column", "convergence_duffing.yaml",
     ["analysis.quantities=[{type: peak, measure: amp_y}]"], "analysis.quantities[0].measure",
     "a column of branches.csv"),
    ("convergence-quantity-names", "convergence_duffing.yaml",
     ["analysis.quantities=[{type: fold, name: f}, {type: peak, name: f}]"], "analysis.quantities",
     "distinct names"),
]


def _call(argv, capsys) -> tuple[int, str]:
    code = main(argv)
    captured = capsys.readouterr()
    assert "Traceback" not in captured.err
    return code, " ".join(captured.err.split())  # the message as one line (it is wrapped at 100 columns)


def _sets(overrides):
    return [arg for o in overrides for arg in ("--set", o)]


@pytest.mark.parametrize("scene,overrides,key,text", [c[1:] for c in CASES], ids=[c[0] for c in CASES])
def test_check_and_run_refuse_alike_and_run_writes_nothing(tmp_path, capsys, scene, overrides, key, text):
    path = str(SCENES / scene)
    code, checked = _call(["check", path, *_sets(overrides)], capsys)
    assert code == 2, checked
    assert checked.startswith(f"contin: error: {key}") and text in checked, checked
    out = tmp_path / "out"
    code, ran = _call(["run", path, "-o", str(out), "-q", *_sets(overrides)], capsys)
    assert (code, ran) == (2, checked)
    assert not out.exists()


def test_a_refused_run_leaves_an_existing_directory_as_it_was(tmp_path, capsys):
    out = tmp_path / "out"
    out.mkdir()
    (out / "notes.txt").write_text("keep me")
    code, err = _call(["run", str(SCENES / "belt_static.yaml"), "-o", str(out), "-q", "--set",
                       "analysis.measure=ww"], capsys)
    assert code == 2 and "analysis.measure" in err
    assert [p.name for p in out.iterdir()] == ["notes.txt"] and (out / "notes.txt").read_text() == "keep me"
