"""Safe arithmetic expressions: parsing, evaluation, differentiation, code generation.

Scene files write forces, matrix entries and parameters as expressions such
as ``"g*x**3 + d*abs(x_dot)*x_dot"`` (SPEC 4.2). The text is parsed with
``ast.parse(text, mode="eval")`` and checked against a whitelist:

- numbers (finite ``int``/``float`` literals) and names,
- unary ``+``/``-``, binary ``+ - * / **`` and parentheses,
- calls of the functions in :data:`FUNCTIONS` with their arity.

Names must be written in Unicode normal form NFKC, the form in which Python
reads identifiers: ``ﬁ`` (U+FB01) or a fullwidth ``ｘ`` would otherwise be
read as ``fi`` and ``x`` and merge with those names.

Everything else (attribute access, subscripts, strings, comparisons, boolean
operators, conditional expressions, lambdas, comprehensions, keyword or
starred arguments, f-strings, ``:=``, ...) raises :class:`ExpressionError`
naming the construct. The length (:data:`MAX_LENGTH`) and the nesting depth
(:data:`MAX_DEPTH`) are bounded before the parser sees deep input, so no
input can exhaust the parser's or this module's recursion. The text is never
passed to ``eval`` or ``exec``.

The checked tree is converted to immutable :class:`Node` objects (sums and
products are n-ary, so long sums stay shallow). On these the module offers
numeric evaluation with numpy (:func:`evaluate`), symbolic differentiation
with simplification of trivial zeros and ones (:func:`diff`), substitution
(:func:`substitute`), polynomial-degree and tau-harmonic analysis, and
Python source generation for numba (:func:`to_source`, :class:`CodeWriter`).

The name ``pi`` is a constant unless a parameter of that name is defined.
"""

from __future__ import annotations

import ast
import math
import re
import unicodedata
import warnings
from typing import Callable, Iterable, Mapping

import numpy as np

from contin.util.naming import suggest

__all__ = [
    "MAX_LENGTH",
    "MAX_DEPTH",
    "FUNCTIONS",
    "ExpressionError",
    "Node",
    "Num",
    "Var",
    "Add",
    "Mul",
    "Pow",
    "Neg",
    "Call",
    "Select",
    "parse",
    "check_names",
    "free_names",
    "evaluate",
    "diff",
    "substitute",
    "to_text",
    "to_source",
    "CodeWriter",
    "polynomial_degree",
    "tau_orders",
    "harmonic_bound",
    "depth",
    "measure",
    "free_names_cached",
    "add",
    "sub",
    "neg",
    "mul",
    "div",
    "power",
    "call",
    "select",
    "ZERO",
    "ONE",
]

#: longest accepted expression text (characters)
MAX_LENGTH = 2000
#: deepest accepted nesting (parentheses, calls, powers, unary operators)
MAX_DEPTH = 50
#: allowed functions and their number of arguments
FUNCTIONS = {"sin": 1, "cos": 1, "tan": 1, "exp": 1, "log": 1, "sqrt": 1, "abs": 1, "sign": 1, "tanh": 1,
             "min": 2, "max": 2}

_FORBIDDEN = {
    ast.Attribute: "attribute access",
    ast.Subscript: "subscript (indexing)",
    ast.Lambda: "lambda",
    ast.ListComp: "comprehension",
    ast.SetComp: "comprehension",
    ast.DictComp: "comprehension",
    ast.GeneratorExp: "comprehension (generator)",
    ast.IfExp: "conditional expression (x if y else z)",
    ast.Compare: "comparison",
    ast.BoolOp: "boolean operator (and/or)",
    ast.JoinedStr: "f-string",
    ast.FormattedValue: "f-string",
    ast.Starred: "starred argument (*)",
    ast.NamedExpr: "assignment expression (:=)",
    ast.List: "list",
    ast.Tuple: "tuple",
    ast.Set: "set",
    ast.Dict: "dict",
    ast.Slice: "slice",
    ast.Await: "await",
    ast.Yield: "yield",
    ast.YieldFrom: "yield",
    ast.keyword: "keyword argument",
}
_BINOPS = {ast.Add: "+", ast.Sub: "-", ast.Mult: "*", ast.Div: "/", ast.Pow: "**"}
_OTHER_OPS = {ast.FloorDiv: "//", ast.Mod: "%", ast.MatMult: "@", ast.LShift: "<<", ast.RShift: ">>",
              ast.BitOr: "|", ast.BitXor: "^", ast.BitAnd: "&", ast.Not: "not", ast.Invert: "~"}
_COMPARE = {ast.Eq: "==", ast.NotEq: "!=", ast.Lt: "<", ast.LtE: "<=", ast.Gt: ">", ast.GtE: ">=",
            ast.Is: "is", ast.IsNot: "is not", ast.In: "in", ast.NotIn: "not in"}


class ExpressionError(ValueError):
    """A refused expression.

    Attributes
    ----------
    where : str
        The key (or description) of the expression, e.g. ``model.forces[0].expr``.
    reason : str
        What is wrong, naming the offending construct or name.
    """

    def __init__(self, where: str, reason: str):
        self.where, self.reason = where, reason
        super().__init__(f"{where}: {reason}")


