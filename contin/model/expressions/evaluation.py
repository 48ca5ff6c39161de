"""Numeric values of expressions with numpy semantics: arrays broadcast, inf and nan propagate."""

from __future__ import annotations

import math
from typing import Mapping

import numpy as np

from contin.model.expressions.nodes import Add, Call, Mul, Neg, Node, Num, Pow, Select, Var

__all__ = ["evaluate"]

_NP = {"sin": np.sin, "cos": np.cos, "tan": np.tan, "exp": np.exp, "log": np.log, "sqrt": np.sqrt, "abs": np.abs,
       "sign": np.sign, "tanh": np.tanh, "min": np.minimum, "max": np.maximum}


def evaluate(node: Node, env: Mapping):
    """Value of an expression with numpy semantics (arrays broadcast; no exceptions on inf/nan).

    Parameters
    ----------
    node : Node
        The expression.
    env : mapping
        Name to number or array. ``pi`` defaults to ``math.pi``.

    Returns
    -------
    float or ndarray
        Of the broadcast shape of the values the expression uses (a scalar
        when they are scalars).

    Raises
    ------
    KeyError
        A name missing from ``env``.
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
