"""Custom scene models: equivalence with built-in models, analytic Jacobians, closed forms, bad input, cache."""

import math
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from contin import ContinWarning
from conftest import fd_jacobian

from contin.model import codegen
from contin.model.catalog import build_model as build_builtin
from contin.scene.custom_model import build_custom_model, check_continuation_parameter
from contin.model.elements.expression import ExpressionCoefficient, ExpressionForce
from contin.model.elements.expression_excitation import ExpressionExcitation
from contin.model.elements.gap import GapForce
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.model.base import FORCE_ELEMENTS, EXCITATION_ELEMENTS, Monomial
from contin.scene.build import build_model
from contin.scene.parse import SceneError, load_scene, parse_scene

ROOT = Path(__file__).resolve().parents[2]

ANALYSIS = """
analysis:
  type: frequency_response
  parameter: w
  range: [0.5, 3.0]
  harmonics: 3
  stability: none
"""


def scene(model_yaml: str, analysis: str = ANALYSIS):
    return parse_scene(textwrap.dedent(model_yaml) + textwrap.dedent(analysis))


def custom(model_yaml: str, analysis: str = ANALYSIS):
    return build_model(scene(model_yaml, analysis))


RICH = """
model:
  dofs: [x, y]
  parameters: {m: 1.2, c: 0.05, k: 1.0, kc: 0.3, g: 0.8, mu: 0.2, d: 0.15, eps: 0.1, ip: 0.05,
               F: "0.1*w**2", G2: "F*mu + 1", w: 1.3}
  mass: [[m, 0], [0, "2*m"]]
  damping: [[c, 0], [0, "c*(1 + 0.5*mu)"]]
  stiffness: [["k*(1 + 0.1*w)", -kc], [-kc, "k + sqrt(kc)"]]
  gyroscopic: {matrix: [[0, 1], [-1, 0]], speed: "ip*w"}
  forces:
    - {dof: x, expr: "g*x**3 + d*abs(x_dot)*x_dot + eps*cos(2*tau)*x"}
    - {dof: y, expr: "mu*(y**2 - 1)*y_dot + G2*tanh(x - y) + 0.1*exp(0.2*x)*sin(y)"}
    - {dof: x, expr: "0.05*min(x, y)*max(y_dot, 0.3)/(1 + x**2)"}
  excitation:
    - {dof: x, expr: "F*cos(tau) + 0.2*mu*sin(2*tau)"}
    - {dof: y, amplitude: "0.3*F", order: 1, phase: 0.4}
    - {dof: y, constant: "0.1*mu"}
"""


