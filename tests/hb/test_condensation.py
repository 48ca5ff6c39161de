"""Exact condensation of the harmonic balance onto the dofs that carry nonlinear forces.

Truth from outside the condensation: the full harmonic-balance problem solved
on its own, the closed-form receptance of a 2-DOF chain (Cramer's rule on the
2x2 impedance), central finite differences, and the full problem's Hill
multipliers.
"""

import json
import warnings

import numpy as np
import pytest

from contin import ContinWarning
from conftest import fd_jacobian

from contin.model.catalog import build_model
from contin.hb.condensation import CondensedHarmonicBalance, condensation_dofs, condense, nonlinear_dofs
from contin.engine.continuation import ContinuationOptions
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.hb.harmonics import embed
from contin.model.base import ForceElement
from contin.models.polynomial import polynomial_model
from contin.engine.newton import solve_at_parameter
from contin.stability import StabilityOptions, hill_spectrum
from contin.stability.monitor import StabilityMonitor

TIGHT = ContinuationOptions(newton_tol=1e-12, newton_max_iter=30)


def solve(problem, guess, lam):
    res = solve_at_parameter(problem, guess, lam, TIGHT)
    assert res.converged, res.message
    return res.x


def two_dof_cubic(g=2.0):
    """Two masses in a chain, a cubic spring on the second one, the force on the first."""
    params = {"k": 1.0, "c": 0.05, "g": g, "F": 1.0, "w": 1.2}
    return polynomial_model(
        ["x1", "x2"], params, mass=[[1, 0], [0, 2]], damping=[["2*c", "-c"], ["-c", "c"]],
        stiffness=[["2*k", "-k"], ["-k", "k"]], nonlinear=[{"dof": "x2", "coef": "g", "x": {"x2": 3}}],
        forcing=[{"dof": "x1", "amplitude": "F"}])


# ------------------------------------------------------------------ (a) small systems
@pytest.mark.parametrize("param, lam", [("w", 1.2), ("F", 1.0), ("k", 1.0)])
def test_condensed_solution_of_a_cubic_2dof_is_the_full_one(param, lam):
    hb = HarmonicBalance(two_dof_cubic(), param, HBOptions(harmonics=5))
    ch = condense(hb)
    assert isinstance(ch, CondensedHarmonicBalance) and list(ch.dofs) == [1] and ch.size == 11
    u_full = solve(hb, hb.linear_solution(lam), lam)
    u_c = solve(ch, ch.linear_solution(lam), lam)
    np.testing.assert_allclose(ch.expand(u_c, lam), u_full, rtol=0, atol=1e-10 * np.abs(u_full).max())
    assert np.abs(u_full.reshape(-1, 2)[3:, 1]).max() > 1e-4  # the cubic spring makes odd harmonics
    R, Ju, Jlam = ch.linearize(u_c, lam)
    np.testing.assert_allclose(Ju, fd_jacobian(lambda v: ch.residual(v, lam), u_c), atol=1e-7 * np.abs(Ju).max())
    h = 1e-6 * max(1.0, abs(lam))
    fd = (ch.residual(u_c, lam + h) - ch.residual(u_c, lam - h)) / (2 * h)
    np.testing.assert_allclose(Jlam, fd, atol=1e-7 * max(1.0, np.abs(Jlam).max()))


@pytest.mark.parametrize("kept", [[0], [1]])
def test_linear_chain_condensed_gives_the_closed_form_receptance(kept):
    p = {"m1": 1.0, "m2": 2.0, "k1": 1.0, "k2": 0.5, "k3": 2.0, "c1": 0.02, "c2": 0.05, "c3": 0.01,
         "F1": 0.7, "w": 0.9}
    hb = HarmonicBalance(build_model("linear_chain", p), "w", HBOptions(harmonics=2))
    assert condense(hb) is hb  # no nonlinear force: nothing to condense onto
    ch = CondensedHarmonicBalance(hb, kept)
    w = 1.3
    u = ch.expand(solve(ch, np.zeros(ch.size), w), w).reshape(-1, 2)
    # x = Re(X e^{iwt}) with Z X = (F1, 0), Z the 2x2 impedance (Cramer's rule)
    z11 = p["k1"] + p["k2"] - p["m1"] * w**2 + 1j * w * (p["c1"] + p["c2"])
    z22 = p["k2"] + p["k3"] - p["m2"] * w**2 + 1j * w * (p["c2"] + p["c3"])
    z12 = -p["k2"] - 1j * w * p["c2"]
    det = z11 * z22 - z12 * z12
    X = np.array([z22, -z12]) * p["F1"] / det
    np.testing.assert_allclose(u[1], X.real, atol=1e-12)
    np.testing.assert_allclose(u[2], -X.imag, atol=1e-12)
    np.testing.assert_allclose(u[[0, 3, 4]], 0.0, atol=1e-14)


