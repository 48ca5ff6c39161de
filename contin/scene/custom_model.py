"""Custom models from the ``model:`` section of a scene (SPEC 4.2).

A custom model is

    M(p) x'' + C(p) x' + K(p) x + sum(forces) = sum(excitation)

with dof names, parameters, matrices whose entries are numbers or
expressions of parameters, optional gyroscopic terms ``speed * G`` added to
the damping matrix, internal forces (expressions in dofs, velocities
``NAME_dot``, the phase ``tau`` and parameters, or contact elements ``gap``
and ``radial_gap``) and external forces (expressions in ``tau`` and
parameters, harmonic or constant forcing). Expressions are parsed by
:mod:`contin.model.expressions`, never evaluated as Python.

Parameters
----------
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

Every problem is reported as a :class:`contin.scene.parse.SceneError` naming the
dotted key (``model.forces[2].clearance``), with the YAML line where known.
"""

from __future__ import annotations

import keyword
import math
from typing import Any, Callable, Iterable

import numpy as np

from contin.model import expressions as ex
from contin.model.elements.expression import ExpressionCoefficient, ExpressionExcitation, ExpressionForce, state_names
from contin.model.elements.gap import GapForce, RadialGapForce
from contin.model.elements.harmonic import HarmonicExcitation
from contin.model.base import Model, Monomial, ParametricMatrix
from contin.util.naming import is_finite_real, is_real, suggest
from contin.scene.parse import Scene, SceneError

__all__ = ["build_custom_model", "check_continuation_parameter", "resolve_parameters", "FORCE_KEYS",
           "EXCITATION_KEYS", "MAX_RESOLVED_DEPTH", "MAX_RESOLVED_SIZE"]

#: deepest expression accepted after dependent parameters are inlined
MAX_RESOLVED_DEPTH = 2 * ex.MAX_DEPTH
#: largest expression (tree nodes, shared parts counted at each use) after inlining
MAX_RESOLVED_SIZE = 20_000

FORCE_KEYS = {
    "expr": {"type": False, "dof": True, "expr": True},
    "gap": {"type": True, "dof": True, "clearance": True, "stiffness": True, "damping": False, "sides": False,
            "clip": False},
    "radial_gap": {"type": True, "dofs": True, "clearance": True, "stiffness": True, "damping": False,
                   "clip": False},
}
EXCITATION_KEYS = {
    "expr": {"dof": True, "expr": True},
    "amplitude": {"dof": True, "amplitude": True, "order": False, "phase": False},
    "constant": {"dof": True, "constant": True},
}
RESERVED = {"tau", "pi"} | set(ex.FUNCTIONS)


def _short(v: Any, limit: int = 80):
    if isinstance(v, str):
        return v if len(v) <= limit else v[: limit - 3] + "..."
    text = repr(v)
    return v if len(text) <= limit else text[: limit - 3] + "..."


def _parent(key: str) -> str | None:
    if key.endswith("]"):
        return key[: key.rindex("[")]
    if "." in key:
        return key.rsplit(".", 1)[0]
    return None


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
            raise error(key, "a number or an expression of other parameters", _short(v))

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
            raise error(key, "a number or an expression of other parameters", _short(v), "; " + exc.reason) from None
        constants = set() if "pi" in params else {"pi"}
        if not ex.free_names(node) - constants:
            val = float(ex.evaluate(node, {}))
            if not math.isfinite(val):
                raise error(key, "a finite value", _short(v), f"; it evaluates to {val}")
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
        _check_size(node, key, error)
        dependent[q] = node
    return independent, dependent


def _check_size(node, key, error):
    d, s = ex.measure(node)
    if d > MAX_RESOLVED_DEPTH or s > MAX_RESOLVED_SIZE:
        raise error(key, "an expression of moderate size", None,
                    f"; with the dependent parameters inlined it has depth {d} and {s} nodes "
                    f"(limits {MAX_RESOLVED_DEPTH} and {MAX_RESOLVED_SIZE})")


