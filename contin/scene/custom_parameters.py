"""The parameters of a custom scene model: independent values and dependent expressions.

A parameter is a number or an expression of other parameters (for example
``F: "0.1*w**2"``). Definitions are resolved in dependency order (a cycle is
an error naming its parameters) and every *dependent* parameter is inlined
into the expressions that use it, so it stays a function of the independent
ones: continuing in ``w`` moves ``F`` along. Only the *independent*
parameters (those given as numbers, or as expressions without names) form
the model's parameter vector ``Model.parameters``; continuing in a dependent
parameter is refused (:func:`check_continuation_parameter`). The dependent
ones are kept in ``model.dependent_parameters`` (name to
:class:`~contin.model.elements.expression.ExpressionCoefficient`, whose
``value(p)`` gives their value).

Every problem is reported through the ``error`` callable of the custom
model's builder (:mod:`contin.scene.custom_model`), as a
:class:`contin.scene.parse.SceneError` naming the dotted key.
"""

from __future__ import annotations

import keyword
import math
from typing import Callable, Iterable

from contin.model import expressions as ex
from contin.model.base import Model
from contin.model.elements.registry import shorten
from contin.util.naming import is_finite_real, is_real
from contin.scene.parse import SceneError

__all__ = ["check_continuation_parameter", "resolve_parameters", "check_size", "RESERVED", "MAX_RESOLVED_DEPTH",
           "MAX_RESOLVED_SIZE"]

#: deepest expression accepted after dependent parameters are inlined
MAX_RESOLVED_DEPTH = 2 * ex.MAX_DEPTH
#: largest expression (tree nodes, shared parts counted at each use) after inlining
MAX_RESOLVED_SIZE = 20_000
#: names no parameter or dof may take
RESERVED = {"tau", "pi"} | set(ex.FUNCTIONS)


def check_continuation_parameter(model: Model, name: str, key: str = "analysis.parameter",
                                 lines: dict | None = None) -> None:
    """Refuse continuation in a dependent parameter of a custom model.

    Parameters
    ----------
    model : Model
        A model from :func:`build_custom_model` (other models pass).
    name : str
        The parameter the analysis would vary.
    key : str
        Scene key named in the error.
    lines : dict, optional
        ``scene.lines``, for the line number.

    Raises
    ------
    SceneError
        If ``name`` is a dependent parameter (an expression of others).
    """
    dep = getattr(model, "dependent_parameters", None) or {}
    if name in dep:
        raise SceneError(key, f"an independent parameter (one of {list(model.parameters)})", name,
                         (lines or {}).get(key),
                         hint=f"; '{name}' is defined as {dep[name].text!r} and follows the parameters it uses: "
                              f"continue in one of those, or give '{name}' a number")


def resolve_parameters(params: dict, error: Callable[..., SceneError], reserved: Iterable[str] = ()):
    """Split parameters into independent values and resolved dependent expressions.

    Parameters
    ----------
    params : dict
        ``model.parameters``: name to a number or an expression text.
    error : callable
        ``error(key, expected, found, hint) -> SceneError``.
    reserved : iterable of str
        Names that parameters may not use (dofs, velocities).

    Returns
    -------
    independent : dict
        Name to float, in the scene's order.
    dependent : dict
        Name to :class:`contin.model.expressions.Node` in the independent names
        only, in dependency order.
    """
    reserved = set(reserved)
    names = list(params)
    for q in names:
        key = f"model.parameters.{q}"
        if not isinstance(q, str) or not q.isidentifier() or keyword.iskeyword(q):
            raise error(key, "a parameter name that is a valid identifier", q)
        if q.startswith("__"):
            raise error(key, "a parameter name not starting with '__'", q)
        if q in RESERVED - {"pi"}:
            raise error(key, "a parameter name that is not reserved", q,
                        hint=f"; '{q}' is {'the excitation phase' if q == 'tau' else 'a function'}")
        if q in reserved:
            raise error(key, "a parameter name different from the dofs and their velocities", q)
    independent: dict = {}
    pending: dict = {}
    for q in names:
        key = f"model.parameters.{q}"
        v = params[q]
        if is_real(v):
            if not is_finite_real(v):
                raise error(key, "a finite number or an expression of other parameters", v)
            independent[q] = float(v)
            continue
        if not isinstance(v, str):
            raise error(key, "a number or an expression of other parameters", shorten(v))

        def explain(name, _q=q):
            if name in reserved or name == "tau":
                return f"a parameter cannot depend on '{name}' (only on other parameters)"
            if name == _q:
                return f"parameter '{_q}' is defined in terms of itself"
            return None

        try:
            node = ex.parse(v, key)
            ex.check_names(node, names, key, explain)
        except ex.ExpressionError as exc:
            raise error(key, "a number or an expression of other parameters", shorten(v), "; " + exc.reason) from None
        constants = set() if "pi" in params else {"pi"}
        if not ex.free_names(node) - constants:
            val = float(ex.evaluate(node, {}))
            if not math.isfinite(val):
                raise error(key, "a finite value", shorten(v), f"; it evaluates to {val}")
            independent[q] = val
            continue
        pending[q] = node
    # dependency order (Kahn): what remains is on or behind a cycle
    deps = {q: {d for d in ex.free_names(n) if d in pending} for q, n in pending.items()}
    order, ready = [], [q for q in pending if not deps[q]]
    users: dict = {q: [] for q in pending}
    for q, ds in deps.items():
        for d in ds:
            users[d].append(q)
    left = {q: len(ds) for q, ds in deps.items()}
    while ready:
        q = ready.pop(0)
        order.append(q)
        for u in users[q]:
            left[u] -= 1
            if left[u] == 0:
                ready.append(u)
    if len(order) < len(pending):
        stuck = [q for q in pending if q not in order]
        start = stuck[0]
        path, seen, q = [], {}, start
        while q not in seen:  # follow unresolved dependencies until one repeats: a cycle
            seen[q] = len(path)
            path.append(q)
            q = sorted(d for d in deps[q] if d in stuck)[0]
        cycle = path[seen[q]:] + [q]
        raise error(f"model.parameters.{cycle[0]}", "parameter definitions without a cycle", None,
                    "; the parameters " + " -> ".join(cycle) + " depend on each other")
    dependent: dict = {}
    for q in order:
        key = f"model.parameters.{q}"
        node = ex.substitute(pending[q], dependent)
        check_size(node, key, error)
        dependent[q] = node
    return independent, dependent


def check_size(node, key, error):
    """Refuse an expression too large once the dependent parameters are inlined (``error`` as above)."""
    d, s = ex.measure(node)
    if d > MAX_RESOLVED_DEPTH or s > MAX_RESOLVED_SIZE:
        raise error(key, "an expression of moderate size", None,
                    f"; with the dependent parameters inlined it has depth {d} and {s} nodes "
                    f"(limits {MAX_RESOLVED_DEPTH} and {MAX_RESOLVED_SIZE})")
