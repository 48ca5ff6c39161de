"""Generated numba source of expressions: names mapped to array accesses, shared and deep parts in temporaries."""

import doctest

from contin.model import expressions as ex
from contin.model.expressions import parse, source


def test_codegen_names_map_to_array_accesses():
    node = parse("g*x**3 + c*abs(x_dot)*x_dot + cos(2*tau)")
    names = {"g": "p[3]", "c": "p[1]", "x": "x[j, 0]", "x_dot": "xd[j, 0]", "tau": "tau[j]"}
    src = ex.to_source(node, names.__getitem__)
    assert src == "p[3]*x[j, 0]**3 + p[1]*abs(xd[j, 0])*xd[j, 0] + np.cos(2.0*tau[j])"
    compile(src, "<test>", "eval")  # syntax only
    w = ex.CodeWriter(names.__getitem__)
    d = ex.diff(node, "x_dot")
    w.count(node)
    w.count(d)
    texts = [w.emit(node), w.emit(d)]
    assert w.lines == ["_t0 = abs(xd[j, 0])"]
    assert texts[1] == "p[1]*np.sign(xd[j, 0])*xd[j, 0] + p[1]*_t0"


def test_codewriter_keeps_generated_code_shallow():
    text = "sin(" * 45 + "x" + ")" * 45
    node = parse(text)
    w = ex.CodeWriter(lambda s: s)
    d = ex.diff(node, "x")
    w.count(d)
    out = w.emit(d)
    source = "\n".join(w.lines + [f"r = {out}"])
    compile(source, "<test>", "exec")

    def nesting(line):
        level = peak = 0
        for ch in line:
            level += ch == "("
            level -= ch == ")"
            peak = max(peak, level)
        return peak

    assert max(nesting(line) for line in w.lines + [out]) <= 2 * ex.CodeWriter.INLINE_DEPTH


def test_the_documented_example_runs():
    failed, attempted = doctest.testmod(source)
    assert attempted and not failed
