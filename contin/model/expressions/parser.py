"""Reading expression text: the whitelist, the limits on length and nesting, and the refusals naming the construct.

The grammar and the whitelist are described in :mod:`contin.model.expressions`.
The text is parsed by ``ast.parse(text, mode="eval")`` after the length and
bracket-nesting pre-check, the tree is checked node by node, and only then
converted to :class:`~contin.model.expressions.Node` objects through the
simplifying constructors. The text is never passed to ``eval`` or ``exec``.
"""

from __future__ import annotations

import ast
import math
import re
import unicodedata
import warnings
from typing import Callable, Iterable

import numpy as np

from contin.model.expressions.algebra import add, call, mul, neg, power
from contin.model.expressions.nodes import Node, Num, Var, free_names
from contin.util.naming import suggest

__all__ = ["MAX_LENGTH", "MAX_DEPTH", "FUNCTIONS", "ExpressionError", "parse", "check_names"]

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

#: known names listed in the message refusing an unknown one
_LISTED_NAMES = 12


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


def check_names(node: Node, names: Iterable[str], where: str, explain: Callable[[str], str | None] | None = None):
    """Refuse names outside ``names`` (``pi`` is always allowed).

    Parameters
    ----------
    node : Node
        The expression.
    names : iterable of str
        The names it may use.
    where : str
        Key named in error messages.
    explain : callable, optional
        ``explain(name)`` returns a specific reason for a refused name (for
        example "the excitation cannot depend on the dof 'x'") or None.

    Raises
    ------
    ExpressionError
        For the first refused name in alphabetical order, with a "did you
        mean" hint and the known names.
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
                more = ", ..." if len(listed) > _LISTED_NAMES else ""
                reason += f"; known names: {', '.join(listed[:_LISTED_NAMES])}{more}"
        raise ExpressionError(where, reason)