# ------------------------------------------------------------------ nodes
class Node:
    """Immutable expression node with structural equality and a cached hash."""

    __slots__ = ("_hash",)

    def _key(self) -> tuple:
        raise NotImplementedError

    def __eq__(self, other):
        return self is other or (type(self) is type(other) and self._key() == other._key())

    def __hash__(self):
        try:
            return self._hash
        except AttributeError:
            h = hash((type(self).__name__,) + self._key())
            object.__setattr__(self, "_hash", h)
            return h

    def __setattr__(self, name, value):
        raise AttributeError("expression nodes are immutable")

    def children(self) -> tuple:
        return ()

    def __repr__(self):
        return f"{type(self).__name__}({to_text(self)!r})"


def _init(obj, **fields):
    for k, v in fields.items():
        object.__setattr__(obj, k, v)


class Num(Node):
    """A finite number."""

    __slots__ = ("value",)

    def __init__(self, value: float):
        _init(self, value=float(value))

    def _key(self):
        return (self.value,)


class Var(Node):
    """A name: parameter, dof, velocity ``NAME_dot`` or ``tau``."""

    __slots__ = ("name",)

    def __init__(self, name: str):
        _init(self, name=str(name))

    def _key(self):
        return (self.name,)


class Add(Node):
    """``sum(terms)``."""

    __slots__ = ("terms",)

    def __init__(self, terms):
        _init(self, terms=tuple(terms))

    def _key(self):
        return self.terms

    def children(self):
        return self.terms


class Mul(Node):
    """``prod(factors) / prod(divisors)``."""

    __slots__ = ("factors", "divisors")

    def __init__(self, factors, divisors=()):
        _init(self, factors=tuple(factors), divisors=tuple(divisors))

    def _key(self):
        return (self.factors, self.divisors)

    def children(self):
        return self.factors + self.divisors


class Pow(Node):
    """``base ** exp``."""

    __slots__ = ("base", "exp")

    def __init__(self, base: Node, exp: Node):
        _init(self, base=base, exp=exp)

    def _key(self):
        return (self.base, self.exp)

    def children(self):
        return (self.base, self.exp)


class Neg(Node):
    """``-arg``."""

    __slots__ = ("arg",)

    def __init__(self, arg: Node):
        _init(self, arg=arg)

    def _key(self):
        return (self.arg,)

    def children(self):
        return (self.arg,)


class Call(Node):
    """``fn(*args)`` for a function of :data:`FUNCTIONS`."""

    __slots__ = ("fn", "args")

    def __init__(self, fn: str, args):
        _init(self, fn=fn, args=tuple(args))

    def _key(self):
        return (self.fn, self.args)

    def children(self):
        return self.args


class Select(Node):
    """``if_le if lhs <= rhs else otherwise`` (from derivatives of min/max; not user syntax)."""

    __slots__ = ("lhs", "rhs", "if_le", "otherwise")

    def __init__(self, lhs, rhs, if_le, otherwise):
        _init(self, lhs=lhs, rhs=rhs, if_le=if_le, otherwise=otherwise)

    def _key(self):
        return (self.lhs, self.rhs, self.if_le, self.otherwise)

    def children(self):
        return (self.lhs, self.rhs, self.if_le, self.otherwise)


ZERO, ONE = Num(0.0), Num(1.0)


# --------------------------------------------------------- smart builders
def _finite(v) -> bool:
    return isinstance(v, float) and math.isfinite(v)


def add(*terms: Node) -> Node:
    """Sum with nested sums flattened, numbers folded and zeros dropped."""
    flat, nums = [], []
    for t in terms:
        for s in (t.terms if isinstance(t, Add) else (t,)):
            (nums if isinstance(s, Num) else flat).append(s)
    const = math.fsum(n.value for n in nums) if nums else 0.0
    if not math.isfinite(const):
        flat += nums  # overflow: keep the numbers apart, as the arithmetic would
    elif const != 0.0:
        flat.append(Num(const))
    if not flat:
        return ZERO
    return flat[0] if len(flat) == 1 else Add(flat)


def neg(a: Node) -> Node:
    if isinstance(a, Num):
        return Num(-a.value)
    if isinstance(a, Neg):
        return a.arg
    if isinstance(a, Mul) and a.factors and isinstance(a.factors[0], Num):
        return mul(*a.factors, Num(-1.0), divisors=a.divisors)
    return Neg(a)


def sub(a: Node, b: Node) -> Node:
    return add(a, neg(b))