class _Builder:
    def __init__(self, scene: Scene):
        self.scene = scene
        self.m = scene.model
        self.lines = scene.lines

    # -- errors -----------------------------------------------------------
    def line(self, key: str):
        k = key
        while k:
            if k in self.lines:
                return self.lines[k]
            k = _parent(k)
        return None

    def error(self, key: str, expected: str, found: Any = None, hint: str = "") -> SceneError:
        return SceneError(key, expected, found, self.line(key), hint=hint)

    # -- names -------------------------------------------------------------
    def setup_names(self):
        dofs = self.m["dofs"]
        for i, d in enumerate(dofs):
            key = f"model.dofs[{i}]"
            if keyword.iskeyword(d) or d in RESERVED or d.startswith("__"):
                raise self.error(key, "a dof name that is not a keyword, a function name, 'tau' or 'pi'", d)
            if d.endswith("_dot") and d[:-4] in dofs:
                raise self.error(key, "dof names different from the velocity names", d,
                                 hint=f"; '{d}' is the velocity of '{d[:-4]}'")
        self.dofs = list(dofs)
        self.n = len(dofs)
        self.state = state_names(self.dofs)
        params = self.m["parameters"]
        self.independent, self.dependent = resolve_parameters(params, self.error, self.state)
        self.pnames = list(self.independent)
        self.all_params = list(params)

    def explain(self, allow_state: bool, allow_tau: bool):
        dofs = self.dofs

        def why(name):
            is_dof = name in dofs
            is_velocity = name.endswith("_dot") and name[:-4] in dofs
            if is_dof or is_velocity:
                what = "dof" if is_dof else "velocity"
                if allow_tau:
                    return (f"the excitation cannot depend on the {what} '{name}' "
                            f"(write state-dependent terms under model.forces)")
                return f"this entry may only use parameters, and '{name}' is a {what} of the model"
            if name == "tau" and not allow_tau:
                return "'tau' (the excitation phase) is not allowed here; this entry may only use parameters"
            if name.endswith("_dot") and allow_state:
                base = name[:-4]
                return (f"unknown velocity '{name}': '{base}' is not a degree of freedom{suggest(base, dofs)} "
                        f"(dofs: {', '.join(dofs)})")
            return None

        return why

    def expression(self, value, key: str, allow_state=False, allow_tau=False, what="an expression of parameters"):
        """Parse ``value`` at ``key`` and inline the dependent parameters."""
        names = set(self.all_params)
        if allow_state:
            names |= set(self.state)
        if allow_tau:
            names.add("tau")
        try:
            node = ex.parse(value, key)
            ex.check_names(node, names, key, self.explain(allow_state, allow_tau))
        except ex.ExpressionError as exc:
            raise self.error(key, what, _short(value), "; " + exc.reason) from None
        node = ex.substitute(node, self.dependent)
        _check_size(node, key, self.error)
        return node

    def coefficient(self, value, key: str, what="a number or an expression of parameters"):
        """A Monomial when the expression is a product of parameter powers, else an ExpressionCoefficient."""
        if value is None or isinstance(value, bool) or not isinstance(value, (int, float, str)):
            raise self.error(key, what, _short(value))
        return self.coefficient_of(self.expression(value, key, what=what), key, value)

    def coefficient_of(self, node, key: str, original):
        """Coefficient object of a parameter expression, checked finite at the default parameters."""
        mono = _monomial(node, self.pnames)
        coef = mono if mono is not None else ExpressionCoefficient(node, self.pnames, key)
        with np.errstate(all="ignore"):
            v = float(coef.value(self.p0))
        if not math.isfinite(v):
            raise self.error(key, "a finite value at the default parameters", _short(original),
                             f"; it evaluates to {v}")
        return coef

    # -- matrices ------------------------------------------------------------
    def shape_text(self):
        return f"a {self.n}x{self.n} matrix ({self.n} dof{'s' if self.n > 1 else ''}: {', '.join(self.dofs)})"

    def matrix(self, key: str, value, required=False, factor=None):
        n = self.n
        if value is None:
            if required:
                raise self.error(key, self.shape_text() + " (required)")
            return ParametricMatrix(n, ()), set()
        if n == 1 and (isinstance(value, (int, float, str)) and not isinstance(value, bool)):
            value = [[value]]
        if not isinstance(value, list):
            raise self.error(key, self.shape_text() + " as a list of rows", _short(value))
        if len(value) != n:
            raise self.error(key, self.shape_text(), None, f", found {len(value)} row{'s' if len(value) != 1 else ''}")
        terms, used = [], set()
        for i, row in enumerate(value):
            rkey = f"{key}[{i}]"
            if not isinstance(row, list):
                raise self.error(rkey, f"a row of {n} entries (numbers or expressions of parameters)", _short(row))
            if len(row) != n:
                raise self.error(rkey, f"a row of {n} entries ({n} dofs: {', '.join(self.dofs)})", None,
                                 f", found {len(row)} entr{'ies' if len(row) != 1 else 'y'}")
            for j, e in enumerate(row):
                ekey = f"{rkey}[{j}]"
                if e is None or isinstance(e, bool) or not isinstance(e, (int, float, str)):
                    raise self.error(ekey, "a number or an expression of parameters", _short(e))
                node = self.expression(e, ekey)
                if factor is not None:
                    node = ex.mul(factor, node)
                if node == ex.ZERO:
                    continue
                used |= ex.free_names(node) & set(self.pnames)
                coef = self.coefficient_of(node, ekey, e)
                A = np.zeros((n, n))
                A[i, j] = 1.0
                terms.append((coef, A))
        return ParametricMatrix(n, tuple(terms)), used

    # -- items ---------------------------------------------------------------
    def keys_of(self, item, key, allowed: dict, kind: str):
        for k in item:
            if k not in allowed:
                raise self.error(f"{key}.{k}",
                                 f"one of the keys {', '.join(allowed)} (for a {kind})", None,
                                 f"; unknown key '{k}'{suggest(k, allowed)}")
        for k, required in allowed.items():
            if required and item.get(k) is None:
                raise self.error(f"{key}.{k}", f"a value for '{k}' (required for a {kind})")

    def dof(self, value, key):
        if not isinstance(value, str) or value not in self.dofs:
            hint = suggest(value, self.dofs) if isinstance(value, str) else ""
            raise self.error(key, f"the name of a dof (one of {', '.join(self.dofs)})", _short(value), hint)
        return self.dofs.index(value)

    def number(self, value, key, default, minimum=None):
        if value is None:
            return default
        if not is_finite_real(value) or (minimum is not None and value < minimum):
            exp = "a finite number" if minimum is None else f"a number >= {minimum}"
            raise self.error(key, exp, _short(value))
        return float(value)

    def boolean(self, value, key, default=False):
        if value is None:
            return default
        if not isinstance(value, bool):
            raise self.error(key, "true or false", _short(value))
        return value

    def contact_values(self, item, key):
        """Clearance, stiffness and damping of a contact element; none of them may be negative.

        A negative clearance would put the stop inside the free play, a
        negative stiffness or damping would pull the body into the stop. Zero
        is allowed: a stop touching at rest, a stop without elastic or viscous
        force (a limiting case, e.g. in a sweep of the stiffness).
        """
        clearance = self.coefficient(item["clearance"], f"{key}.clearance")
        if clearance.value(self.p0) < 0:
            raise self.error(f"{key}.clearance", "a clearance >= 0 at the default parameters",
                             _short(item["clearance"]))
        stiffness = self.coefficient(item["stiffness"], f"{key}.stiffness")
        if stiffness.value(self.p0) < 0:
            raise self.error(f"{key}.stiffness", "a contact stiffness >= 0 at the default parameters (a negative "
                             "one would pull the body into the stop)", _short(item["stiffness"]),
                             f"; it is {stiffness.value(self.p0):g}")
        damping = item.get("damping")
        damping = self.coefficient(0.0 if damping is None else damping, f"{key}.damping")
        if damping.value(self.p0) < 0:
            raise self.error(f"{key}.damping", "a contact damping >= 0 at the default parameters (a negative one "
                             "would feed energy in at every impact)", _short(item["damping"]),
                             f"; it is {damping.value(self.p0):g}")
        return clearance, stiffness, damping

    def forces(self):
        items = self.m["forces"]
        expr_items, elements, kinds = [], [], []
        for i, item in enumerate(items):
            key = f"model.forces[{i}]"
            if not isinstance(item, dict):
                raise self.error(key, "a mapping such as {dof: x, expr: \"g*x**3\"} or {type: gap, dof: x, "
                                      "clearance: 0.1, stiffness: 1000}", _short(item))
            kind = item.get("type", "expr")
            if kind is None:
                kind = "expr"
            if not isinstance(kind, str) or kind not in FORCE_KEYS:
                raise self.error(f"{key}.type", "one of " + ", ".join(repr(k) for k in FORCE_KEYS), _short(kind),
                                 suggest(kind, FORCE_KEYS) if isinstance(kind, str) else "")
            self.keys_of(item, key, FORCE_KEYS[kind], f"'{kind}' force")
            if kind == "expr":
                d = self.dof(item["dof"], f"{key}.dof")
                node = self.expression(item["expr"], f"{key}.expr", allow_state=True, allow_tau=True,
                                       what="an expression of the dofs, their velocities NAME_dot, tau and parameters")
                expr_items.append((d, node, key))
                continue
            clearance, stiffness, damping = self.contact_values(item, key)
            clip = self.boolean(item.get("clip"), f"{key}.clip")
            label = f"forces[{i}] {kind}"
            if kind == "gap":
                d = self.dof(item["dof"], f"{key}.dof")
                sides = item.get("sides", "both")
                sides = "both" if sides is None else sides
                if sides not in ("+", "-", "both"):
                    raise self.error(f"{key}.sides", "one of '+', '-', 'both' (quote the signs in YAML: \"-\")",
                                     _short(sides))
                elements.append(GapForce(d, clearance, stiffness, damping, sides=sides, clip=clip, label=label))
            else:
                dofs = item["dofs"]
                if not isinstance(dofs, list) or len(dofs) != 2:
                    raise self.error(f"{key}.dofs", "a list of two dof names [X, Y]", _short(dofs))
                ix = self.dof(dofs[0], f"{key}.dofs[0]")
                iy = self.dof(dofs[1], f"{key}.dofs[1]")
                if ix == iy:
                    raise self.error(f"{key}.dofs", "two different dofs", dofs)
                elements.append(RadialGapForce((ix, iy), clearance, stiffness, damping, clip=clip, label=label))
            kinds.append(kind)
        if expr_items:
            try:
                force = ExpressionForce(self.dofs, self.pnames, [(d, node) for d, node, _ in expr_items],
                                        label="forces (expr)")
            except (RecursionError, SyntaxError, MemoryError) as exc:
                raise self.error("model.forces", "expressions that can be compiled", None,
                                 f"; code generation failed: {type(exc).__name__}: {exc}") from None
            elements.insert(0, force)
            kinds.insert(0, "expr")
        return elements, kinds

    def excitations(self):
        items = self.m["excitation"]
        exprs, elements = [], []
        for i, item in enumerate(items):
            key = f"model.excitation[{i}]"
            if not isinstance(item, dict):
                raise self.error(key, "a mapping such as {dof: x, expr: \"F*cos(tau)\"}, "
                                      "{dof: x, amplitude: F, order: 1, phase: 0} or {dof: x, constant: f0}",
                                 _short(item))
            present = [k for k in ("expr", "amplitude", "constant") if k in item]
            if len(present) != 1:
                raise self.error(key, "exactly one of the keys expr, amplitude, constant", None,
                                 f"; found {', '.join(present) if present else 'none'} "
                                 f"(keys: {', '.join(map(str, item))})")
            kind = present[0]
            self.keys_of(item, key, EXCITATION_KEYS[kind], f"'{kind}' excitation")
            d = self.dof(item["dof"], f"{key}.dof")
            if kind == "expr":
                node = self.expression(item["expr"], f"{key}.expr", allow_tau=True,
                                       what="an expression of tau and parameters")
                exprs.append((d, node))
                continue
            if kind == "amplitude":
                coef = self.coefficient(item["amplitude"], f"{key}.amplitude")
                order = self.number(item.get("order"), f"{key}.order", 1.0, minimum=0)
                phase = self.number(item.get("phase"), f"{key}.phase", 0.0)
            else:
                coef = self.coefficient(item["constant"], f"{key}.constant")
                order, phase = 0.0, 0.0
            if isinstance(coef, Monomial):
                elements.append(HarmonicExcitation(d, coef, order, phase, label=f"excitation[{i}]"))
            else:
                shape = ex.call("cos", ex.add(ex.mul(ex.Num(order), ex.Var("tau")), ex.Num(phase)))
                exprs.append((d, ex.mul(coef.node, shape)))
        if exprs:
            elements.insert(0, ExpressionExcitation(self.dofs, self.pnames, exprs, label="excitation (expr)"))
        return elements

    def check_mass(self, Mv: np.ndarray) -> None:
        """A mass matrix is symmetric positive definite: refuse one that is not (at the default parameters)."""
        given_as_rows = isinstance(self.m["mass"], list)
        for i in range(self.n):
            if not Mv[i, i] > 0:
                key = f"model.mass[{i}][{i}]" if given_as_rows else "model.mass"
                raise self.error(key, f"a positive mass on the diagonal (the inertia of dof {self.dofs[i]}: a mass "
                                 "matrix is positive definite)", _short(self.m["mass"][i][i] if given_as_rows
                                                                       else self.m["mass"]),
                                 f"; it is {Mv[i, i]:g} at the default parameters")
        scale = np.abs(Mv).max()
        asym = np.abs(Mv - Mv.T)
        if asym.max() > 1e-12 * scale:
            i, j = np.unravel_index(int(np.argmax(asym)), asym.shape)
            raise self.error("model.mass", "a symmetric matrix (a mass matrix is symmetric positive definite)", None,
                             f"; at the default parameters entry [{i}][{j}] is {Mv[i, j]:g} and entry [{j}][{i}] "
                             f"is {Mv[j, i]:g}")
        if _singular(Mv):
            raise self.error("model.mass", "a nonsingular matrix at the default parameters", _short(Mv.tolist()))
        s = 1.0 / np.sqrt(np.diag(Mv))  # scaled, so masses of 1e-8 and 1e8 side by side are fine
        lowest = float(np.linalg.eigvalsh(Mv * s[:, None] * s[None, :]).min())
        if not lowest > 0:
            raise self.error("model.mass", "a positive definite matrix (a mass matrix: every motion has kinetic "
                             "energy > 0)", _short(Mv.tolist()),
                             f"; scaled to a unit diagonal its lowest eigenvalue is {lowest:.3g} at the default "
                             "parameters")

    def check_frequency_value(self, freq: str) -> None:
        """The excitation frequency is never negative."""
        v = self.independent[freq]
        if v < 0:
            key = f"model.parameters.{freq}"
            raise self.error(key, "a number >= 0 (the excitation frequency)", self.m["parameters"][freq])

    # -- the model -------------------------------------------------------------
    def build(self) -> Model:
        m = self.m
        self.setup_names()
        self.p0 = np.array([self.independent[q] for q in self.pnames], dtype=float)
        freq = m["frequency"]
        if freq in self.dependent:
            raise self.error("model.frequency", "an independent parameter (a number under model.parameters)", freq,
                             f"; '{freq}' is an expression of other parameters")
        if freq not in self.independent:
            raise self.error("model.frequency", "the name of the excitation-frequency parameter", freq,
                             f"; add it under model.parameters{suggest(freq, self.pnames)}")
        self.check_frequency_value(freq)
        M, m_used = self.matrix("model.mass", m["mass"], required=True)
        C, c_used = self.matrix("model.damping", m["damping"])
        K, k_used = self.matrix("model.stiffness", m["stiffness"])
        gyro = m["gyroscopic"] or {}
        G_text = None
        if gyro:
            allowed = {"matrix": True, "speed": True}
            self.keys_of(gyro, "model.gyroscopic", allowed, "gyroscopic")
            s = gyro["speed"]
            if isinstance(s, bool) or not isinstance(s, (int, float, str)):
                raise self.error("model.gyroscopic.speed", "the name of a parameter (or an expression of parameters)",
                                 _short(s))
            speed = self.expression(s, "model.gyroscopic.speed")
            G, g_used = self.matrix("model.gyroscopic.matrix", gyro["matrix"], required=True, factor=speed)
            C = C + G
            c_used |= g_used
            G_text = f"gyroscopic: ({ex.to_text(speed)})*G ({self.n}x{self.n}) added to the damping"
        self.check_mass(M.value(self.p0))
        forces, force_kinds = self.forces()
        excitations = self.excitations()

        def mat_text(label, symbol, mat, used):
            if not mat.terms:
                return f"{label}: none"
            what = f"entries in {', '.join(sorted(used))}" if used else "constant"
            return f"{label}: {symbol} ({self.n}x{self.n}, {what}; frequency domain)"

        terms = [mat_text("mass", "M", M, m_used), mat_text("damping", "C", C, c_used),
                 mat_text("stiffness", "K", K, k_used)]
        if G_text:
            terms.append(G_text)
        if self.dependent:
            terms.append("dependent parameters: " + ", ".join(f"{q} = {ex.to_text(node)}"
                                                              for q, node in self.dependent.items()))
        effects = ["mass"] + (["damping"] if C.terms else []) + (["stiffness"] if K.terms else [])
        effects += (["gyroscopic"] if gyro else []) + force_kinds + (["excitation"] if excitations else [])
        model = Model(
            name=m["name"],
            dof_names=tuple(self.dofs),
            parameters=dict(self.independent),
            mass=M,
            damping=C,
            stiffness=K,
            forces=forces,
            excitations=excitations,
            frequency=freq,
            effects=tuple(dict.fromkeys(effects)),
            terms=terms,
        )
        model.dependent_parameters = {q: ExpressionCoefficient(node, self.pnames, f"model.parameters.{q}")
                                      for q, node in self.dependent.items()}
        a = self.scene.data.get("analysis") or {}
        for k in ("parameter", "frequency"):
            name = a.get(k)
            if isinstance(name, str):
                check_continuation_parameter(model, name, f"analysis.{k}", self.lines)
        return model


