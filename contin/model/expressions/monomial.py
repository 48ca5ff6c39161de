"""Coefficients that are a constant times integer powers of parameters, read through the expression parser.

Matrix entries, force coefficients and amplitudes of the built-in models are
such monomials (``"-0.5*k*w**2"``, ``"k/m"``, ``"2*pi*f"``); their values and
parameter derivatives then have a closed form. The text follows the grammar of
:mod:`contin.model.expressions`; a sum, a function call or a non-integer power
is refused, naming the part that is not a product.
"""

from __future__ import annotations

import math
from typing import Sequence

from contin.model.expressions.nodes import Add, Call, Mul, Neg, Node, Num, Pow, Var, free_names, to_text
from contin.model.expressions.parser import ExpressionError, parse
from contin.util.naming import suggest

__all__ = ["parse_monomial"]

#: what a refusal shows of the offending text (characters)
_SHOWN = 60


def parse_monomial(text, names: Sequence[str], where: str = "coefficient") -> tuple[float, tuple[tuple[int, int], ...]]:
    """Read a coefficient ``const * prod_j p[j]**e_j`` over the parameters ``names``.

    Parameters
    ----------
    text : str or number
        A number, or a product of numbers and integer powers of parameters,
        such as ``"-0.5*k*w**2"``, ``"k/m"`` or ``"(k*w)**2"``. ``pi`` is the
        constant unless it is one of ``names``.
    names : sequence of str
        The parameters, in the order of the parameter vector ``p``.
    where : str
        Key named in error messages, e.g. ``"model.stiffness[0][1]"``.

    Returns
    -------
    const : float
        The finite constant factor.
    powers : tuple of (int, int)
        ``(j, e)`` pairs: parameter index ``j`` into ``names`` and its integer
        power ``e`` (negative for divisors), sorted by ``j``, each index once,
        no zero powers. The coefficient is
        ``const * prod(p[j]**e for j, e in powers)``.

    Raises
    ------
    ExpressionError
        A :class:`ValueError` naming ``where``: text refused by :func:`parse`,
        an unknown name (``"unknown parameter 'kk' in 'kk*x' (did you mean
        'k'?)"``), a sum, a call, a non-integer power, a division by zero or a
        constant that is not finite.

    Examples
    --------
    >>> parse_monomial("-0.5*k*w**2", ["w", "k"])
    (-0.5, ((0, 2), (1, 1)))
    >>> parse_monomial(3, ["w"])
    (3.0, ())
    """
    node = parse(text, where)
    index: dict[str, int] = {}
    for j, name in enumerate(names):
        index.setdefault(name, j)
    shown = _shown(text)
    for name in sorted(free_names(node)):
        if name not in index and name != "pi":
            raise ExpressionError(where, f"unknown parameter '{name}' in {shown}{suggest(name, list(names))}")
    const, powers = _factors(node, index, shown, where)
    if not math.isfinite(const):
        raise ExpressionError(where, f"the constant factor of {shown} is not finite")
    return const, tuple(sorted((j, e) for j, e in powers.items() if e != 0))


def _shown(text) -> str:
    s = repr(text) if isinstance(text, str) else repr(str(text))
    return s if len(s) <= _SHOWN else s[: _SHOWN - 4] + "...'"


def _factors(node: Node, index: dict, shown: str, where: str) -> tuple[float, dict]:
    """``(const, {j: e})`` of a product; the recursion depth is bounded by the parser's nesting limit."""
    if isinstance(node, Num):
        return node.value, {}
    if isinstance(node, Var):
        if node.name in index:
            return 1.0, {index[node.name]: 1}
        return math.pi, {}  # the constant: every other name was checked
    if isinstance(node, Neg):
        const, powers = _factors(node.arg, index, shown, where)
        return -const, powers
    if isinstance(node, Mul):
        const, powers = 1.0, {}
        for part, sign in [(f, 1) for f in node.factors] + [(d, -1) for d in node.divisors]:
            c, p = _factors(part, index, shown, where)
            if sign > 0:
                const *= c
            elif c == 0.0:
                raise ExpressionError(where, f"division by zero in {shown}")
            else:
                const /= c
            for j, e in p.items():
                powers[j] = powers.get(j, 0) + sign * e
        return const, powers
    if isinstance(node, Pow):
        e = node.exp
        if not (isinstance(e, Num) and e.value == int(e.value)):
            raise ExpressionError(where, f"power of '{to_text(node.base)}' must be an integer in {shown}")
        k = int(e.value)
        const, powers = _factors(node.base, index, shown, where)
        if const == 0.0 and k < 0:
            raise ExpressionError(where, f"division by zero in {shown}")
        try:
            const = const ** k
        except OverflowError:
            const = math.inf
        return const, {j: p * k for j, p in powers.items()}
    kind = f"a call of {node.fn}()" if isinstance(node, Call) else "a sum" if isinstance(node, Add) else "a selection"
    raise ExpressionError(where, f"expected a number or a product of powers of parameters (such as '-0.5*k*w**2') "
                                 f"in {shown}, found {kind}: '{to_text(node)}'")