def mul(*factors: Node, divisors: Iterable[Node] = ()) -> Node:
    """Product with nested products flattened, numbers folded, ``0*a -> 0`` and ``1*a -> a``."""
    num, den, knum, kden = [], [], [], []
    sign = 1.0

    def take(node, into_num):
        nonlocal sign
        while isinstance(node, Neg):
            sign = -sign
            node = node.arg
        if isinstance(node, Mul):
            for f in node.factors:
                take(f, into_num)
            for d in node.divisors:
                take(d, not into_num)
            return
        if isinstance(node, Num) and (into_num or node.value != 0.0):
            (knum if into_num else kden).append(node.value)
            return
        (num if into_num else den).append(node)  # includes division by a literal zero (inf at run time)

    for f in factors:
        take(f, True)
    for d in divisors:
        take(d, False)
    const = sign
    for v in knum:
        const *= v
    for v in kden:
        const /= v
    if const == 0.0:
        return ZERO
    if not math.isfinite(const):
        # overflow of the folded numbers: keep them apart, as the arithmetic would
        num = [Num(v) for v in knum] + ([Num(sign)] if sign < 0 else []) + num
        den = [Num(v) for v in kden] + den
        return Mul(num, den)
    negative = const == -1.0
    if negative:
        const = 1.0
    if const != 1.0:
        num.insert(0, Num(const))
    if not num and not den:
        return Num(const)
    if not num:
        num = [ONE]
    node = num[0] if (len(num) == 1 and not den) else Mul(num, den)
    return Neg(node) if negative else node


def div(a: Node, b: Node) -> Node:
    return mul(a, divisors=(b,))


def power(base: Node, exp: Node) -> Node:
    if isinstance(exp, Num):
        if exp.value == 0.0:
            return ONE
        if exp.value == 1.0:
            return base
        if isinstance(base, Num):
            try:
                v = float(base.value ** exp.value)
            except (OverflowError, ZeroDivisionError, ValueError, TypeError):
                v = None
            if _finite(v):
                return Num(v)
    if isinstance(base, Num) and base.value == 1.0:
        return ONE
    return Pow(base, exp)


_NUMERIC = {"sin": math.sin, "cos": math.cos, "tan": math.tan, "exp": math.exp, "log": math.log, "sqrt": math.sqrt,
            "abs": abs, "sign": lambda v: float(np.sign(v)), "tanh": math.tanh, "min": min, "max": max}


def call(fn: str, *args: Node) -> Node:
    if all(isinstance(a, Num) for a in args):
        try:
            v = float(_NUMERIC[fn](*(a.value for a in args)))
        except (OverflowError, ValueError, ZeroDivisionError):
            v = None
        if _finite(v):
            return Num(v)
    return Call(fn, args)


def select(lhs: Node, rhs: Node, if_le: Node, otherwise: Node) -> Node:
    if if_le == otherwise:
        return if_le
    if isinstance(lhs, Num) and isinstance(rhs, Num):
        return if_le if lhs.value <= rhs.value else otherwise
    return Select(lhs, rhs, if_le, otherwise)


# ---------------------------------------------------------------- parsing
def _short(text: str, limit: int = 40) -> str:
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _precheck(text: str, where: str) -> None:
    if len(text) > MAX_LENGTH:
        raise ExpressionError(where, f"expression too long ({len(text)} characters; the limit is {MAX_LENGTH})")
    level = peak = 0
    for ch in text:
        if ch in "([{":
            level += 1
            peak = max(peak, level)
        elif ch in ")]}":
            level -= 1
    if peak > MAX_DEPTH:
        raise ExpressionError(where, f"expression nested too deeply ({peak} levels of brackets; the limit is {MAX_DEPTH})")


def _ast_depth(tree: ast.AST) -> int:
    """Nesting depth, counting a left-leaning chain of ``+ -`` or ``* /`` as one level (iteratively)."""
    group = {ast.Add: 1, ast.Sub: 1, ast.Mult: 2, ast.Div: 2}
    peak = 0
    stack = [(tree, 1)]
    while stack:
        node, d = stack.pop()
        peak = max(peak, d)
        if peak > MAX_DEPTH:
            return peak
        if isinstance(node, ast.BinOp):
            g = group.get(type(node.op))
            left = node.left
            same = isinstance(left, ast.BinOp) and g is not None and group.get(type(left.op)) == g
            stack.append((left, d if same else d + 1))
            stack.append((node.right, d + 1))
            continue
        for child in ast.iter_child_nodes(node):
            stack.append((child, d + 1))
    return peak


