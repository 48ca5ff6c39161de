"""Expressions' values against numpy, derivatives against finite differences, printed text read back."""

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from contin.model import expressions as ex
from contin.model.expressions import parse

CASES = [
    ("g*x**3", lambda e: e["g"] * e["x"] ** 3),
    ("-x*y/2 + 3", lambda e: -e["x"] * e["y"] / 2 + 3),
    ("a - b - (c - d)", lambda e: e["a"] - e["b"] - (e["c"] - e["d"])),
    ("x**y**2", lambda e: e["x"] ** (e["y"] ** 2)),
    ("-2**2*x", lambda e: -4 * e["x"]),
    ("sin(x)*cos(y) + tan(0.3*x)", lambda e: np.sin(e["x"]) * np.cos(e["y"]) + np.tan(0.3 * e["x"])),
    ("exp(-x**2)*log(1 + y**2)", lambda e: np.exp(-e["x"] ** 2) * np.log(1 + e["y"] ** 2)),
    ("sqrt(1 + x**2)/(2 + tanh(y))", lambda e: np.sqrt(1 + e["x"] ** 2) / (2 + np.tanh(e["y"]))),
    ("abs(x)*sign(y) + min(x, y) - max(x, 2*y)",
     lambda e: np.abs(e["x"]) * np.sign(e["y"]) + np.minimum(e["x"], e["y"]) - np.maximum(e["x"], 2 * e["y"])),
    ("d*abs(x_dot)*x_dot + eps*cos(2*tau + 0.3)*x",
     lambda e: e["d"] * np.abs(e["x_dot"]) * e["x_dot"] + e["eps"] * np.cos(2 * e["tau"] + 0.3) * e["x"]),
    ("(x + y)**-2 / x / y", lambda e: (e["x"] + e["y"]) ** -2 / e["x"] / e["y"]),
    ("+x - -y + 1e-3*pi", lambda e: e["x"] + e["y"] + 1e-3 * math.pi),
    ("2**x * a**0.5", lambda e: 2 ** e["x"] * e["a"] ** 0.5),
]
NAMES = ["x", "y", "a", "b", "c", "d", "g", "eps", "x_dot", "tau"]


def random_env(rng, n=50):
    env = {k: rng.uniform(0.2, 1.5, n) * rng.choice([-1, 1], n) for k in NAMES}
    env["a"] = np.abs(env["a"])
    env["x"] = np.abs(env["x"]) + 0.1  # powers with real exponents need a positive base
    return env


@pytest.mark.parametrize("text,ref", CASES, ids=[c[0] for c in CASES])
def test_values_match_numpy(text, ref, rng):
    env = random_env(rng)
    np.testing.assert_allclose(ex.evaluate(parse(text), env), ref(env), rtol=1e-12)


@pytest.mark.parametrize("text,ref", CASES, ids=[c[0] for c in CASES])
def test_derivatives_match_finite_differences(text, ref, rng):
    env = random_env(rng, 20)
    node = parse(text)
    for name in sorted(ex.free_names(node) - {"pi"}):
        d = np.broadcast_to(ex.evaluate(ex.diff(node, name), env), env["x"].shape)
        h = 1e-6
        up, dn = dict(env), dict(env)
        up[name] = env[name] + h
        dn[name] = env[name] - h
        fd = (ref(up) - ref(dn)) / (2 * h)
        np.testing.assert_allclose(d, fd, rtol=1e-6, atol=1e-7, err_msg=f"d/d{name} of {text}")


def test_printed_text_parses_back_to_the_same_values(rng):
    env = random_env(rng)
    for text, _ in CASES:
        for node in (parse(text), ex.diff(parse(text), "x")):
            printed = ex.to_text(node)
            if "select" in printed:  # derivatives of min/max are not user syntax
                continue
            np.testing.assert_allclose(ex.evaluate(parse(printed), env), np.broadcast_to(ex.evaluate(node, env), 50),
                                       rtol=1e-13, err_msg=printed)


