"""No silent branch jumping: consecutive stored points are connected.

:func:`contin.engine.continuation.connection_report` recomputes, from the problem
alone, the tangent at every stored point and the solution on the hyperplane
through each chord's midpoint; the secant-tangent angle must stay bounded and
the midpoint solution must lie between the two points. Checked on every
example scene with a frequency response (a representative subset runs by
default, all of them with ``-m slow``), on random well-posed polynomial
models (hypothesis), and shown to catch a constructed jump. The same runs' data exports
agree with their tables.
"""

import json
from pathlib import Path

import numpy as np
import pytest
import scipy.io
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from conftest import fuzz_examples

import contin
from contin.analyses.frequency_response import build_problem, engine_problem, start_scenes
from contin.bifurcation.grazing_steps import GRAZING_TURN
from contin.engine.branch import BranchBuilder, BranchStatus
from contin.model.catalog import build_model
from contin.output.checkpoint import read_records, rebuild_branches
from contin.output.exports import coefficient_names
from contin.engine.continuation import connection_report, continuation
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.hb.torus import QuasiPeriodicBalance, TorusOptions
from contin.models.polynomial import polynomial_model
from contin.scene.build import build_model as scene_model
from contin.scene.parse import load_scene
from contin.bifurcation.circle_branch import circle_child_start
from contin.bifurcation.start import integrated_model
from contin.bifurcation.switching import doubled_problem
from contin.timedomain.multiple_shooting import ShootingProblem
from contin.timedomain.shooting_options import ShootingOptions

pytestmark = pytest.mark.hard
ROOT = Path(__file__).resolve().parents[2]
SCENES = sorted(p.name for p in (ROOT / "scenes").glob("*.yaml")
                if (yaml.safe_load(p.read_text()).get("analysis") or {}).get("type") == "frequency_response")
# the default run checks these five (each scene run is shared with tests/cli/test_example_scenes.py); they
# stand in for the rotor, belt and absorber scenes, which are slow (2 to 70 s each with -n 1)
QUICK = {"duffing.yaml", "custom_duffing.yaml", "gap_oscillator.yaml", "mathieu.yaml", "mathieu_duffing_pd.yaml"}


def test_the_report_catches_a_jump_between_sheets():
    hb = HarmonicBalance(build_model("duffing", {"F": 0.5, "c": 0.1}), "w", HBOptions(harmonics=1))
    br = continuation(hb, hb.linear_solution(0.5), 0.5, (0.5, 3.0), parameter_name="w")
    assert connection_report(hb, br)["ok"]
    # splice: the resonant branch up to w = 1.8, then straight onto the non-resonant one beyond 1.8
    w = br.parameter
    turn = int(np.flatnonzero(np.diff(w) < 0)[0])  # the upper fold
    i = int(np.flatnonzero(w[:turn] <= 1.8)[-1])
    low = turn + int(np.flatnonzero(np.diff(w[turn:]) > 0)[0])  # the lower fold
    j = low + int(np.flatnonzero(w[low:] >= 1.8)[0])
    fake = BranchBuilder("w", hb.size)
    for k in list(range(i + 1)) + list(range(j, len(br))):
        fake.append_point(br.unknowns[k], w[k], br.tangents[k], 0.0, 0, 0.0, 0.0)
    fake.finish(BranchStatus.RANGE_END)
    fake.branch.info.update(br.info)
    rep = connection_report(hb, fake.branch)
    assert not rep["ok"]
    assert [f[0] for f in rep["failures"]] == [i]