def _describe_forbidden(node: ast.AST, text: str) -> str | None:
    seg = None
    try:
        seg = ast.get_source_segment(text, node)
    except Exception:  # noqa: BLE001  (positions are best effort)
        seg = None
    seg = f" '{_short(seg)}'" if seg else ""
    t = type(node)
    if t in _FORBIDDEN:
        if t is ast.Attribute:
            return f"attribute access '.{node.attr}' is not allowed"
        if t is ast.keyword:
            return f"keyword argument '{node.arg}=' is not allowed" if node.arg else "keyword argument '**' is not allowed"
        if t is ast.Compare:
            ops = " ".join(_COMPARE.get(type(o), "?") for o in node.ops)
            return f"comparison '{ops}'{seg} is not allowed"
        if t is ast.BoolOp:
            return f"boolean operator '{'and' if isinstance(node.op, ast.And) else 'or'}' is not allowed"
        return f"{_FORBIDDEN[t]}{seg} is not allowed"
    if t is ast.Constant:
        v = node.value
        if isinstance(v, str):
            return f"string {_short(v)!r} is not allowed (expressions hold numbers and names)"
        if isinstance(v, bytes):
            return "bytes literal is not allowed"
        if isinstance(v, bool) or v is None or v is Ellipsis:
            return f"constant {v!r} is not allowed"
        if isinstance(v, complex):
            return f"complex number {v!r} is not allowed"
        return None
    if t is ast.BinOp and type(node.op) not in _BINOPS:
        return f"operator '{_OTHER_OPS.get(type(node.op), '?')}' is not allowed (allowed: + - * / **)"
    if t is ast.UnaryOp and not isinstance(node.op, (ast.UAdd, ast.USub)):
        return f"operator '{_OTHER_OPS.get(type(node.op), '?')}' is not allowed (allowed: unary + and -)"
    if t is ast.Call:
        if not isinstance(node.func, ast.Name):
            return f"call of{seg or ' an expression'} is not allowed (only the functions {', '.join(FUNCTIONS)})"
        name = node.func.id
        if name not in FUNCTIONS:
            return (f"call of '{name}' is not allowed: not an allowed function{suggest(name, FUNCTIONS)} "
                    f"(allowed: {', '.join(FUNCTIONS)})")
        if node.keywords:
            kw = node.keywords[0]
            return f"keyword argument '{kw.arg}=' is not allowed" if kw.arg else "keyword argument '**' is not allowed"
        if any(isinstance(a, ast.Starred) for a in node.args):
            return "starred argument (*) is not allowed"
        if len(node.args) != FUNCTIONS[name]:
            k = FUNCTIONS[name]
            return f"{name}() takes {k} argument{'s' if k > 1 else ''}, found {len(node.args)}"
        return None
    if t is ast.Name:
        if node.id.startswith("__"):
            return f"name '{node.id}' is not allowed (names starting with '__' are reserved)"
        if node.id in FUNCTIONS:
            return f"function '{node.id}' used without a call, write {node.id}(...)"
        return None
    if t in (ast.Expression, ast.BinOp, ast.UnaryOp, ast.Load) or t in _BINOPS or t in (ast.UAdd, ast.USub):
        return None
    return f"'{t.__name__}' construct{seg} is not allowed"


def _check_normal_form(node: ast.Name, text: str, where: str) -> None:
    """Refuse a name written otherwise than Python reads it (NFKC): ``ﬁ`` would silently be ``fi``."""
    try:
        raw = ast.get_source_segment(text, node)
    except Exception:  # noqa: BLE001  (positions are best effort)
        raw = None
    if raw is None:
        raw = next((w for w in re.findall(r"\w+", text, re.UNICODE)
                    if w != node.id and unicodedata.normalize("NFKC", w) == node.id), None)
    if raw is not None and raw != node.id:
        chars = ", ".join(f"{c!r} (U+{ord(c):04X})" for c in dict.fromkeys(raw)
                          if unicodedata.normalize("NFKC", c) != c) or "combining characters"
        raise ExpressionError(where, f"name {raw!r} is not in Unicode normal form NFKC: Python reads it as "
                              f"{node.id!r} ({chars}), so it would merge with that name; write {node.id!r}")


def parse(text, where: str = "expression", names: Iterable[str] | None = None) -> Node:
    """Parse and check an expression.

    Parameters
    ----------
    text : str or number
        The expression (a YAML number is accepted as a constant).
    where : str
        Key named in error messages, e.g. ``"model.forces[0].expr"``.
    names : iterable of str, optional
        If given, every name must be one of these (or the constant ``pi``).

    Returns
    -------
    Node

    Raises
    ------
    ExpressionError
        Naming ``where`` and the offending construct, name or limit.
    """
    if isinstance(text, bool) or not isinstance(text, (str, int, float, np.integer, np.floating)):
        raise ExpressionError(where, f"expected an expression (text) or a number, found {type(text).__name__}")
    if not isinstance(text, str):
        try:
            v = float(text)
        except OverflowError:
            v = math.inf
        if not math.isfinite(v):
            raise ExpressionError(where, f"number {v!r} is not finite")
        return Num(v)
    _precheck(text, where)
    if not text.strip():
        raise ExpressionError(where, "empty expression")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # e.g. "invalid decimal literal" for '1x': reported as an error below
            tree = ast.parse(text.strip(), mode="eval")
    except SyntaxError as exc:
        msg = exc.msg or "invalid syntax"
        col = f" at column {exc.offset}" if exc.offset else ""
        raise ExpressionError(where, f"invalid syntax{col}: {msg} in {_short(text, 60)!r}") from None
    except (ValueError, MemoryError, RecursionError) as exc:
        raise ExpressionError(where, f"cannot parse {_short(text, 60)!r}: {exc}") from None
    if _ast_depth(tree) > MAX_DEPTH:
        raise ExpressionError(where, f"expression nested too deeply (the limit is {MAX_DEPTH} levels)")
    callee = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Name):
            _check_normal_form(node, text.strip(), where)
        if isinstance(node, ast.Call):
            callee.add(id(node.func))
        if id(node) in callee and isinstance(node, ast.Name):
            continue  # the function name of an allowed call
        reason = _describe_forbidden(node, text.strip())
        if reason:
            raise ExpressionError(where, reason)
    out = _convert(tree.body, where)
    if names is not None:
        check_names(out, names, where)
    return out


