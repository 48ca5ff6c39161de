"""Fuzzing scenes: mutated valid scenes and random expressions give a clear error or a model, nothing else.

Every example goes through ``parse_scene`` and ``runner.build_model``, and
some through ``contin check`` on a temporary file. The only exceptions
allowed out are :class:`contin.scene.parse.SceneError` and ``ValueError`` with a
non-empty message; anything else (``TypeError``, ``KeyError``,
``RecursionError``, ``OverflowError``, ...) or a slow example fails.
"""

import copy
import tempfile
from pathlib import Path

import pytest
from conftest import no_hang
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from conftest import fuzz_examples

from contin.app.cli import main
from contin.scene.build import build_model
from contin.scene.parse import SceneError, parse_scene

ROOT = Path(__file__).resolve().parents[2]

RICH = """
model:
  name: rotor
  dofs: [x, y, z]
  parameters: {m: 1.2, c: 0.05, k: 1.0, kc: 0.3, g: 0.8, mu: 0.2, ip: 0.1, delta: 0.1, kbn: 100,
               F: "0.1*w**2", G2: "F*mu + 1", w: 1.3}
  mass: [[m, 0, 0], [0, m, 0], [0, 0, "2*m"]]
  damping: [[c, 0, 0], [0, c, 0], [0, 0, "c*(1 + mu)"]]
  stiffness: [["k*(1 + 0.1*w)", -kc, 0], [-kc, k, 0], [0, 0, "k + sqrt(kc)"]]
  gyroscopic: {matrix: [[0, 1, 0], [-1, 0, 0], [0, 0, 0]], speed: "ip*w"}
  forces:
    - {dof: x, expr: "g*x**3 + mu*abs(x_dot)*x_dot + 0.1*cos(2*tau)*x"}
    - {dof: z, expr: "mu*(z**2 - 1)*z_dot + G2*tanh(x - z)"}
    - {type: gap, dof: z, clearance: delta, stiffness: kbn, damping: 0, sides: "+", clip: true}
    - {type: radial_gap, dofs: [x, y], clearance: delta, stiffness: kbn, damping: "0.01*kbn"}
  excitation:
    - {dof: x, expr: "F*cos(tau) + 0.2*mu*sin(2*tau)"}
    - {dof: y, amplitude: "0.3*F", order: 1, phase: 0.4}
    - {dof: z, constant: "0.1*mu"}
  frequency: w
analysis:
  type: frequency_response
  parameter: w
  range: [0.5, 3.0]
  harmonics: 3
  samples: 64
  stability: none
output:
  measure: amp_x
"""

BASES = [
    yaml.safe_load((ROOT / "scenes/custom_duffing.yaml").read_text()),
    yaml.safe_load((ROOT / "scenes/gap_oscillator.yaml").read_text()),
    yaml.safe_load(RICH),
    yaml.safe_load((ROOT / "scenes/duffing.yaml").read_text()),
]
NAMES = ["x", "y", "z", "x_dot", "y_dot", "z_dot", "tau", "w", "m", "c", "k", "g", "F", "mu", "kc", "G2", "pi",
         "q", "xx", "w_dot", "__class__"]

# -------------------------------------------------------------- strategies
def _expr_tree():
    leaf = st.one_of(st.sampled_from(NAMES), st.floats(-1e3, 1e3, allow_nan=False).map(lambda v: repr(round(v, 4))),
                     st.integers(0, 5).map(str))

    def extend(children):
        fn = st.sampled_from(["sin", "cos", "tan", "exp", "log", "sqrt", "abs", "sign", "tanh", "min", "max",
                              "foo", "__import__"])
        op = st.sampled_from(["+", "-", "*", "/", "**", "//", "<", " and ", "%"])
        return st.one_of(
            st.tuples(children, op, children).map(lambda t: f"({t[0]}{t[1]}{t[2]})"),
            st.tuples(fn, st.lists(children, min_size=0, max_size=3)).map(lambda t: f"{t[0]}({', '.join(t[1])})"),
            children.map(lambda c: f"-{c}"),
        )

    return st.recursive(leaf, extend, max_leaves=12)