# ---------------------------------------------------------------- equivalence
@pytest.mark.slow  # the custom Duffing scene against the built-in: test_custom_duffing_scene_runs_like_the_builtin
def test_custom_duffing_equals_builtin_duffing(rng):
    mc = build_model(load_scene(ROOT / "scenes/custom_duffing.yaml"))
    mb = build_builtin("duffing")
    assert mc.param_names == mb.param_names
    assert mc.degree == 3  # polynomial: the exact default sample count 4H+1
    for param in ("w", "g", "F", "c"):
        hc = HarmonicBalance(mc, param, HBOptions(harmonics=5))
        hbb = HarmonicBalance(mb, param, HBOptions(harmonics=5))
        assert hc.N == hbb.N == 21
        for _ in range(3):
            u = 0.5 * rng.normal(size=hc.size)
            lam = hc.p0[hc.k] * (0.7 + 0.6 * rng.random())
            Rc, Jc, Lc = hc.linearize(u, lam)
            Rb, Jb, Lb = hbb.linearize(u, lam)
            np.testing.assert_allclose(Rc, Rb, rtol=1e-12, atol=1e-12)
            np.testing.assert_allclose(Jc, Jb, rtol=1e-12, atol=1e-12)
            np.testing.assert_allclose(Lc, Lb, rtol=1e-12, atol=1e-12)
            np.testing.assert_allclose(hc.residual(u, lam), Rb, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("param", ["w", "mu", "k", "F", "ip", "m"])
def test_rich_custom_model_jacobians_match_finite_differences(param, rng):
    if param == "F":
        with pytest.raises(SceneError, match=r"analysis.parameter.*independent parameter.*'F' is defined as"):
            custom(RICH, ANALYSIS.replace("parameter: w", "parameter: F"))
        return
    model = custom(RICH)
    assert "F" not in model.parameters and set(model.dependent_parameters) == {"F", "G2"}
    hb = HarmonicBalance(model, param, HBOptions(harmonics=3, samples=64))
    u = 0.4 * rng.normal(size=hb.size)
    lam = hb.p0[hb.k] * 1.1
    R, Ju, Jlam = hb.linearize(u, lam)
    np.testing.assert_allclose(R, hb.residual(u, lam), atol=1e-14)
    Jfd = fd_jacobian(lambda v: hb.residual(v, lam), u)
    assert np.abs(Ju - Jfd).max() <= 2e-6 * np.abs(Ju).max()
    Jlam_fd = fd_jacobian(lambda l: hb.residual(u, l[0]), np.array([lam]))[:, 0]
    assert np.abs(Jlam - Jlam_fd).max() <= 2e-6 * max(np.abs(Jlam).max(), 1e-12)


def test_dependent_parameter_follows_the_independent_ones():
    model = custom(RICH)
    p = model.parameter_vector({"w": 2.0, "mu": 0.5})
    assert model.dependent_parameters["F"].value(p) == pytest.approx(0.4)
    assert model.dependent_parameters["G2"].value(p) == pytest.approx(0.4 * 0.5 + 1)
    # the excitation sees F = 0.1 w^2 at every w
    hb = HarmonicBalance(model, "w", HBOptions(harmonics=3, samples=64))
    for w in (1.0, 2.0):
        fext, _ = hb.excitation(hb.params_at(w))
        assert fext[2] == pytest.approx(0.1 * w**2)  # cos 1 coefficient of x (block 1, dof 0)


def test_expression_force_matches_numpy_reference(rng):
    """The generated kernel against the safe evaluator, sample by sample."""
    from contin.model import expressions as ex

    dofs, params = ["x", "y"], ["a", "b"]
    texts = {0: "a*x**3 + b*abs(x_dot)*x_dot + sin(x - y)*cos(3*tau)", 1: "min(x, y) + sqrt(b)*exp(-y**2)*y_dot"}
    force = ExpressionForce(dofs, params, list(texts.items()))
    N = 17
    x, xd = rng.normal(size=(N, 2)), rng.normal(size=(N, 2))
    tau = rng.uniform(0, 2 * np.pi, N)
    p = np.array([0.7, 1.3])
    f, J, Jd = np.zeros((N, 2)), np.zeros((N, 2, 2)), np.zeros((N, 2, 2))
    force.evaluate(x, xd, tau, p, f, J, Jd)
    env = {"x": x[:, 0], "y": x[:, 1], "x_dot": xd[:, 0], "y_dot": xd[:, 1], "tau": tau, "a": p[0], "b": p[1]}
    for i, t in texts.items():
        node = ex.parse(t)
        np.testing.assert_allclose(f[:, i], ex.evaluate(node, env), rtol=1e-13)
        for j, name in enumerate(dofs):
            np.testing.assert_allclose(J[:, i, j], np.broadcast_to(ex.evaluate(ex.diff(node, name), env), N), rtol=1e-12)
            np.testing.assert_allclose(Jd[:, i, j], np.broadcast_to(ex.evaluate(ex.diff(node, name + "_dot"), env), N),
                                       rtol=1e-12)
    for k in range(2):
        assert force.depends_on(k)
        dp = np.zeros((N, 2))
        force.evaluate_dp(x, xd, tau, p, k, dp)
        for i, t in texts.items():
            ref = np.broadcast_to(ex.evaluate(ex.diff(ex.parse(t), params[k]), env), N)
            np.testing.assert_allclose(dp[:, i], ref, rtol=1e-12, atol=1e-15)
    assert force.tau_orders() == (3.0,)
    assert force.degree is None
    assert "a*x**3" in force.describe()


def test_element_kinds_are_registered():
    assert FORCE_ELEMENTS["expr"] is ExpressionForce
    assert EXCITATION_ELEMENTS["expr"] is ExpressionExcitation


def test_build_custom_model_is_what_the_runner_calls():
    sc = load_scene(ROOT / "scenes/custom_duffing.yaml")
    model = build_custom_model(sc)
    assert model.name == "custom_duffing" and model.param_names == ("m", "c", "k", "g", "F", "w")
    assert model.effects == ("mass", "damping", "stiffness", "expr", "excitation")
    assert [type(f) for f in model.forces] == [ExpressionForce]


def test_model_description_lists_the_terms():
    model = custom(RICH)
    text = model.describe()
    assert "mass: M (2x2, entries in m" in text
    assert "stiffness: K (2x2, entries in k, kc, w" in text
    assert "gyroscopic: (ip*w)*G" in text
    assert "dependent parameters: F = 0.1*w**2" in text
    assert "g*x**3" in text and "F*cos(tau)" not in text  # excitation shown with F inlined
    assert "0.1*w**2*cos(tau)" in text
    assert model.effects[:3] == ("mass", "damping", "stiffness")


def test_monomial_entries_stay_monomials():
    model = custom("""
    model:
      dofs: [x]
      parameters: {m: 2, k: 3, w: 1, q: "k/m"}
      mass: [[m]]
      stiffness: [["-0.5*k*w**2"]]
      damping: [[q]]
    """)
    (mono, _), = model.stiffness.terms
    assert isinstance(mono, Monomial) and mono.const == -0.5
    (coef, _), = model.damping.terms
    assert isinstance(coef, ExpressionCoefficient)  # k/m has a negative power
    p = model.parameter_vector()
    assert coef.value(p) == 1.5 and coef.derivative(p, model.parameter_index("m")) == pytest.approx(-0.75)


def test_polynomial_degree_and_tau_orders_choose_samples():
    m = custom("""
    model:
      dofs: [x]
      parameters: {w: 1, e: 0.2}
      mass: [[1]]
      stiffness: [[1]]
      forces:
        - {dof: x, expr: "x**2*x_dot + e*cos(2*tau)*x"}
    """)
    (force,) = m.forces
    assert force.tau_orders() == (2.0,)
    assert force.degree == 4  # cubic, plus one for the cos(2 tau) coefficient
    half = custom("""
    model:
      dofs: [x]
      parameters: {w: 1}
      mass: [[1]]
      forces: [{dof: x, expr: "cos(0.5*tau)*x"}]
    """)
    with pytest.raises(ValueError, match="not periodic"):
        HarmonicBalance(half, "w", HBOptions(harmonics=3))
    HarmonicBalance(half, "w", HBOptions(harmonics=3, subharmonic=2))


# ---------------------------------------------------------------- closed form: gap
def dead_zone_stiffness(A, g, kc):
    """First-harmonic stiffness of kc*(|x| - g)*sign(x) beyond |x| > g, for x = A cos(theta)."""
    r = g / A
    return kc * (1.0 - (2.0 / math.pi) * (math.asin(r) + r * math.sqrt(1.0 - r * r)))


GAP = """
model:
  dofs: [x]
  parameters: {m: 1, c: 0.05, k: 1, g: 1, kc: 20, F: 0.2, w: 0.5}
  mass: [[m]]
  damping: [[c]]
  stiffness: [[k]]
  forces:
    - {type: gap, dof: x, clearance: g, stiffness: kc, damping: 0, sides: SIDES}
  excitation:
    - {dof: x, amplitude: F, order: 1}
"""


@pytest.mark.parametrize("A", [1.05, 1.5, 3.0, 10.0])
def test_gap_oscillator_first_harmonic_matches_describing_function(A):
    """H = 1: R = [mean, (k - w^2 m + k_eq(A)) A - F, -c w A] with the dead-zone describing function."""
    g, kc, c, F = 1.0, 20.0, 0.05, 0.2
    for sides, N in (("both", 256), ("both", 4096), ("'+'", 4096)):
        model = custom(GAP.replace("SIDES", sides))
        hb = HarmonicBalance(model, "w", HBOptions(harmonics=1, samples=N))
        for w in (0.7, 2.0):
            R = hb.residual(np.array([0.0, A, 0.0]), w)
            keq = dead_zone_stiffness(A, g, kc)
            if sides == "both":
                mean = 0.0
            else:  # one stop: half the first harmonic, plus a mean push
                keq *= 0.5
                th0 = math.acos(g / A)
                mean = kc / math.pi * (A * math.sin(th0) - g * th0)
            expected = np.array([mean, (1.0 - w * w + keq) * A - F, -c * w * A])
            # sampling a force with kinks (at the contact onsets): error O(kc A / N^2), about 1.2 kc A / N^2 here
            np.testing.assert_allclose(R, expected, atol=3 * kc * A / N**2 + 1e-12)


def test_gap_element_and_equivalent_expression_agree(rng):
    model_gap = custom(GAP.replace("SIDES", "both"))
    model_expr = custom(GAP.replace("{type: gap, dof: x, clearance: g, stiffness: kc, damping: 0, sides: SIDES}",
                                    '{dof: x, expr: "kc*max(abs(x) - g, 0)*sign(x)"}'))
    assert isinstance(model_gap.forces[0], GapForce) and model_expr.degree is None
    # both sampled alike (an expression force has no switching data, so its contact is not integrated exactly)
    h1 = HarmonicBalance(model_gap, "kc", HBOptions(harmonics=5, samples=512, crossings="none"))
    h2 = HarmonicBalance(model_expr, "kc", HBOptions(harmonics=5, samples=512))
    u = 1.5 * rng.normal(size=h1.size)
    for a, b in zip(h1.linearize(u, 20.0), h2.linearize(u, 20.0)):
        np.testing.assert_allclose(a, b, rtol=1e-11, atol=1e-11)


def test_radial_gap_and_gyroscopic_scene_builds():
    model = custom("""
    model:
      dofs: [x, y]
      parameters: {w: 1.5, ip: 0.1, delta: "0.1", kbn: 1000, cbn: 0.5}
      mass: [[1, 0], [0, 1]]
      stiffness: [[1, 0], [0, 1]]
      gyroscopic: {matrix: [[0, 1], [-1, 0]], speed: w}
      forces:
        - {type: radial_gap, dofs: [x, y], clearance: delta, stiffness: kbn, damping: cbn, clip: true}
      excitation:
        - {dof: x, amplitude: "0.5*w**2"}
        - {dof: y, amplitude: "0.5*w**2", phase: -1.5707963267948966}
    """)
    assert model.parameters["delta"] == 0.1  # a constant expression is an independent parameter
    p = model.parameter_vector()
    C = model.damping.value(p)
    np.testing.assert_allclose(C, [[0, 1.5], [-1.5, 0]])
    np.testing.assert_allclose(model.damping.derivative(p, model.parameter_index("w")), [[0, 1], [-1, 0]])


# ---------------------------------------------------------------- bad input
BASE = """
model:
  dofs: [x, y]
  parameters: {m: 1, k: 1, kc: 0.2, g: 1, F: 0.3, w: 1}
  mass: [[m, 0], [0, m]]
  stiffness: [[k, -kc], [-kc, k]]
  forces:
    - {dof: x, expr: "g*x**3"}
  excitation:
    - {dof: x, expr: "F*cos(tau)"}
"""

BAD = [
    ("  stiffness: [[k, -kc], [-kc, k]]", "  stiffness: [[k, 0], [0, k], [0, 0]]",
     r"model\.stiffness.*expected a 2x2 matrix \(2 dofs: x, y\), found 3 rows"),
    ("  stiffness: [[k, -kc], [-kc, k]]", "  stiffness: [[k, 0, 1], [0, k]]",
     r"model\.stiffness\[0\] \(line \d+\): expected a row of 2 entries.*found 3 entries"),
    ('{dof: x, expr: "g*x**3"}', '{dof: x, expr: "gg*x**3"}',
     r"model\.forces\[0\]\.expr \(line 8\).*unknown name 'gg' \(did you mean 'g'\?\)"),
    ('{dof: x, expr: "g*x**3"}', '{dof: x, expr: "g*x**3", sidez: 1}',
     r"model\.forces\[0\]\.sidez.*unknown key 'sidez'"),
    ('{dof: x, expr: "g*x**3"}', '{type: gap, dof: x, clearance: 0.1, stiffnes: 10}',
     r"model\.forces\[0\]\.stiffnes.*unknown key 'stiffnes' \(did you mean 'stiffness'\?\)"),
    ('{dof: x, expr: "g*x**3"}', '{type: gap, dof: x, clearance: "-g", stiffness: 10}',
     r"model\.forces\[0\]\.clearance.*clearance >= 0"),
    ('{dof: x, expr: "g*x**3"}', '{type: gap, dof: x, clearance: 0.1, stiffness: kk}',
     r"model\.forces\[0\]\.stiffness.*unknown name 'kk' \(did you mean 'k'\?\)"),
    ('{dof: x, expr: "g*x**3"}', '{type: gapp, dof: x}', r"model\.forces\[0\]\.type.*\(did you mean 'gap'\?\)"),
    ('{dof: x, expr: "g*x**3"}', '{dof: z, expr: "x"}', r"model\.forces\[0\]\.dof.*one of x, y"),
    ('{dof: x, expr: "g*x**3"}', '{dof: x, expr: "g*z_dot"}',
     r"model\.forces\[0\]\.expr.*unknown velocity 'z_dot': 'z' is not a degree of freedom"),
    ('{dof: x, expr: "g*x**3"}', '{dof: x, expr: "__import__(\'os\')"}',
     r"model\.forces\[0\]\.expr.*call of '__import__' is not allowed"),
    ('{dof: x, expr: "F*cos(tau)"}', '{dof: x, expr: "F*cos(tau)*x"}',
     r"model\.excitation\[0\]\.expr.*the excitation cannot depend on the dof 'x'"),
    ('{dof: x, expr: "F*cos(tau)"}', '{dof: x, expr: "F*y_dot"}',
     r"model\.excitation\[0\]\.expr.*cannot depend on the velocity 'y_dot'"),
    ('{dof: x, expr: "F*cos(tau)"}', '{dof: x, amplitude: F, expr: "F"}',
     r"model\.excitation\[0\].*exactly one of the keys expr, amplitude, constant"),
    ('{dof: x, expr: "F*cos(tau)"}', '{dof: x, amplitude: F, order: -1}', r"model\.excitation\[0\]\.order.*>= 0"),
    ("kc: 0.2,", 'kc: "2*q", q: "r + 1", r: "kc/2 + k", ',
     r"model\.parameters\.kc.*kc -> q -> r -> kc depend on each other"),
    ("kc: 0.2,", 'kc: "x*2",', r"model\.parameters\.kc.*a parameter cannot depend on 'x'"),
    ("kc: 0.2,", 'kc: [1, 2],', r"model\.parameters\.kc.*a number or an expression"),
    ("kc: 0.2,", 'tau: 1, kc: 0.2,', r"model\.parameters\.tau.*not reserved"),
    ("  mass: [[m, 0], [0, m]]", "  mass: [[m, m], [m, m]]", r"model\.mass.*nonsingular matrix at the default"),
    ("  mass: [[m, 0], [0, m]]", "", r"model\.mass.*2x2 matrix.*\(required\)"),
    ("  mass: [[m, 0], [0, m]]", "  mass: [[m, 0], [0, x]]", r"model\.mass\[1\]\[1\].*only use parameters, and 'x' is a dof"),
    ("  mass: [[m, 0], [0, m]]", "  mass: [[m, 0], [0, \"m*tau\"]]", r"model\.mass\[1\]\[1\].*'tau'"),
    ("  mass: [[m, 0], [0, m]]", "  mass: [[m, 0], [0, \"1/(m-1)\"]]", r"model\.mass\[1\]\[1\].*finite value at the default parameters.*evaluates to inf"),
    ("w: 1}", "W: 1}", r"model\.frequency.*excitation-frequency parameter.*did you mean 'W'"),
    ("w: 1}", "v: 1, w: \"2*v\"}", r"model\.frequency.*independent parameter"),
    ("  forces:", "  gyroscopic: {matrix: [[0, 1], [-1, 0]], sped: w}\n  forces:",
     r"model\.gyroscopic\.sped.*did you mean 'speed'"),
    ("  forces:", "  gyroscopic: {matrix: [[0, 1]], speed: w}\n  forces:", r"model\.gyroscopic\.matrix.*found 1 row"),
    ("dofs: [x, y]", "dofs: [x, x_dot]", r"model\.dofs\[1\].*velocity of 'x'"),
    ("dofs: [x, y]", "dofs: [x, sin]", r"model\.dofs\[1\].*function name"),
]


@pytest.mark.parametrize("old,new,pattern", BAD, ids=[b[2][:40] for b in BAD])
def test_bad_custom_input_names_the_key(old, new, pattern):
    assert old in BASE
    text = BASE.replace(old, new)
    with pytest.raises(SceneError, match=pattern):
        custom(text)


def test_badly_scaled_but_regular_mass_is_accepted():
    model = custom(BASE.replace("  mass: [[m, 0], [0, m]]", "  mass: [[1e-8, 0], [0, 1e8]]"))
    np.testing.assert_allclose(np.diag(model.mass.value(model.parameter_vector())), [1e-8, 1e8])


def test_unknown_name_error_has_the_yaml_line():
    text = textwrap.dedent(BASE).replace('"g*x**3"', '"g*xx**3"')
    with pytest.raises(SceneError) as info:
        custom(text)
    line = next(i for i, s in enumerate(text.splitlines(), 1) if "xx" in s)
    assert info.value.line == line and info.value.key == "model.forces[0].expr"


def test_continuation_in_a_dependent_parameter_is_refused():
    model = custom(BASE.replace("F: 0.3", 'F: "0.1*w**2"'))
    check_continuation_parameter(model, "w")
    with pytest.raises(SceneError, match=r"analysis\.parameter.*'F' is defined as '0.1\*w\*\*2'"):
        check_continuation_parameter(model, "F")
    with pytest.raises(SceneError, match=r"analysis\.frequency.*'F' is defined"):
        custom(BASE.replace("F: 0.3", 'F: "0.1*w**2"'), ANALYSIS + "  frequency: F\n")


def test_huge_inlined_parameters_are_refused_quickly():
    params = ", ".join(f'a{i}: "a{i - 1} + a{i - 1}"' for i in range(1, 60))
    text = BASE.replace("kc: 0.2,", f"kc: 0.2, a0: 1.5, {params},").replace('"g*x**3"', '"a59*x"')
    with pytest.raises(SceneError, match=r"model\.parameters\.a\d+.*(nodes|depth)"):
        custom(text)


# ---------------------------------------------------------------- kernel cache
CACHE_CODE = """
import numpy as np
from contin.scene.build import build_model
from contin.scene.parse import load_scene
from contin.hb.problem import HarmonicBalance, HBOptions
model = build_model(load_scene({scene!r}))
hb = HarmonicBalance(model, 'g', HBOptions(harmonics=3))
u = np.linspace(0.1, 0.7, hb.size)
hb.linearize(u, 1.0)
mod = model.forces[0].kernels()
print(mod.__file__)
print(len(mod.evaluate.stats.cache_misses), len(mod.evaluate.stats.cache_hits),
      len(mod.evaluate_dp.stats.cache_misses), len(mod.evaluate_dp.stats.cache_hits))
"""


def test_kernel_module_is_cached_across_processes(tmp_path):
    env = dict(os.environ, CONTIN_CACHE_DIR=str(tmp_path / "kernels"))
    env.pop("NUMBA_CACHE_DIR", None)
    code = CACHE_CODE.format(scene=str(ROOT / "scenes/custom_duffing.yaml"))

    def run():
        out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True)
        lines = out.stdout.split("\n")
        return lines[0], [int(v) for v in lines[1].split()]

    path1, stats1 = run()
    path2, (miss_f, hit_f, miss_dp, hit_dp) = run()
    assert path1 == path2 and Path(path1).parent == tmp_path / "kernels"
    assert Path(path1).name.startswith("contin_kernel_")
    assert miss_f == 0 and hit_f >= 1 and miss_dp == 0 and hit_dp >= 1