def _convert(node: ast.AST, where: str) -> Node:
    # Recursion depth is bounded by _ast_depth; left chains of + - and * / are walked in a loop.
    if isinstance(node, ast.Constant):
        try:
            v = float(node.value)
        except OverflowError:
            v = math.inf
        if not math.isfinite(v):
            raise ExpressionError(where, f"number too large: {_short(str(node.value))}")
        return Num(v)
    if isinstance(node, ast.Name):
        return Var(node.id)
    if isinstance(node, ast.UnaryOp):
        a = _convert(node.operand, where)
        return a if isinstance(node.op, ast.UAdd) else neg(a)
    if isinstance(node, ast.BinOp):
        if isinstance(node.op, (ast.Add, ast.Sub)):
            items = []
            while isinstance(node, ast.BinOp) and isinstance(node.op, (ast.Add, ast.Sub)):
                r = _convert(node.right, where)
                items.append(neg(r) if isinstance(node.op, ast.Sub) else r)
                node = node.left
            items.append(_convert(node, where))
            return add(*reversed(items))
        if isinstance(node.op, (ast.Mult, ast.Div)):
            num, den = [], []
            while isinstance(node, ast.BinOp) and isinstance(node.op, (ast.Mult, ast.Div)):
                r = _convert(node.right, where)
                (den if isinstance(node.op, ast.Div) else num).append(r)
                node = node.left
            num.append(_convert(node, where))
            return mul(*reversed(num), divisors=reversed(den))
        return power(_convert(node.left, where), _convert(node.right, where))
    if isinstance(node, ast.Call):
        return call(node.func.id, *(_convert(a, where) for a in node.args))
    raise ExpressionError(where, f"'{type(node).__name__}' construct is not allowed")  # pragma: no cover


def free_names(node: Node) -> set:
    """Names used in an expression (including ``pi`` if it appears)."""
    return set(free_names_cached(node))


def check_names(node: Node, names: Iterable[str], where: str, explain: Callable[[str], str | None] | None = None):
    """Refuse names outside ``names`` (``pi`` is always allowed).

    Parameters
    ----------
    explain : callable, optional
        ``explain(name)`` returns a specific reason for a refused name (for
        example "the excitation cannot depend on the dof 'x'") or None.
    """
    names = set(names)
    for name in sorted(free_names(node)):
        if name in names or name == "pi":
            continue
        reason = explain(name) if explain else None
        if reason is None:
            reason = f"unknown name '{name}'{suggest(name, sorted(names))}"
            if names:
                listed = sorted(names)
                more = ", ..." if len(listed) > 12 else ""
                reason += f"; known names: {', '.join(listed[:12])}{more}"
        raise ExpressionError(where, reason)


def measure(node: Node) -> tuple:
    """``(depth, size)`` of the expression tree, counting shared sub-expressions at every use.

    Iterative and memoised on the shared structure, so it is cheap even when
    substitution has made the tree exponentially large.
    """
    memo: dict = {}
    stack = [(node, False)]
    while stack:
        n, ready = stack.pop()
        if n in memo:
            continue
        kids = n.children()
        if ready or not kids:
            ds = [memo[c] for c in kids]
            memo[n] = (1 + max((d for d, _ in ds), default=0), 1 + sum(s for _, s in ds))
            continue
        stack.append((n, True))
        stack.extend((c, False) for c in kids if c not in memo)
    return memo[node]


def depth(node: Node) -> int:
    """Depth of the expression tree (see :func:`measure`)."""
    return measure(node)[0]


# ------------------------------------------------------------- evaluation
_NP = {"sin": np.sin, "cos": np.cos, "tan": np.tan, "exp": np.exp, "log": np.log, "sqrt": np.sqrt, "abs": np.abs,
       "sign": np.sign, "tanh": np.tanh, "min": np.minimum, "max": np.maximum}


def evaluate(node: Node, env: Mapping):
    """Value of an expression with numpy semantics (arrays broadcast; no exceptions on inf/nan).

    Parameters
    ----------
    env : mapping
        Name to number or array. ``pi`` defaults to ``math.pi``.
    """
    with np.errstate(all="ignore"):
        return _eval(node, env)


def _eval(n: Node, env):
    if isinstance(n, Num):
        return n.value
    if isinstance(n, Var):
        if n.name in env:
            return env[n.name]
        if n.name == "pi":
            return math.pi
        raise KeyError(n.name)
    if isinstance(n, Add):
        v = _eval(n.terms[0], env)
        for t in n.terms[1:]:
            v = v + _eval(t, env)
        return v
    if isinstance(n, Mul):
        v = 1.0
        for f in n.factors:
            v = v * _eval(f, env)
        for d in n.divisors:
            v = np.divide(v, _eval(d, env))
        return v
    if isinstance(n, Pow):
        return np.power(np.asarray(_eval(n.base, env), dtype=float), _eval(n.exp, env))
    if isinstance(n, Neg):
        return -_eval(n.arg, env)
    if isinstance(n, Call):
        return _NP[n.fn](*(np.asarray(_eval(a, env), dtype=float) for a in n.args))
    if isinstance(n, Select):
        return np.where(_eval(n.lhs, env) <= _eval(n.rhs, env), _eval(n.if_le, env), _eval(n.otherwise, env))
    raise TypeError(f"not an expression node: {n!r}")  # pragma: no cover