EXPRESSIONS = st.one_of(
    _expr_tree(),
    st.text(alphabet="xyzwtaucos()+-*/.0123456789e_ ,[]'\"\\:=<>!|&~@#;{}", max_size=40),
    st.sampled_from(["__import__('os').system('true')", "x.__class__", "lambda: 1", "[i for i in x]", "x if y else z",
                     "1 < 2", "sin(x=1)", "-" * 3000 + "x", "(" * 80 + "x" + ")" * 80, "x**" * 300 + "x", "1/0",
                     "0**-1", "exp(1000)", "10**400", "log(0)", "sqrt(-1)", "x_dot_dot", "tau_dot", "w*" * 600 + "w"]),
)

SCALARS = st.one_of(
    st.none(), st.booleans(), st.integers(-10, 10), st.integers(10**300, 10**400),
    st.floats(allow_nan=True, allow_infinity=True), st.text(max_size=12), EXPRESSIONS,
)
VALUES = st.recursive(SCALARS, lambda c: st.one_of(st.lists(c, max_size=4),
                                                   st.dictionaries(st.text(max_size=6), c, max_size=3)),
                      max_leaves=12)
KEYS = st.one_of(st.sampled_from(["type", "dof", "dofs", "expr", "clearance", "stiffness", "damping", "sides", "clip",
                                  "amplitude", "order", "phase", "constant", "matrix", "speed", "mass", "forces",
                                  "excitation", "parameters", "frequency", "builtin", "effects", "options", "gyroscopic",
                                  "harmonics", "range", "parameter", "samples", "subharmonic", "stability"]),
                 st.text(max_size=8), st.integers(-3, 3))


def _paths(node, prefix=()):
    out = [prefix]
    if isinstance(node, dict):
        for k in node:
            out += _paths(node[k], prefix + (k,))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            out += _paths(v, prefix + (i,))
    return out


def _get(node, path):
    for p in path:
        node = node[p]
    return node


@st.composite
def mutated_scene(draw):
    data = copy.deepcopy(draw(st.sampled_from(BASES)))
    for _ in range(draw(st.integers(1, 3))):
        paths = [p for p in _paths(data) if p]
        inner = [p for p in paths if len(p) >= 2 and p[0] == "model"]
        if inner and draw(st.integers(0, 4)) < 4:  # mostly inside the model section, the code under test
            paths = inner
        if not paths:
            break
        path = draw(st.sampled_from(paths))
        parent, last = _get(data, path[:-1]), path[-1]
        op = draw(st.sampled_from(["value", "expr", "rename", "delete", "wrap", "stringify", "nested", "add_key"]))
        if op == "delete":
            del parent[last]
        elif op == "rename" and isinstance(parent, dict):
            new = draw(st.one_of(KEYS, st.just(str(last) + "x"), st.just(str(last)[:-1]), st.just(str(last).upper())))
            parent[new] = parent.pop(last)
        elif op == "value":
            parent[last] = draw(VALUES)
        elif op == "expr":
            parent[last] = draw(EXPRESSIONS)
        elif op == "wrap":
            parent[last] = [parent[last]]
        elif op == "stringify":
            parent[last] = str(parent[last])
        elif op == "nested":
            parent[last] = draw(st.lists(st.lists(st.one_of(st.integers(-2, 2), EXPRESSIONS, st.lists(st.integers()),
                                                            st.none()), max_size=4), max_size=4))
        elif op == "add_key":
            target = _get(data, path)
            if isinstance(target, dict):
                target[draw(KEYS)] = draw(VALUES)
            elif isinstance(target, list):
                target.append(draw(VALUES))
    return data


def _dump(data) -> str | None:
    try:
        return yaml.safe_dump(data, sort_keys=False)
    except yaml.YAMLError:
        return None


def _allowed(exc: BaseException) -> bool:
    return isinstance(exc, (SceneError, ValueError)) and str(exc).strip() != ""