def test_cache_file_is_written_once_and_repaired(tmp_path, monkeypatch):
    monkeypatch.setenv("CONTIN_CACHE_DIR", str(tmp_path))
    source = "# test module\nVALUE = 1\n"
    name = codegen.module_name(source)
    path = tmp_path / f"{name}.py"
    codegen._write_atomic(path, source)
    os.utime(path, (1_000_000, 1_000_000))
    codegen._write_atomic(path, source)  # same content: untouched (numba's cache index keys on the stamp)
    assert path.stat().st_mtime == 1_000_000
    path.write_text("damaged")
    codegen._write_atomic(path, source)
    assert path.read_text() == source
    assert not [p for p in tmp_path.iterdir() if p.suffix == ".tmp"]
    assert codegen.kernel_cache_dir() == tmp_path
    assert codegen.load_module(source).VALUE == 1


RACE_CODE = """
import sys
from contin.model import codegen
mod = codegen.load_module("# race\\nVALUE = 42\\n" + "X = 1\\n" * 20000)
print(mod.VALUE, mod.__file__)
"""


def test_processes_racing_to_write_a_kernel_module(tmp_path):
    env = dict(os.environ, CONTIN_CACHE_DIR=str(tmp_path))
    procs = [subprocess.Popen([sys.executable, "-c", RACE_CODE], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                              text=True, env=env) for _ in range(6)]
    outs = [p.communicate(timeout=60) for p in procs]
    assert all(p.returncode == 0 for p in procs), [e for _, e in outs]
    files = {o.split()[1] for o, _ in outs}
    assert {o.split()[0] for o, _ in outs} == {"42"} and len(files) == 1
    assert sorted(p.name for p in tmp_path.iterdir() if p.is_file()) == [Path(files.pop()).name]