# ------------------------------------------------------------------ (b) bearing rotor
@pytest.fixture(scope="module", params=["interval", "exact"])
def rotor_nu1(request):
    from contin.bifurcation.start import homotopy_start

    hb = HarmonicBalance(build_model("bearing_rotor", {"w": 2.0}), "w",
                         HBOptions(harmonics=10, samples=256, crossings=request.param))
    guess = np.zeros(hb.size)
    guess[:4] = [0.0, 0.5, 0.0, 0.2]  # disc and bearing pushed along the static force f0
    return hb, homotopy_start(hb, 2.0, "kbn", 20.0, guess)


@pytest.fixture(scope="module")
def rotor_nu2():
    from contin.bifurcation.start import simulation_start

    hb = HarmonicBalance(build_model("bearing_rotor", {"f0": 0.5}), "w",
                         HBOptions(harmonics=20, subharmonic=2, samples=512, crossings="interval"))
    w = 2.16  # inside the stable 1/2-subharmonic range: the simulation is entrained
    u = simulation_start(hb, w, transient=600, steps_per_period=1024)
    assert np.abs(u.reshape(-1, 4)[1:3]).max() > 0.1  # the +-w/2 components: a genuine subharmonic
    return hb, u, w


def check_rotor(hb, u, w, rng):
    ch = condense(hb)
    assert list(ch.dofs) == [2, 3] and ch.size * 2 == hb.size  # the bearing's x2, y2
    # Newton on the condensed problem from a perturbed restriction lands on the full solution
    u_c = solve(ch, ch.restrict(u) + 1e-6 * rng.normal(size=ch.size), w)
    np.testing.assert_allclose(ch.expand(u_c, w), u, rtol=0, atol=1e-9)
    # the Jacobians against central differences of the condensed residual, off the solution too
    for v in (u_c, u_c + 1e-3 * rng.normal(size=ch.size)):
        R, Ju, Jlam = ch.linearize(v, w)
        np.testing.assert_allclose(R, ch.residual(v, w), rtol=0, atol=1e-12 * max(1.0, np.abs(R).max()))
        np.testing.assert_allclose(Ju, fd_jacobian(lambda x: ch.residual(x, w), v, 1e-8),
                                   rtol=0, atol=2e-6 * np.abs(Ju).max())
        h = 1e-7
        fd = (ch.residual(v, w + h) - ch.residual(v, w - h)) / (2 * h)
        np.testing.assert_allclose(Jlam, fd, rtol=0, atol=2e-6 * np.abs(Jlam).max())
    return ch, u_c


def test_rotor_nu1_condensed_equals_full(rotor_nu1, rng):
    hb, u = rotor_nu1
    check_rotor(hb, u, 2.0, rng)


@pytest.mark.slow  # by default the rotor's nu = 1 problem and its doubled embedding are checked
def test_rotor_nu2_condensed_equals_full(rotor_nu2, rng):
    hb, u, w = rotor_nu2
    ch, u_c = check_rotor(hb, u, w, rng)
    # the full problem's Hill multipliers, whichever problem is passed
    ref = hill_spectrum(hb, u, w)
    got = hill_spectrum(ch, u_c, w)
    np.testing.assert_allclose(np.sort_complex(got.multipliers), np.sort_complex(ref.multipliers), atol=1e-9)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ContinWarning)  # Hill beside a contact switch: compared, not trusted
        got = StabilityMonitor(ch, StabilityOptions(method="hill"))(u_c, w)
        ref = StabilityMonitor(hb, StabilityOptions(method="hill"))(u, w)
    np.testing.assert_allclose(got["max_multiplier"], ref["max_multiplier"], rtol=1e-9)
    assert got["n_unstable"] == ref["n_unstable"]


