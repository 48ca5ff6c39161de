"""Symbolic derivatives of expressions, simplified by the constructors of :mod:`contin.model.expressions.algebra`.

Derivatives are memoised per call on the shared sub-expressions, and a
sub-expression free of the variable differentiates to zero without a walk
(:func:`~contin.model.expressions.free_names_cached`).
"""

from __future__ import annotations

from contin.model.expressions.algebra import add, call, div, mul, neg, power, select, sub
from contin.model.expressions.nodes import (ONE, ZERO, Add, Call, Mul, Neg, Node, Num, Pow, Select, Var,
                                            free_names_cached)

__all__ = ["diff"]


def diff(node: Node, name: str, _memo: dict | None = None) -> Node:
    """Symbolic derivative ``d node / d name``, simplified.

    ``abs`` differentiates to ``sign``, ``sign`` to zero, ``min``/``max`` to
    the derivative of the selected argument (the first on ties).

    Parameters
    ----------
    node : Node
        The expression.
    name : str
        The variable.
    _memo : dict, optional
        Derivatives of sub-expressions already taken with respect to ``name``
        (filled by the recursion, so shared sub-expressions are differentiated once).

    Returns
    -------
    Node
        ``ZERO`` when ``name`` does not occur in ``node``.
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