# -------------------------------------------------------- differentiation
def diff(node: Node, name: str, _memo: dict | None = None) -> Node:
    """Symbolic derivative ``d node / d name``, simplified.

    ``abs`` differentiates to ``sign``, ``sign`` to zero, ``min``/``max`` to
    the derivative of the selected argument (the first on ties).
    """
    memo = {} if _memo is None else _memo
    key = node
    if key in memo:
        return memo[key]
    if name not in free_names_cached(node):
        memo[key] = ZERO
        return ZERO
    d = _diff(node, name, memo)
    memo[key] = d
    return d


_FREE_CACHE: dict = {}


def free_names_cached(node: Node) -> frozenset:
    try:
        return _FREE_CACHE[node]
    except KeyError:
        pass
    if isinstance(node, Var):
        out = frozenset((node.name,))
    elif isinstance(node, Num):
        out = frozenset()
    else:
        out = frozenset().union(*(free_names_cached(c) for c in node.children()))
    if len(_FREE_CACHE) > 200_000:
        _FREE_CACHE.clear()
    _FREE_CACHE[node] = out
    return out


def _diff(n: Node, x: str, memo) -> Node:
    D = lambda a: diff(a, x, memo)  # noqa: E731
    if isinstance(n, Var):
        return ONE if n.name == x else ZERO
    if isinstance(n, Num):
        return ZERO
    if isinstance(n, Add):
        return add(*(D(t) for t in n.terms))
    if isinstance(n, Neg):
        return neg(D(n.arg))
    if isinstance(n, Mul):
        F, Dv = n.factors, n.divisors
        terms = []
        for i, f in enumerate(F):
            df = D(f)
            if df != ZERO:
                terms.append(mul(*F[:i], df, *F[i + 1:], divisors=Dv))
        for i, d in enumerate(Dv):
            dd = D(d)
            if dd != ZERO:
                terms.append(neg(mul(*F, dd, divisors=Dv + (d,))))
        return add(*terms)
    if isinstance(n, Pow):
        b, e = n.base, n.exp
        db = D(b)
        de = D(e)
        out = []
        if db != ZERO:
            if isinstance(e, Num):
                out.append(mul(Num(e.value), power(b, Num(e.value - 1.0)), db))
            else:
                out.append(mul(e, power(b, sub(e, ONE)), db))
        if de != ZERO:
            out.append(mul(n, call("log", b), de))
        return add(*out)
    if isinstance(n, Call):
        if n.fn in ("min", "max"):
            a, b = n.args
            da, db = D(a), D(b)
            # min: a' where a <= b; max: a' where b <= a
            return select(a, b, da, db) if n.fn == "min" else select(b, a, da, db)
        a = n.args[0]
        da = D(a)
        if da == ZERO or n.fn == "sign":
            return ZERO
        fn = n.fn
        if fn == "sin":
            g = call("cos", a)
        elif fn == "cos":
            g = neg(call("sin", a))
        elif fn == "tan":
            g = div(ONE, power(call("cos", a), Num(2.0)))
        elif fn == "exp":
            g = n
        elif fn == "log":
            return div(da, a)
        elif fn == "sqrt":
            return div(da, mul(Num(2.0), n))
        elif fn == "abs":
            g = call("sign", a)
        elif fn == "tanh":
            g = sub(ONE, power(n, Num(2.0)))
        else:  # pragma: no cover
            raise ValueError(f"no derivative rule for {fn}")
        return mul(g, da)
    if isinstance(n, Select):
        return select(n.lhs, n.rhs, D(n.if_le), D(n.otherwise))
    raise TypeError(f"not an expression node: {n!r}")  # pragma: no cover


def substitute(node: Node, mapping: Mapping[str, Node]) -> Node:
    """Replace names by expressions (re-simplifying on the way up)."""
    if not mapping or not (free_names_cached(node) & set(mapping)):
        return node
    if isinstance(node, Var):
        return mapping[node.name]
    S = lambda a: substitute(a, mapping)  # noqa: E731
    if isinstance(node, Add):
        return add(*(S(t) for t in node.terms))
    if isinstance(node, Mul):
        return mul(*(S(f) for f in node.factors), divisors=[S(d) for d in node.divisors])
    if isinstance(node, Pow):
        return power(S(node.base), S(node.exp))
    if isinstance(node, Neg):
        return neg(S(node.arg))
    if isinstance(node, Call):
        return call(node.fn, *(S(a) for a in node.args))
    if isinstance(node, Select):
        return select(S(node.lhs), S(node.rhs), S(node.if_le), S(node.otherwise))
    return node  # pragma: no cover