def test_doubled_condensed_problem_embeds_consistently(rotor_nu1):
    hb, u = rotor_nu1
    ch = condense(hb)
    ch2 = ch.with_options(subharmonic=2, harmonics=2 * hb.H, samples=2 * hb.N)
    assert isinstance(ch2, CondensedHarmonicBalance) and ch2.nu == 2 and list(ch2.dofs) == list(ch.dofs)
    u2 = embed(ch.restrict(u), ch.n, 2, ch2.H)
    np.testing.assert_allclose(ch2.expand(u2, 2.0), embed(u, hb.n, 2, ch2.H), atol=1e-12)
    assert np.abs(ch2.residual(u2, 2.0)).max() < 1e-8


# ------------------------------------------------------------------ (c) the expansion's derivative
@pytest.mark.parametrize("param", ["w", "f0", "ip"])
def test_expand_direction_is_the_derivative_of_expand(param, rng):
    model = build_model("bearing_rotor", {"w": 2.1})
    hb = HarmonicBalance(model, param, HBOptions(harmonics=6, subharmonic=2, samples=64))
    ch = condense(hb)
    lam = float(hb.p0[hb.k])
    u, du = rng.normal(size=ch.size), rng.normal(size=ch.size)
    for dlam in (0.0, 0.7):
        h = 1e-6
        fd = (ch.expand(u + h * du, lam + h * dlam) - ch.expand(u - h * du, lam - h * dlam)) / (2 * h)
        got = ch.expand_direction(u, lam, du, dlam)
        np.testing.assert_allclose(got, fd, rtol=0, atol=1e-7 * np.abs(fd).max())
        np.testing.assert_array_equal(ch.restrict(got), du)


# ------------------------------------------------------------------ (d) what is condensed, and refusals
def test_condense_keeps_every_dof_that_carries_a_force():
    coupled = polynomial_model(["x", "y"], {"w": 1.0}, mass=[[1, 0], [0, 1]], stiffness=[[1, 0], [0, 2]],
                               nonlinear=[{"dof": "x", "coef": 0.1, "x": {"y": 2}}], forcing=[{"dof": "x"}])
    hb = HarmonicBalance(coupled, "w", HBOptions(harmonics=3))
    assert nonlinear_dofs(coupled) == ((0, 1), "")  # acts on x, depends on y
    assert condense(hb) is hb
    with pytest.raises(ValueError, match="every dof carries a nonlinear force"):
        condense(hb, require=True)
    duffing = HarmonicBalance(build_model("duffing"), "w", HBOptions(harmonics=3))
    assert condense(duffing) is duffing
    with pytest.raises(ValueError, match="must be kept"):
        CondensedHarmonicBalance(HarmonicBalance(two_dof_cubic(), "w", HBOptions(harmonics=3)), [0])


def test_an_element_that_cannot_tell_its_dofs_prevents_condensation():
    class Opaque(ForceElement):
        kind = "opaque"
        degree = 3

        def evaluate(self, x, xd, tau, p, f, dfdx, dfdxd):
            f[:, 1] += x[:, 1] ** 3
            dfdx[:, 1, 1] += 3 * x[:, 1] ** 2

        def evaluate_dp(self, x, xd, tau, p, k, dfdp):
            pass

        def depends_on(self, k):
            return False

    model = two_dof_cubic()
    model.forces = [Opaque()]
    hb = HarmonicBalance(model, "w", HBOptions(harmonics=3))
    assert condense(hb) is hb
    with pytest.raises(ValueError, match="'opaque' does not tell which dofs"):
        condense(hb, require=True)
    with pytest.raises(ValueError, match="cannot eliminate"):
        CondensedHarmonicBalance(hb, [1])