def scene_branches(name, scene_run):
    out = scene_run(name)  # the run shared with tests/cli/test_example_scenes.py
    scene = load_scene(ROOT / "scenes" / name)
    model = scene_model(scene)
    hb = build_problem(scene, model)
    records = read_records(out / "state.jsonl")
    headers = {r["branch"]: r for r in records if r.get("type") == "branch"}
    branches = rebuild_branches(records, hb.parameter)
    summary = json.loads((out / "summary.json").read_text())["analysis"]["branches"]
    problems = {}
    for j, br in sorted(branches.items()):
        nu = int(br.info["subharmonic"])
        if (br.info.get("torus") or {}).get("circle") and summary[j]["origin"] is None:  # fitted to a simulation
            problems[j] = fitted_circle(scene, model, hb, float(br.parameter[0]))
            yield j, problems[j], br
            continue
        if (br.info.get("torus") or {}).get("circle"):  # an invariant circle: made again by its start, its anchor
            origin = summary[j]["origin"]
            parent = branches[summary[j]["parent"]]
            sp = next(s for s in parent.special_points if s.kind.value == "ns" and s.parameter == origin["parameter"])
            problems[j] = circle_child_start(problems[summary[j]["parent"]], sp.parameter, sp.unknowns,
                                             br.info["torus"]["points"]).problem
            yield j, problems[j], br
            continue
        if headers.get(j, {}).get("method") == "shooting":  # the integrated flow's problem, as followed
            sh = headers[j]["shooting"]
            opts = ShootingOptions(steps_per_period=sh["steps_per_period"], segments=sh["segments"], subharmonic=nu,
                                   start_step=sh.get("start_step", 0))
            base = {k: v for k, v in hb.parameters().items() if k != hb.parameter}
            problems[j] = ShootingProblem(integrated_model(hb), hb.parameter, base, opts)
            yield j, problems[j], br
            continue
        if br.info.get("torus") is not None:  # a quasi-periodic branch: its own problem
            t = br.info["torus"]
            opts = TorusOptions(t["harmonics"], t["harmonics2"], t["samples"], t["samples2"], nu, t["crossings"])
            yield j, QuasiPeriodicBalance(model, hb.parameter, opts, hb.parameters(), hb.frequency,
                                          pin=tuple(t["pin"])), br
            continue
        problem = hb if nu == hb.nu else doubled_problem(hb, nu // hb.nu)
        assert problem.H == br.info["harmonics"]
        # the branches hold the engine's unknowns: those of the condensed problem where it was condensed
        yield j, engine_problem(scene, problem), br


def fitted_circle(scene, model, hb, lam0: float):
    """The circle problem of a ``solution: torus`` start at ``lam0``, fitted again to the same simulation (the
    same anchor) as the run fitted it (contin.analyses.torus_start)."""
    from contin.analyses.shooting_rows import ShootingSettings, shooting_problem
    from contin.analyses.torus_start import circle_from_simulation

    for _, sc in start_scenes(scene):
        a = sc.analysis
        if a.get("solution") == "torus" and a["start"] == lam0:
            settings = ShootingSettings.from_dict(a.get("shooting"), "analysis.shooting")
            return circle_from_simulation(shooting_problem(build_problem(sc, model), settings), a, lam0, hb.H)[0]
    raise AssertionError(f"no torus start at {lam0}")


def natural_steps_connected(name, j, problem, br) -> int:
    """A branch in natural steps (circles at fixed parameter values) has no jump: between two stored circles the
    circle at the midway parameter value (solved from their mean, else from the secant of the steps) has a rotation
    number between theirs; where neither start converges, the step crossed a resonance ``p/q`` (``q <= 12``: a
    tongue a step passes over), or a circle of their mean size with the parameter free joins them (circles of a pass
    of size steps). Neither the arclength report's tangents nor distances between the circles' points
    tell a jump here: at the corners of a contact system's circles the null vectors of ``[R_u R_w]`` turn by up to
    87 degrees against the secants, and the points slide along the circle (on rotor_fig3.yaml the midway circle
    lies up to 1.3 steps from the mean of its neighbours, its rotation number between theirs)."""
    from fractions import Fraction

    from contin.engine.newton import solve_at_parameter
    from contin.engine.options import ContinuationOptions

    opts = ContinuationOptions(newton_tol=1e-8, newton_max_iter=20)
    rho = [float(problem.blocks(u)[1]) for u in br.unknowns]
    for i in range(len(br) - 1):
        la, lb = float(br.parameter[i]), float(br.parameter[i + 1])
        lam, a = 0.5 * (la + lb), br.unknowns[i]
        guesses = [0.5 * (a + br.unknowns[i + 1])]
        if i:
            guesses.append(a + (a - br.unknowns[i - 1]) * (lam - la) / (la - float(br.parameter[i - 1])))
        lo, hi = sorted(rho[i:i + 2])
        margin = 0.1 * (hi - lo) + 1e-9
        found = None
        for guess in guesses:
            r = solve_at_parameter(problem, guess, lam, opts, residual=lambda x, lam=lam: problem.residual(x, lam),
                                   jacobian_at_solution=False)
            if r.converged:
                found = float(problem.blocks(r.x)[1])
                break
        if found is not None and lo - margin <= found <= hi + margin:
            continue
        # across a fold the midway parameter's circle may be the other half's
        if _size_midway(problem, br, i, opts, lo, hi):
            continue
        assert found is None, f"{name} branch {j}: the circle at {lam} turns by {found}, its neighbours by {lo} and {hi}"
        near = [Fraction(p, q) for q in range(1, 13) for p in range(q + 1) if lo <= p / q <= hi]
        assert near, f"{name} branch {j}: no circle at {lam} and no resonance of q <= 12 in [{lo}, {hi}]"
    return len(br) - 1


def _size_midway(problem, br, i, opts, lo, hi) -> bool:
    """Whether circles ``i`` and ``i + 1`` are joined by a circle of their mean size, the parameter free (a pass of
    size steps, contin.bifurcation.circle_fold: at a fold, or along a tongue's edge where no circle exists at the
    midway parameter alone), whose parameter and rotation number lie between theirs."""
    from contin.bifurcation.circle_fold import circle_size, size_step

    a, b = br.unknowns[i], br.unknowns[i + 1]
    la, lb = float(br.parameter[i]), float(br.parameter[i + 1])
    sa, sb = circle_size(problem, a), circle_size(problem, b)
    x = np.r_[a, la]
    r = size_step(problem, x, 0.5 * (sa + sb) / sa - 1.0, 0.5 * (x + np.r_[b, lb]), opts)
    if not r.converged:
        return False
    lam, mid = float(r.x[-1]), float(problem.blocks(r.x[:-1])[1])
    lam_margin = 0.5 * abs(lb - la) + 1e-9  # across a fold the midway circle may lie beyond both
    margin = 0.1 * (hi - lo) + 1e-9
    return min(la, lb) - lam_margin <= lam <= max(la, lb) + lam_margin and lo - margin <= mid <= hi + margin


@pytest.mark.parametrize("name", [pytest.param(n, marks=() if n in QUICK else (pytest.mark.slow, pytest.mark.longest))
                                  for n in SCENES])
def test_example_scene_branches_are_connected(name, scene_run):
    n = 0
    for j, problem, br in scene_branches(name, scene_run):
        assert np.all(np.isfinite(br.unknowns)) and np.all(np.isfinite(br.parameter))
        # a shooting branch steps over grazing corners with turns up to GRAZING_TURN (a 3/2-power point of the
        # flow map), where secant and tangents part by as much: the test then guards against jumps only
        if br.info.get("continuation") == "natural":
            n += natural_steps_connected(name, j, problem, br)
            continue
        turn = GRAZING_TURN + 30.0 if isinstance(problem, ShootingProblem) else 45.0
        rep = connection_report(problem, br, max_angle_deg=turn)
        assert rep["ok"], f"{name} branch {j}: {rep['failures'][:3]}"
        n += rep["checked"]
    assert n > 10


@pytest.mark.parametrize("name", sorted(QUICK))
def test_exports_of_example_runs_agree_with_their_tables(name, scene_run, tmp_path):
    """Brackets in order, one coefficient row per table row, the coefficients' time history giving the
    table's extremes, no NaN in the data files (contin.output.exports)."""
    r = contin.load(scene_run(name))
    for s in r.special_points:
        assert s.interval[0] <= s.interval[1], s
    rows = r.data["coefficient_rows"]
    np.testing.assert_array_equal(rows, np.arange(len(r["branch"])))
    dof = r.dofs[0]
    for row in rows[:: max(1, len(rows) // 7)]:
        _, x, _ = r.time_history(row, samples=4096)
        scale = max(abs(r[f"max_{dof}"][row]), abs(r[f"min_{dof}"][row]), 1e-12)
        assert abs(x[:, 0].max() - r[f"max_{dof}"][row]) < 1e-5 * scale
        assert abs(x[:, 0].min() - r[f"min_{dof}"][row]) < 1e-5 * scale
    copy = r.save(tmp_path / "copy", exports=["npz", "mat"])
    z = np.load(copy / "results.npz")
    assert not any(np.isnan(z[k]).any() for k in z.files if z[k].dtype.kind == "f")
    mat = scipy.io.loadmat(copy / "results.mat", squeeze_me=True, struct_as_record=False)
    np.testing.assert_array_equal(np.atleast_1d(mat["branches"].branch), r["branch"])
    header = (copy / "coefficients.csv").read_text().splitlines()[0].split(",")
    assert header[5:] == coefficient_names(r.dofs, int(z["H"]))


@st.composite
def polynomial_systems(draw):
    """Two coupled hardening oscillators, forced on the first dof."""
    c1, c2 = draw(st.floats(0.02, 0.2)), draw(st.floats(0.02, 0.2))
    k2, kc = draw(st.floats(0.5, 3.0)), draw(st.floats(0.05, 1.0))
    g1, g2 = draw(st.floats(0.0, 2.0)), draw(st.floats(0.0, 2.0))
    F = draw(st.floats(0.05, 0.5))
    return polynomial_model(
        ["x1", "x2"], {"w": 0.3}, [[1, 0], [0, 1]], [[c1, 0], [0, c2]], [[1 + kc, -kc], [-kc, k2 + kc]],
        nonlinear=[{"dof": "x1", "coef": g1, "x": {"x1": 3}}, {"dof": "x2", "coef": g2, "x": {"x2": 3}}],
        forcing=[{"dof": "x1", "amplitude": F}])


@settings(max_examples=fuzz_examples(6), deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
@given(polynomial_systems())
def test_random_polynomial_models_stay_on_their_branch(model):
    hb = HarmonicBalance(model, "w", HBOptions(harmonics=3))
    br = continuation(hb, hb.linear_solution(0.3), 0.3, (0.3, 3.0), {"max_points": 1500}, parameter_name="w")
    assert br.status == BranchStatus.RANGE_END, br.message
    assert np.all(np.isfinite(br.unknowns))
    rep = connection_report(hb, br)
    assert rep["ok"], rep["failures"][:3]
