"""The expression tree: immutable node types, their text, and queries of their structure.

Nodes are built by the parser (:mod:`contin.model.expressions.parser`) and by
the simplifying constructors of :mod:`contin.model.expressions.algebra`; the
classes here do no simplification themselves. Sums and products are n-ary, so
long sums stay shallow. A node's ``repr`` is its text in the input syntax, so
the printer lives with the node types; its numba spelling is used by
:mod:`contin.model.expressions.source`.
"""

from __future__ import annotations

import math
from typing import Callable

__all__ = [
    "Node",
    "Num",
    "Var",
    "Add",
    "Mul",
    "Pow",
    "Neg",
    "Call",
    "Select",
    "ZERO",
    "ONE",
    "free_names",
    "free_names_cached",
    "measure",
    "depth",
    "Printer",
    "to_text",
]


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
    """``fn(*args)`` for a function of :data:`contin.model.expressions.FUNCTIONS`."""

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


# ------------------------------------------------------------- structure
_FREE_CACHE: dict = {}
#: entries of the free-name cache before it is emptied (bounds its memory)
_FREE_CACHE_SIZE = 200_000


def free_names_cached(node: Node) -> frozenset:
    """Names used in an expression, memoised on the (shared, immutable) nodes.

    Returns
    -------
    frozenset of str
        Including ``pi`` if it appears.
    """
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
    if len(_FREE_CACHE) > _FREE_CACHE_SIZE:
        _FREE_CACHE.clear()
    _FREE_CACHE[node] = out
    return out


def free_names(node: Node) -> set:
    """Names used in an expression (including ``pi`` if it appears)."""
    return set(free_names_cached(node))


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


# -------------------------------------------------------------- printing
_PREC = {Add: 1, Neg: 2, Mul: 2, Pow: 4}


def _num_text(v: float) -> str:
    if v == int(v) and abs(v) < 1e15:
        return str(int(v))
    return repr(v)


class Printer:
    """Text of nodes, in the input syntax or spelt for generated numba code.

    Parameters
    ----------
    name_of : callable
        Maps a name to its text, e.g. ``"x" -> "x[j, 0]"``.
    numba : bool
        Generated-code spelling (``np.sin``, float literals, ``... if ... else ...``).
    temps : dict, optional
        Node to the name of a temporary that holds it (shared with
        :class:`contin.model.expressions.CodeWriter`).
    """

    def __init__(self, name_of: Callable[[str], str], numba: bool, temps: dict | None = None):
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
        """Text of ``n``, in parentheses if it binds less tightly than ``min_prec``."""
        s = self.text(n)
        if n in self.temps:
            return s
        if isinstance(n, Num):
            return f"({s})" if (n.value < 0 and min_prec >= 3) or s.startswith("-") and min_prec >= 3 else s
        p = _PREC.get(type(n), 9)
        return f"({s})" if p < min_prec else s


def to_text(node: Node) -> str:
    """Readable text of an expression (same syntax as the input)."""
    return Printer(lambda name: name, False).text(node)