def test_auto_keeps_undamped_linear_dofs_that_could_resonate():
    model = two_dof_cubic()
    hb = HarmonicBalance(model, "w", HBOptions(harmonics=3), {"c": 0.0})
    kept, why = condensation_dofs(hb)
    assert kept is None and "damping of the linear dofs ['x1']" in why
    assert condense(hb) is hb
    assert isinstance(condense(hb, require=True), CondensedHarmonicBalance)


def test_element_dofs_cover_where_forces_act(rng):
    """Each built-in element's declared dofs hold every nonzero entry of its force and Jacobians."""
    models = [build_model("bearing_rotor"), build_model("timing_belt"), two_dof_cubic(),
              build_model("mathieu"), build_model("duffing")]
    for model in models:
        for el in model.forces:
            d = el.active_dofs()
            assert d is not None, el.kind
            other = [i for i in range(model.n_dof) if i not in d]
            N, n = 64, model.n_dof
            x, xd = rng.normal(size=(N, n)), rng.normal(size=(N, n))
            f, fx, fv = np.zeros((N, n)), np.zeros((N, n, n)), np.zeros((N, n, n))
            el.evaluate(x, xd, np.linspace(0, 2 * np.pi, N), model.parameter_vector(), f, fx, fv)
            assert np.all(f[:, other] == 0) and np.all(fx[:, other] == 0) and np.all(fx[:, :, other] == 0)
            assert np.all(fv[:, other] == 0) and np.all(fv[:, :, other] == 0)


# ------------------------------------------------------------------ scenes
SCENE = """
model:
  dofs: [x1, x2]
  parameters: {k: 1, c: 0.05, g: 2, F: 0.1, w: 0.3}
  mass: [[1, 0], [0, 2]]
  damping: [[2*c, -c], [-c, c]]
  stiffness: [[2*k, -k], [-k, k]]
  forces:
    - {dof: x2, expr: "g*x2**3"}
  excitation:
    - {dof: x1, expr: "F*cos(tau)"}
analysis:
  type: frequency_response
  parameter: w
  range: [0.3, 1.2]
  harmonics: 3
  stability: hill
  continuation: {ds: 0.2, ds_max: 0.5}
output:
  plots: false
"""


def test_scene_key_condense(tmp_path):
    from contin.app.cli import main
    from contin.output.results import read_csv

    path = tmp_path / "s.yaml"
    path.write_text(SCENE)
    assert main(["run", str(path), "-o", str(tmp_path / "bad"), "-q", "--set", "analysis.condense=maybe"]) == 2
    out = {}
    for how in ("true", "false"):
        o = tmp_path / how
        assert main(["run", str(path), "-o", str(o), "-q", "--set", f"analysis.condense={how}"]) == 0
        out[how] = (read_csv(o / "branches.csv"), read_csv(o / "special_points.csv"), o)
    summary = json.loads((out["true"][2] / "summary.json").read_text())["analysis"]["condensation"]
    assert summary == {"condensed": True, "dofs": ["x2"], "unknowns": 7, "full_unknowns": 14}
    (rt, st, ot), (_, sf, _) = out["true"], out["false"]
    assert list(st["kind"]) == list(sf["kind"])
    assert "fold" in list(st["kind"])  # the hardening spring bends the first resonance over
    np.testing.assert_allclose(st["w"], sf["w"], atol=1e-8)
    np.testing.assert_allclose(st["amp_x1"], sf["amp_x1"], atol=1e-8)
    # the checkpoint holds the kept dofs' coefficients; expanded, they solve the full problem, with the rows' measures
    from contin.analyses.frequency_response import build_problem
    from contin.hb.measures import point_measures
    from contin.scene.build import build_model as scene_model
    from contin.scene.parse import load_scene

    scene = load_scene(str(path), [])
    model = scene_model(scene)
    hb = build_problem(scene, model)
    from contin.output.checkpoint import read_records

    from contin.output.expansion import StoredExpansion

    rec = read_records(ot / "state.jsonl")  # the arrays read back from state.bin
    headers = [r for r in rec if r["type"] == "branch"]
    assert [r["dofs"] for r in headers] == [[1]] and headers[0]["unknowns"] == "engine"
    points = [r for r in rec if r.get("type", "point") == "point"]
    assert len(points) == len(rt["w"])
    expand = StoredExpansion(hb)
    for r in points:
        assert np.asarray(r["u"]).size == hb.size // 2  # x2's coefficients: half the bytes
        u = expand(headers[0], r["u"], r["lam"])
        assert u.size == hb.size and np.abs(hb.residual(u, r["lam"])).max() < 1e-9
        m = point_measures(u, 2, list(model.dof_names), 5)
        assert abs(m["amp_x1"] - rt["amp_x1"][r["row"]]) < 1e-12