def _build(text: str, overrides=()):
    try:
        with no_hang(60):
            build_model(parse_scene(text, "<fuzz>", overrides))
    except Exception as exc:  # noqa: BLE001  (the point of the test)
        if not _allowed(exc):
            raise AssertionError(f"{type(exc).__name__} escaped: {exc!r}\n--- scene ---\n{text[:3000]}") from exc


# -------------------------------------------------------------- tests
@pytest.fixture(scope="module")
def scratch():
    with tempfile.TemporaryDirectory() as d:
        yield Path(d)


@settings(max_examples=fuzz_examples(150), deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                                                   HealthCheck.function_scoped_fixture])
@given(mutated_scene(), st.booleans())
def test_mutated_scenes_give_clear_errors(scratch, data, run_check):
    text = _dump(data)
    if text is None:
        return
    _build(text)
    if run_check:
        path = scratch / "scene.yaml"
        path.write_text(text)
        try:
            with no_hang(60):
                code = main(["check", str(path)])
            assert code in (0, 2)
        except Exception as exc:  # noqa: BLE001
            if not _allowed(exc):
                raise AssertionError(f"contin check: {type(exc).__name__} escaped: {exc!r}\n{text[:3000]}") from exc


@settings(max_examples=fuzz_examples(150), deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.sampled_from(["forces[0].expr", "excitation[0].expr", "mass", "stiffness", "parameters.F", "parameters.k",
                        "forces[2].clearance", "gyroscopic.speed", "excitation[1].amplitude"]), EXPRESSIONS)
def test_random_expressions_in_a_valid_scene(where, expr):
    data = copy.deepcopy(BASES[2])
    model = data["model"]
    if where in ("mass", "stiffness"):
        model[where][1][1] = expr
    elif where.startswith("parameters."):
        model["parameters"][where.split(".")[1]] = expr
    elif where == "gyroscopic.speed":
        model["gyroscopic"]["speed"] = expr
    else:
        section, field = where.split(".")
        name, idx = section[:-3], int(section[-2])
        model[name][idx][field] = expr
    _build(yaml.safe_dump(data, sort_keys=False))


@settings(max_examples=fuzz_examples(60), deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(st.one_of(
    st.tuples(st.sampled_from(["model.parameters.F", "model.forces", "model.mass", "model.dofs", "model.frequency",
                               "model.excitation", "model.gyroscopic.speed", "analysis.parameter", "model.parameters",
                               "model.forces.0"]),
              st.text(alphabet="[]{}:,'\" xywF0123.-*()a", max_size=30)).map(lambda t: f"{t[0]}={t[1]}"),
    st.text(max_size=20)), max_size=3))
def test_random_overrides(overrides):
    _build(yaml.safe_dump(BASES[2], sort_keys=False), overrides)


def test_custom_duffing_scene_still_builds():
    model = build_model(parse_scene((ROOT / "scenes/custom_duffing.yaml").read_text()))
    assert model.degree == 3


HUGE = 10**400
# Inputs the fuzzing once found escaping as TypeError, OverflowError or MemoryError.
ESCAPES = [
    ("scenes/duffing.yaml", "analysis.type=[frequency_response]"),
    ("scenes/duffing.yaml", "analysis.type={a: 1}"),
    ("scenes/duffing.yaml", f"analysis.range=[0.5, {HUGE}]"),
    ("scenes/duffing.yaml", "model.options={1: 2}"),
    ("scenes/duffing.yaml", f"model.parameters.F={HUGE}"),
    ("scenes/custom_duffing.yaml", f"analysis.harmonics={10**14}"),
]


@pytest.mark.parametrize("scene,override", ESCAPES, ids=[c[1][:30] for c in ESCAPES])
def test_former_escapes_are_clean_errors(scene, override, capsys):
    key = override.split("=", 1)[0]
    assert main(["check", str(ROOT / scene), "--set", override]) == 2
    err = capsys.readouterr().err.replace("\n", " ")
    assert key.split(".")[0] in err and "expected" in err
