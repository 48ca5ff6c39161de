"""Reading expressions: refusals named by construct, unknown names, limits on length and nesting, NFKC names."""

import pytest
from conftest import no_hang
from hypothesis import given, settings
from hypothesis import strategies as st

from contin.model import expressions as ex
from contin.model.expressions import ExpressionError, parse


FORBIDDEN = [
    ("__import__('os')", "call of '__import__'"),
    ("__import__", "names starting with '__'"),
    ("x.__class__", "attribute access '.__class__'"),
    ("a[0]", "subscript"),
    ("lambda: 1", "lambda"),
    ("[i for i in x]", "comprehension"),
    ("{i for i in x}", "comprehension"),
    ("(i for i in x)", "comprehension"),
    ('"s"', "string 's'"),
    ("x if y else z", "conditional expression"),
    ("1 < 2", "comparison '<'"),
    ("x == y", "comparison '=='"),
    ("sin(x=1)", "keyword argument 'x='"),
    ("max(x, y, key=abs)", "keyword argument 'key='"),
    ("x and y", "boolean operator 'and'"),
    ("not x", "operator 'not'"),
    ("~x", "operator '~'"),
    ("x // 2", "operator '//'"),
    ("x % 2", "operator '%'"),
    ("x @ y", "operator '@'"),
    ("f'{x}'", "f-string"),
    ("sin(*x)", "starred"),
    ("(y := 1)", "assignment expression"),
    ("[x, y]", "list"),
    ("(x, y)", "tuple"),
    ("{'a': 1}", "dict"),
    ("1j", "complex number"),
    ("True", "constant True"),
    ("None", "constant None"),
    ("open('f')", "call of 'open'"),
    ("exp(x)(y)", "call of"),
    ("sin", "without a call"),
    ("sin(x, y)", "sin() takes 1 argument, found 2"),
    ("max(x)", "max() takes 2 arguments, found 1"),
    ("snh(x)", "(did you mean 'sin'?)"),
    ("x +", "invalid syntax"),
    ("", "empty expression"),
    ("1e999", "number too large"),
    ("9" * 400, "number too large"),
    ("x; import os", "invalid syntax"),
    ("b'x'", "bytes"),
]


@pytest.mark.parametrize("text,fragment", FORBIDDEN, ids=[f[0][:30] for f in FORBIDDEN])
def test_forbidden_constructs_are_refused_by_name(text, fragment):
    with pytest.raises(ExpressionError) as info:
        parse(text, "model.forces[0].expr")
    msg = str(info.value)
    assert msg.startswith("model.forces[0].expr: ")
    assert fragment in msg


def test_non_text_is_refused():
    for v in (None, True, [1], {"a": 1}, float("nan"), float("inf")):
        with pytest.raises(ExpressionError, match="k:"):
            parse(v, "k")
    assert parse(3, "k") == ex.Num(3.0)


def test_unknown_names_get_did_you_mean():
    with pytest.raises(ExpressionError, match=r"unknown name 'gg' \(did you mean 'g'\?\)"):
        parse("gg*x**3", "k", names=["g", "x"])
    with pytest.raises(ExpressionError, match=r"unknown name 'x_dto' \(did you mean 'x_dot'\?\)"):
        parse("x_dto", "k", names=["x", "x_dot"])
    assert parse("2*pi*x", "k", names=["x"])  # pi is a constant


PATHOLOGICAL = [
    "-" * 100_000 + "x",
    "(" * 100_000 + "x" + ")" * 100_000,
    "x" * 1_000_000,
    "(" * 60 + "x" + ")" * 60,
    "[" * 500,
    "-" * 1999 + "x",
    "x**" * 600 + "x",
    "sin(" * 51 + "x" + ")" * 51,
    "not " * 499 + "x",
    "lambda:" * 285 + "1",
    "a if b else " * 180 + "c",
    "x" + ".a" * 900,
    "x" + "[0]" * 600,
]


@pytest.mark.parametrize("text", PATHOLOGICAL, ids=[f"{t[:12]}..{len(t)}" for t in PATHOLOGICAL])
def test_long_and_deep_input_is_refused_without_crash_or_hang(text):
    with no_hang(30), pytest.raises(ExpressionError) as info:
        parse(text, "k")
    assert str(info.value).startswith("k: ")


def test_limits_are_named():
    with pytest.raises(ExpressionError, match=f"too long .*limit is {ex.MAX_LENGTH}"):
        parse("x+" * 1500 + "x")
    with pytest.raises(ExpressionError, match=f"nested too deeply.*limit is {ex.MAX_DEPTH}"):
        parse("(" * 60 + "x" + ")" * 60)
    with pytest.raises(ExpressionError, match=f"nested too deeply.*limit is {ex.MAX_DEPTH}"):
        parse("-" * 60 + "x")


def test_long_flat_sums_are_fine():
    text = "+".join(f"{i}*x**{i % 4}" for i in range(200))
    assert len(text) < ex.MAX_LENGTH
    node = parse(text)
    assert ex.depth(node) <= 4
    assert ex.evaluate(node, {"x": 1.0}) == pytest.approx(sum(range(200)))
    d = ex.diff(node, "x")
    assert ex.evaluate(d, {"x": 1.0}) == pytest.approx(sum(i * (i % 4) for i in range(200)))


@settings(max_examples=300, deadline=None)
@given(st.text(alphabet="xyab_0123456789.+-*/()e, sincoqrtlgmdu[]'\"\\:=<>!%&|^~@#;{}\n\t", max_size=60))
def test_random_text_parses_or_is_refused_cleanly(text):
    try:
        node = parse(text, "k", names=["x", "y", "a", "b"])
    except ExpressionError as exc:
        assert str(exc).startswith("k: ") and len(str(exc)) > 4
        return
    ex.diff(node, "x")
    ex.to_text(node)


# ---------------------------------------------------------------- names Python reads in NFKC
@pytest.mark.parametrize("text,raw,read", [
    ("ﬁ*x", "ﬁ", "fi"),             # the ligature U+FB01
    ("g*ｘ**3", "ｘ", "x"),           # fullwidth x, U+FF58
    ("ｓｉｎ(x)", "ｓｉｎ", "sin"),    # a fullwidth function name
    ("xⁿ + 1", "xⁿ", "xn"),          # a superscript letter
    ("e\u0301 + 1", "e\u0301", "\u00e9"),  # e and a combining acute accent: one composed letter
])
def test_a_name_that_python_would_read_as_another_is_refused(text, raw, read):
    with pytest.raises(ExpressionError, match=f"name '{raw}' is not in Unicode normal form NFKC: Python reads it "
                                              f"as '{read}'.*write '{read}'"):
        parse(text, "k")


def test_names_in_normal_form_parse_as_written():
    assert ex.free_names(parse("é*x + δ + x1", "k")) == {"é", "δ", "x", "x1"}