def _singular(M: np.ndarray) -> bool:
    """Rank test after scaling by the diagonal, so widely different masses (1e-6 and 1e6) are not singular."""
    d = np.abs(np.diag(M))
    if np.all(d > 0):
        s = 1.0 / np.sqrt(d)
        M = M * s[:, None] * s[None, :]
    return bool(np.linalg.matrix_rank(M) < M.shape[0])


def _monomial(node, pnames) -> Monomial | None:
    """``node`` as ``const * prod p_j**e_j`` with integer ``e_j >= 0``, or None."""
    const, powers = 1.0, {}

    def take(n, e) -> bool:
        nonlocal const
        if isinstance(n, ex.Num):
            try:
                const *= n.value ** e
            except (OverflowError, ZeroDivisionError):
                return False
            return True
        if isinstance(n, ex.Var):
            if n.name not in pnames:
                return False
            j = pnames.index(n.name)
            powers[j] = powers.get(j, 0) + e
            return True
        if isinstance(n, ex.Neg):
            const = -const if e % 2 else const
            return take(n.arg, e)
        if isinstance(n, ex.Mul):
            return all(take(f, e) for f in n.factors) and all(take(d, -e) for d in n.divisors)
        if isinstance(n, ex.Pow) and isinstance(n.exp, ex.Num) and n.exp.value == int(n.exp.value) \
                and abs(n.exp.value) <= 64:
            return take(n.base, e * int(n.exp.value))
        return False

    if not take(node, 1) or any(e < 0 for e in powers.values()) or not math.isfinite(const):
        return None
    return Monomial(const, tuple(sorted((j, e) for j, e in powers.items() if e != 0)))


def build_custom_model(scene: Scene) -> Model:
    """The :class:`contin.model.base.Model` of a scene's custom ``model:`` section.

    Parameters
    ----------
    scene : Scene
        A validated scene (:func:`contin.scene.parse.parse_scene`) whose model has
        no ``builtin`` key.

    Returns
    -------
    Model
        Its parameter vector holds the independent parameters only;
        ``model.dependent_parameters`` maps the others to
        :class:`~contin.model.elements.expression.ExpressionCoefficient`.

    Raises
    ------
    SceneError
        Naming the dotted key of the first problem found (and its line).
    """
    return _Builder(scene).build()
