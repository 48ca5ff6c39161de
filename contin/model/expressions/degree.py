"""How an expression depends on the state and on ``tau``: polynomial degree and trigonometric orders.

They tell harmonic balance the degree of a force (hence its samples per
period) and which harmonics an excitation holds.
"""

from __future__ import annotations

from typing import Iterable

from contin.model.expressions.derivative import diff
from contin.model.expressions.nodes import Add, Call, Mul, Neg, Node, Num, Pow, Var, free_names_cached

__all__ = ["MAX_POLYNOMIAL_DEGREE", "polynomial_degree", "tau_orders", "harmonic_bound"]

#: highest degree counted as a polynomial (higher ones count as non-polynomial)
MAX_POLYNOMIAL_DEGREE = 32
#: highest integer power of a trigonometric polynomial in tau whose order is bounded
_MAX_TAU_POWER = 64


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
        if isinstance(e, Num) and e.value >= 0 and e.value == int(e.value) and e.value <= _MAX_TAU_POWER:
            b = _hb(n.base)
            return None if b is None else b * e.value
        return None
    return None
