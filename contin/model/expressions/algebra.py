"""Building expressions: sums, products, powers and calls with trivial simplifications; substitution.

Every node made by the parser, by differentiation and by substitution goes
through these constructors, so nested sums and products are flattened,
numbers are folded, zeros and ones vanish, and calls and powers of numbers
are computed, as long as the folded value stays finite (an overflow keeps the
numbers apart, as the arithmetic at run time would).
"""

from __future__ import annotations

import math
from typing import Iterable, Mapping

import numpy as np

from contin.model.expressions.nodes import (ONE, ZERO, Add, Call, Mul, Neg, Node, Num, Pow, Select, Var,
                                            free_names_cached)

__all__ = ["add", "sub", "neg", "mul", "div", "power", "call", "select", "substitute"]


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
    """``-a``: a number negated, a double negation removed, the sign folded into a leading number."""
    if isinstance(a, Num):
        return Num(-a.value)
    if isinstance(a, Neg):
        return a.arg
    if isinstance(a, Mul) and a.factors and isinstance(a.factors[0], Num):
        return mul(*a.factors, Num(-1.0), divisors=a.divisors)
    return Neg(a)


def sub(a: Node, b: Node) -> Node:
    """``a - b``, as ``add(a, neg(b))``."""
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
    """``a / b``, as a product with the divisor ``b``."""
    return mul(a, divisors=(b,))


def power(base: Node, exp: Node) -> Node:
    """``base ** exp``: ``a**0 -> 1``, ``a**1 -> a``, ``1**a -> 1``, finite powers of numbers computed."""
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
    """``fn(*args)``, computed when every argument is a number and the value is finite."""
    if all(isinstance(a, Num) for a in args):
        try:
            v = float(_NUMERIC[fn](*(a.value for a in args)))
        except (OverflowError, ValueError, ZeroDivisionError):
            v = None
        if _finite(v):
            return Num(v)
    return Call(fn, args)


def select(lhs: Node, rhs: Node, if_le: Node, otherwise: Node) -> Node:
    """``if_le if lhs <= rhs else otherwise``, decided now when both sides are numbers or both branches agree."""
    if if_le == otherwise:
        return if_le
    if isinstance(lhs, Num) and isinstance(rhs, Num):
        return if_le if lhs.value <= rhs.value else otherwise
    return Select(lhs, rhs, if_le, otherwise)


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