def test_unwritable_cache_directory_falls_back(tmp_path, monkeypatch):
    blocker = tmp_path / "file"
    blocker.write_text("not a directory")
    monkeypatch.setenv("CONTIN_CACHE_DIR", str(blocker / "kernels"))
    with pytest.warns(ContinWarning, match="kernels"):  # the refused directory is named
        mod = codegen.load_module("# fallback test\nVALUE = 7\n")
    assert mod.VALUE == 7 and not str(mod.__file__).startswith(str(blocker))


# ---------------------------------------------------------------- example scenes
def test_example_scenes_check(capsys):
    from contin.app.cli import main

    for name in ("custom_duffing", "gap_oscillator"):
        assert main(["check", str(ROOT / "scenes" / f"{name}.yaml")]) == 0
    out = capsys.readouterr().out
    assert "g*x**3" in out and "gap: contact on x" in out and "samples N=4096" in out


def test_custom_duffing_scene_runs_like_the_builtin(tmp_path):
    from contin.output.results import read_csv
    from contin.app.runner import run_scene

    for name in ("custom_duffing", "duffing"):
        # the same stability setting: the stability events steer the steps (custom_duffing has none)
        scene = load_scene(ROOT / "scenes" / f"{name}.yaml", ["analysis.harmonics=3", "analysis.stability=none"])
        run_scene(scene, tmp_path / name, progress=False)
    a, b = read_csv(tmp_path / "custom_duffing/branches.csv"), read_csv(tmp_path / "duffing/branches.csv")
    np.testing.assert_allclose(a["w"], b["w"], rtol=1e-12)
    np.testing.assert_allclose(a["amp_x"], b["amp_x"], rtol=1e-10)