def test_condense_true_without_linear_dofs_is_a_scene_error(tmp_path):
    from contin.app.cli import main

    path = tmp_path / "s.yaml"
    path.write_text(SCENE.replace('- {dof: x2, expr: "g*x2**3"}', '- {dof: x2, expr: "g*x2**3 + g*x1**3"}'))
    assert main(["check", str(path), "--set", "analysis.condense=true"]) == 2
    assert main(["check", str(path)]) == 0


# ------------------------------------------------------------------ switching through the condensed problem
def mathieu_with_absorber():
    """x'' + c x' + (delta + eps cos t) x + g x^3 with a damped linear absorber y: PD on the trivial branch."""
    params = {"c": 0.1, "eps": 0.4, "g": 1.0, "delta": -0.2, "ka": 0.05, "ca": 0.02, "w": 1.0}
    return polynomial_model(
        ["x", "y"], params, mass=[[1, 0], [0, 0.5]], damping=[["c", 0], [0, "ca"]],
        stiffness=[["ka", "-ka"], ["-ka", "ka"]],
        nonlinear=[{"dof": "x", "coef": "delta", "x": {"x": 1}},
                   {"dof": "x", "coef": "eps", "x": {"x": 1}, "order": 1},
                   {"dof": "x", "coef": "g", "x": {"x": 3}}])


def test_period_doubling_switch_through_the_condensed_problem():
    from contin.bifurcation.diagram import follow
    from contin.bifurcation.switching import switch_at

    model = mathieu_with_absorber()
    hb = HarmonicBalance(model, "delta", HBOptions(harmonics=5))
    ch = condense(hb)
    assert list(ch.dofs) == [0]
    opts = ContinuationOptions(ds=0.02, ds_max=0.05, newton_tol=1e-12)
    kw = dict(stability=StabilityOptions(method="hill"), switch=("pd",))
    full = follow(hb, np.zeros(hb.size), -0.2, (-0.2, 0.45), opts, **kw)
    cond = follow(ch, np.zeros(ch.size), -0.2, (-0.2, 0.45), opts, **kw)
    pf, pc = full[0].points_of_kind("pd"), cond[0].points_of_kind("pd")
    assert len(pf) == len(pc) >= 1
    for a, b in zip(pf, pc):
        assert abs(a.parameter - b.parameter) < 1e-8
    assert len(full) == len(cond) >= 2
    for i in range(1, len(full)):
        fa, ca_ = full[i], cond[i]
        p2 = cond.problems[i]
        assert isinstance(p2, CondensedHarmonicBalance) and p2.nu == 2
        u_full = p2.expand(ca_.unknowns[0], ca_.parameter[0])
        # the first points need not be the same point of the branch: compare at the full first point's delta
        v = solve(p2, p2.restrict(fa.unknowns[0]), fa.parameter[0])
        np.testing.assert_allclose(p2.expand(v, fa.parameter[0]), fa.unknowns[0], atol=1e-9)
        assert np.abs(u_full.reshape(-1, 2)[1:3]).max() > 1e-3  # a half-order component
    # Hill's direction, restricted, gives the same first point as the SVD of the condensed odd block
    sp = pc[0]
    a = switch_at(ch, cond[0], sp, options=opts, pd_direction="svd")[0]
    b = switch_at(ch, cond[0], sp, options=opts, pd_direction="hill")[0]
    assert min(np.abs(a.u - b.u).max(), np.abs(a.u + b.u).max()) < 1e-8 and abs(a.lam - b.lam) < 1e-9