# ------------------------------------------------------------ analysis
MAX_POLYNOMIAL_DEGREE = 32


def polynomial_degree(node: Node, state: Iterable[str]) -> int | None:
    """Degree of a polynomial in the ``state`` names, or None.

    Sub-expressions free of state names are coefficients (any function of
    parameters and ``tau``). Degrees above :data:`MAX_POLYNOMIAL_DEGREE`
    count as non-polynomial.
    """
    st = frozenset(state)
    d = _degree(node, st)
    return None if d is None or d > MAX_POLYNOMIAL_DEGREE else d


def _degree(n: Node, st) -> int | None:
    if not (free_names_cached(n) & st):
        return 0
    if isinstance(n, Var):
        return 1
    if isinstance(n, Add):
        ds = [_degree(t, st) for t in n.terms]
        return None if None in ds else max(ds)
    if isinstance(n, Neg):
        return _degree(n.arg, st)
    if isinstance(n, Mul):
        if any(free_names_cached(d) & st for d in n.divisors):
            return None
        total = 0
        for f in n.factors:
            d = _degree(f, st)
            if d is None:
                return None
            total += d
            if total > MAX_POLYNOMIAL_DEGREE:
                return None
        return total
    if isinstance(n, Pow):
        e = n.exp
        if isinstance(e, Num) and e.value >= 0 and e.value == int(e.value) and e.value <= MAX_POLYNOMIAL_DEGREE:
            d = _degree(n.base, st)
            return None if d is None else d * int(e.value)
        return None
    return None  # functions of state (abs, sin(x), min, ...) are not polynomials


def _linear_in_tau(arg: Node) -> float | None:
    """``k`` if ``arg = k*tau + c`` with numeric ``k`` and a tau-free ``c``, else None."""
    c = diff(arg, "tau")
    if not isinstance(c, Num):
        return None
    return abs(c.value)


def tau_orders(node: Node) -> tuple | None:
    """Multiples ``k`` of ``tau`` in ``sin(k*tau + c)``/``cos(k*tau + c)`` factors.

    Returns
    -------
    tuple of float, or None
        None if ``tau`` also appears in another form (orders not detectable).
    """
    if "tau" not in free_names_cached(node):
        return ()
    found, stack = set(), [node]
    while stack:
        n = stack.pop()
        if "tau" not in free_names_cached(n):
            continue
        if isinstance(n, Var):
            return None
        if isinstance(n, Call) and n.fn in ("sin", "cos"):
            k = _linear_in_tau(n.args[0])
            if k is None:
                return None
            if k != 0.0:
                found.add(k)
            continue
        stack.extend(n.children())
    return tuple(sorted(found))


def harmonic_bound(node: Node) -> float | None:
    """Highest multiple of ``tau`` in a trigonometric polynomial in ``tau``, or None if unbounded/unknown."""
    return _hb(node)


def _hb(n: Node):
    if "tau" not in free_names_cached(n):
        return 0.0
    if isinstance(n, Call) and n.fn in ("sin", "cos"):
        return _linear_in_tau(n.args[0])
    if isinstance(n, Add):
        vals = [_hb(t) for t in n.terms]
        return None if None in vals else max(vals)
    if isinstance(n, Neg):
        return _hb(n.arg)
    if isinstance(n, Mul):
        if any("tau" in free_names_cached(d) for d in n.divisors):
            return None
        vals = [_hb(f) for f in n.factors]
        return None if None in vals else float(sum(vals))
    if isinstance(n, Pow):
        e = n.exp
        if isinstance(e, Num) and e.value >= 0 and e.value == int(e.value) and e.value <= 64:
            b = _hb(n.base)
            return None if b is None else b * e.value
        return None
    return None


# -------------------------------------------------------------- printing
_PREC = {Add: 1, Neg: 2, Mul: 2, Pow: 4}


def _num_text(v: float) -> str:
    if v == int(v) and abs(v) < 1e15:
        return str(int(v))
    return repr(v)