# ------------------------------------------------------------------ random expressions
def _leaf():
    return st.one_of(
        st.sampled_from(["x", "y", "a"]).map(lambda n: (n, lambda e, n=n: e[n])),
        st.floats(0.1, 3.0).map(lambda v: (repr(round(v, 3)), lambda e, v=round(v, 3): v + 0 * e["x"])),
    )


def _extend(children):
    unary = st.sampled_from(["sin", "cos", "exp", "tanh", "abs", "neg", "sqrt", "log"])
    binary = st.sampled_from(["+", "-", "*", "/", "min", "max", "pow"])

    def un(args):
        f, (t, g) = args
        np_f = {"sin": np.sin, "cos": np.cos, "exp": np.exp, "tanh": np.tanh, "abs": np.abs, "sqrt": np.sqrt,
                "log": np.log}
        if f == "neg":
            return f"-({t})", lambda e: -g(e)
        if f in ("sqrt", "log"):  # keep the argument in the domain
            return f"{f}(1 + ({t})**2)", lambda e: np_f[f](1 + g(e) ** 2)
        if f == "exp":
            return f"exp(tanh({t}))", lambda e: np.exp(np.tanh(g(e)))
        return f"{f}({t})", lambda e: np_f[f](g(e))

    def bi(args):
        op, (t1, g1), (t2, g2) = args
        if op == "min":
            return f"min({t1}, {t2})", lambda e: np.minimum(g1(e), g2(e))
        if op == "max":
            return f"max({t1}, {t2})", lambda e: np.maximum(g1(e), g2(e))
        if op == "pow":
            return f"(1 + ({t1})**2)**(tanh({t2}))", lambda e: (1 + g1(e) ** 2) ** np.tanh(g2(e))
        if op == "/":
            return f"({t1})/(1 + ({t2})**2)", lambda e: g1(e) / (1 + g2(e) ** 2)
        fn = {"+": np.add, "-": np.subtract, "*": np.multiply}[op]
        return f"({t1}) {op} ({t2})", lambda e: fn(g1(e), g2(e))

    return st.one_of(st.tuples(unary, children).map(un), st.tuples(binary, children, children).map(bi))


EXPRESSIONS = st.recursive(_leaf(), _extend, max_leaves=10)


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(EXPRESSIONS, st.integers(0, 2**32 - 1))
def test_random_expressions_values_and_derivatives(expr, seed):
    text, ref = expr
    rng = np.random.default_rng(seed)
    env = {k: rng.uniform(-1.5, 1.5, 16) for k in ("x", "y", "a")}
    node = parse(text)
    with np.errstate(all="ignore"):
        want = np.broadcast_to(ref(env), (16,))
    got = np.broadcast_to(ex.evaluate(node, env), (16,))
    ok = np.isfinite(want) & (np.abs(want) < 1e8)
    np.testing.assert_allclose(got[ok], want[ok], rtol=1e-9, atol=1e-12)
    for name in ("x", "y"):
        d = np.broadcast_to(ex.evaluate(ex.diff(node, name), env), (16,))
        fds = []
        for h in (1e-6, 5e-7):
            up, dn = dict(env), dict(env)
            up[name] = env[name] + h
            dn[name] = env[name] - h
            with np.errstate(all="ignore"):
                fds.append((ref(up) - ref(dn)) / (2 * h))
        fd1, fd2 = (np.broadcast_to(f, (16,)) for f in fds)
        # skip points near kinks (abs, min, max), where the two step sizes disagree
        smooth = np.isfinite(fd1) & np.isfinite(fd2) & (np.abs(fd1 - fd2) <= 1e-5 * (1 + np.abs(fd1)))
        smooth &= np.abs(fd1) < 1e6
        np.testing.assert_allclose(d[smooth], fd1[smooth], rtol=1e-5, atol=1e-6, err_msg=f"d/d{name} of {text}")
