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
input can exhaust the parser's or this package's recursion. The text is never
passed to ``eval`` or ``exec``.

The name ``pi`` is a constant unless a parameter of that name is defined.

The package holds one idea per module; every name below is importable from
the package itself (``from contin.model import expressions as ex``):

- :mod:`~contin.model.expressions.parser`: the whitelist, the limits,
  :func:`parse`, :func:`check_names`, :class:`ExpressionError`;
- :mod:`~contin.model.expressions.nodes`: immutable :class:`Node` objects
  (sums and products are n-ary, so long sums stay shallow), their text
  (:func:`to_text`) and structure (:func:`free_names`, :func:`measure`);
- :mod:`~contin.model.expressions.algebra`: constructors that simplify
  trivial zeros and ones and fold numbers (:func:`add`, :func:`mul`, ...),
  and :func:`substitute`;
- :mod:`~contin.model.expressions.evaluation`: numeric values with numpy
  (:func:`evaluate`);
- :mod:`~contin.model.expressions.derivative`: symbolic differentiation
  (:func:`diff`);
- :mod:`~contin.model.expressions.degree`: polynomial degree in the state and
  tau-harmonic analysis (:func:`polynomial_degree`, :func:`tau_orders`,
  :func:`harmonic_bound`);
- :mod:`~contin.model.expressions.source`: Python source for numba
  (:func:`to_source`, :class:`CodeWriter`);
- :mod:`~contin.model.expressions.monomial`: coefficients that are a constant
  times integer powers of parameters (:func:`parse_monomial`).
"""

from contin.model.expressions.algebra import add, call, div, mul, neg, power, select, sub, substitute
from contin.model.expressions.degree import MAX_POLYNOMIAL_DEGREE, harmonic_bound, polynomial_degree, tau_orders
from contin.model.expressions.derivative import diff
from contin.model.expressions.evaluation import evaluate
from contin.model.expressions.monomial import parse_monomial
from contin.model.expressions.nodes import (ONE, ZERO, Add, Call, Mul, Neg, Node, Num, Pow, Select, Var, depth,
                                            free_names, free_names_cached, measure, to_text)
from contin.model.expressions.parser import FUNCTIONS, MAX_DEPTH, MAX_LENGTH, ExpressionError, check_names, parse
from contin.model.expressions.source import CodeWriter, to_source

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
    "parse_monomial",
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
    "MAX_POLYNOMIAL_DEGREE",
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