class _Printer:
    """Text of nodes; ``numba`` selects generated-code spelling, ``temps`` maps nodes to temporaries."""

    def __init__(self, name_of, numba: bool, temps: dict | None = None):
        self.name_of, self.numba = name_of, numba
        self.temps = {} if temps is None else temps

    def text(self, n: Node) -> str:
        if n in self.temps:
            return self.temps[n]
        numba = self.numba
        if isinstance(n, Num):
            if not math.isfinite(n.value):
                return ("np.inf" if n.value > 0 else "-np.inf") if numba else repr(n.value)
            return repr(n.value) if numba else _num_text(n.value)
        if isinstance(n, Var):
            return self.name_of(n.name)
        T = self.wrap
        if isinstance(n, Add):
            parts = [T(n.terms[0], 1)]
            for t in n.terms[1:]:
                if isinstance(t, Neg) and t not in self.temps:
                    parts.append(" - " + T(t.arg, 2))
                elif isinstance(t, Num) and t.value < 0:
                    parts.append(" - " + self.text(Num(-t.value)))
                else:
                    parts.append(" + " + T(t, 1))
            return "".join(parts)
        if isinstance(n, Neg):
            return "-" + T(n.arg, 3)
        if isinstance(n, Mul):
            s = "*".join(T(f, 3) if i else T(f, 2) for i, f in enumerate(n.factors)) or ("1.0" if numba else "1")
            for d in n.divisors:
                s += "/" + T(d, 3)
            return s
        if isinstance(n, Pow):
            e = n.exp
            if numba and isinstance(e, Num) and e.value == int(e.value) and abs(e.value) <= 2 ** 31:
                et = str(int(e.value))  # an integer literal lets numba use repeated multiplication
                et = f"({et})" if e.value < 0 else et
            else:
                et = T(e, 4)
            return T(n.base, 5) + "**" + et
        if isinstance(n, Call):
            fn = n.fn
            args = ", ".join(self.text(a) for a in n.args)
            if numba and fn not in ("abs", "min", "max"):
                fn = "np." + fn
            return f"{fn}({args})"
        if isinstance(n, Select):
            cond = f"{self.text(n.lhs)} <= {self.text(n.rhs)}"
            if numba:
                return f"({self.text(n.if_le)} if {cond} else {self.text(n.otherwise)})"
            return f"select({cond}: {self.text(n.if_le)}, {self.text(n.otherwise)})"
        raise TypeError(f"not an expression node: {n!r}")  # pragma: no cover

    def wrap(self, n: Node, min_prec: int) -> str:
        s = self.text(n)
        if n in self.temps:
            return s
        if isinstance(n, Num):
            return f"({s})" if (n.value < 0 and min_prec >= 3) or s.startswith("-") and min_prec >= 3 else s
        p = _PREC.get(type(n), 9)
        return f"({s})" if p < min_prec else s


def to_text(node: Node) -> str:
    """Readable text of an expression (same syntax as the input)."""
    return _Printer(lambda name: name, False).text(node)


def to_source(node: Node, name_of: Callable[[str], str]) -> str:
    """Python source of an expression for numba, names mapped by ``name_of`` (e.g. ``x -> "x[j, 0]"``)."""
    return _Printer(name_of, True).text(node)


class CodeWriter:
    """Python statements for several expressions, shared sub-expressions computed once.

    Sub-expressions used more than once, or nested deeper than
    :attr:`INLINE_DEPTH` levels, are assigned to temporaries ``_t0, _t1, ...``
    so the generated code stays shallow (Python's parser limits nesting) and
    repeated work is done once.

    Parameters
    ----------
    name_of : callable
        Maps a name to its source text, e.g. ``"x" -> "x[j, 0]"``.
    prefix : str
        Prefix of temporary names.

    Examples
    --------
    >>> w = CodeWriter(lambda s: s)
    >>> e = parse("sin(x)**2 + sin(x)")
    >>> w.count(e)
    >>> text = w.emit(e)
    >>> w.lines, text
    (['_t0 = np.sin(x)'], '_t0**2 + _t0')
    """

    INLINE_DEPTH = 6

    def __init__(self, name_of: Callable[[str], str], prefix: str = "_t"):
        self.prefix = prefix
        self.lines: list[str] = []
        self._temps: dict = {}
        self._uses: dict = {}
        self._depth: dict = {}
        self._printer = _Printer(name_of, True, self._temps)

    def count(self, node: Node) -> None:
        """Register a use of ``node`` (call for every expression before :meth:`emit`)."""
        stack = [node]
        while stack:
            n = stack.pop()
            if isinstance(n, (Num, Var)):
                continue
            seen = self._uses.get(n, 0)
            self._uses[n] = seen + 1
            if seen == 0:
                stack.extend(n.children())

    def emit(self, node: Node) -> str:
        """Source text of ``node``; the temporaries it needs are appended to :attr:`lines`."""
        self._prepare(node)
        return self._printer.text(node)

    def assign(self, node: Node) -> str:
        """Name of a temporary holding ``node`` (created, with its statement, if needed)."""
        text = self.emit(node)
        if node not in self._temps:
            t = f"{self.prefix}{len(self._temps)}"
            self.lines.append(f"{t} = {text}")
            self._temps[node] = t
        return self._temps[node]

    def bind(self, node: Node, text: str) -> None:
        """Use ``text`` for ``node`` (a value computed elsewhere, e.g. before a loop)."""
        self._temps[node] = text

    def _prepare(self, n: Node) -> int:
        # post-order: decide temporaries bottom-up; returns the inline nesting depth of n
        if n in self._temps or isinstance(n, (Num, Var)):
            return 0
        if n in self._depth:
            return self._depth[n]
        d = 1 + max((self._prepare(c) for c in n.children()), default=0)
        if self._uses.get(n, 0) > 1 or d > self.INLINE_DEPTH:
            t = f"{self.prefix}{len(self._temps)}"
            self.lines.append(f"{t} = {self._printer.text(n)}")
            self._temps[n] = t
            d = 0
        self._depth[n] = d
        return d
