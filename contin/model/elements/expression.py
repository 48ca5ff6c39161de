"""Forces and coefficients written as expressions (custom scene models).

:class:`ExpressionForce` (force kind ``expr``) compiles all expression
forces of a model into one generated numba module: a kernel filling ``f``,
``df/dx`` and ``df/dx'`` for all samples, and a kernel for ``df/dp[k]``
(branching on ``k``). The derivatives are symbolic
(:func:`contin.model.expressions.diff`), so the Jacobians are analytic. The module
is cached on disk by :mod:`contin.model.codegen`, so numba's own cache works across
processes. Its scene items are ``{dof: x, expr: "g*x**3"}`` (no ``type``
needed); all of them join into one element. Its compiled time-domain form
(:class:`ExpressionForceForm`) emits the expressions and their symbolic
Jacobians as code.

:class:`ExpressionCoefficient` is a parameter-dependent coefficient with the
interface of :class:`contin.model.base.Monomial` (``value``, ``derivative``,
``depends_on``), usable in :class:`contin.model.base.ParametricMatrix` terms and in
the contact elements.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from contin.model import codegen
from contin.model import expressions as ex
from contin.model.base import ForceElement, register_force
from contin.model.codegen import array_names
from contin.model.elements.registry import CompiledForm, Joined, SceneKeys

__all__ = ["ExpressionForce", "ExpressionForceForm", "ExpressionCoefficient", "state_names", "as_node"]


def state_names(dof_names: Sequence[str]) -> tuple:
    """Displacement and velocity names, ``(x, y, ..., x_dot, y_dot, ...)``."""
    return tuple(dof_names) + tuple(f"{d}_dot" for d in dof_names)


def as_node(e, where: str, names) -> ex.Node:
    """``e`` as an expression tree: a :class:`~contin.model.expressions.Node` as it is, a text parsed in ``names``."""
    return e if isinstance(e, ex.Node) else ex.parse(e, where, names)


class ExpressionCoefficient:
    """A coefficient ``c(p)`` given by an expression of parameters.

    Parameters
    ----------
    expr : Node or str
        Expression in the names ``param_names`` (and the constant ``pi``).
    param_names : sequence of str
        The model's parameter vector, in order.
    """

    def __init__(self, expr, param_names: Sequence[str], where: str = "coefficient"):
        self.param_names = tuple(param_names)
        self.node = as_node(expr, where, self.param_names)
        self._uses = {q: self.param_names.index(q) for q in ex.free_names(self.node) if q in self.param_names}
        self._indices = frozenset(self._uses.values())
        self._dnodes: dict = {}

    @property
    def text(self) -> str:
        return ex.to_text(self.node)

    def _env(self, p) -> dict:
        return {name: float(p[i]) for name, i in self._uses.items()}

    def value(self, p) -> float:
        return float(ex.evaluate(self.node, self._env(p)))

    def derivative(self, p, k: int) -> float:
        if k not in self._indices:
            return 0.0
        if k not in self._dnodes:
            self._dnodes[k] = ex.diff(self.node, self.param_names[k])
        return float(ex.evaluate(self._dnodes[k], self._env(p)))

    def depends_on(self, k: int) -> bool:
        return k in self._indices

    def __repr__(self):
        return f"ExpressionCoefficient({self.text!r})"


@register_force("expr")
class ExpressionForce(ForceElement):
    """Internal forces given by expressions in dofs, velocities, ``tau`` and parameters.

    ``f[dof] += expr`` for each ``(dof, expr)``; several expressions on the
    same dof add up. The names are the dof names, their velocities
    ``NAME_dot`` (time derivatives), the excitation phase ``tau`` and the
    parameters.

    Parameters
    ----------
    dof_names : sequence of str
    param_names : sequence of str
        The model's parameter vector, in order.
    exprs : sequence of (int, Node or str)
        Target dof index and expression.
    label : str

    Attributes
    ----------
    degree : int or None
        Polynomial degree in the dofs and velocities (None if not a
        polynomial). A factor ``cos(k*tau)`` in a coefficient raises the
        degree by one so that the default sample count stays exact for
        forcing orders up to ``H``.
    """

    def __init__(self, dof_names: Sequence[str], param_names: Sequence[str], exprs, label: str = "expr"):
        if not exprs:
            raise ValueError("an expression force needs at least one expression")
        self.dof_names = tuple(dof_names)
        self.param_names = tuple(param_names)
        self.label = label
        n = len(self.dof_names)
        names = set(state_names(self.dof_names)) | {"tau"} | set(self.param_names)
        self.exprs = []
        for i, (dof, e) in enumerate(exprs):
            dof = int(dof)
            if not 0 <= dof < n:
                raise ValueError(f"expression force {i}: dof index {dof} out of range for {n} dofs")
            self.exprs.append((dof, as_node(e, f"expression force {i}", names)))
        totals = [ex.ZERO] * n
        for dof, node in self.exprs:
            totals[dof] = ex.add(totals[dof], node)
        self.totals = totals
        used = set().union(*(ex.free_names(t) for t in totals))
        self._params = tuple(sorted(self.param_names.index(q) for q in used if q in self.param_names))
        state = state_names(self.dof_names)
        degs = [ex.polynomial_degree(t, state) for t in totals]
        orders = [ex.tau_orders(t) for t in totals]
        if any(d is None for d in degs):
            self.degree = None
        else:
            self.degree = max(max(degs), 1) + (1 if any(o for o in orders if o) or "tau" in used else 0)
        self._tau_orders = () if any(o is None for o in orders) else tuple(sorted(set().union(*map(set, orders))))
        self.source = self._module_source()
        self._module = None

    # -- generated code ----------------------------------------------------
    def _name_of(self, name: str) -> str:
        return array_names(self.param_names, self.dof_names)(name)

    def _loop(self, targets, indent: str) -> list:
        """Statements of a loop over samples accumulating ``(array text, node)`` pairs."""
        state = set(state_names(self.dof_names)) | {"tau"}
        hoist = lambda node: not (ex.free_names_cached(node) & state)  # noqa: E731
        pre = ex.CodeWriter(self._name_of, "_c")
        body = ex.CodeWriter(self._name_of, "_t")
        for _, node in targets:
            body.count(node)
        # parameter-only sub-expressions are computed once, before the loop
        hoisted, stack = [], [node for _, node in targets]
        while stack:
            n = stack.pop()
            if isinstance(n, (ex.Num, ex.Var)):
                continue
            if hoist(n):
                pre.count(n)
                hoisted.append(n)
            else:
                stack.extend(n.children())
        for n in hoisted:
            body.bind(n, pre.assign(n))
        stmts = [f"{a} += {body.emit(node)}" for a, node in targets]
        lines = [indent + s for s in pre.lines]
        lines.append(f"{indent}for j in range(x.shape[0]):")
        lines += [f"{indent}    {s}" for s in body.lines + stmts]
        return lines

    def _module_source(self) -> str:
        f_targets, dp_branches = [], []
        for i, t in enumerate(self.totals):
            if t != ex.ZERO:
                f_targets.append((f"f[j, {i}]", t))
        for i, t in enumerate(self.totals):
            for jn, d in enumerate(self.dof_names):
                for arr, name in (("dfdx", d), ("dfdxd", f"{d}_dot")):
                    dt = ex.diff(t, name)
                    if dt != ex.ZERO:
                        f_targets.append((f"{arr}[j, {i}, {jn}]", dt))
        for k in self._params:
            targets = []
            for i, t in enumerate(self.totals):
                dt = ex.diff(t, self.param_names[k])
                if dt != ex.ZERO:
                    targets.append((f"dfdp[j, {i}]", dt))
            if targets:
                dp_branches.append((k, targets))
        self._params = tuple(k for k, _ in dp_branches)
        head = [
            f"# contin generated kernel (codegen {codegen.CODEGEN_VERSION}): expression forces",
            f"# dofs {list(self.dof_names)}, parameters {list(self.param_names)}",
        ]
        for dof, node in self.exprs:
            head.append(f"# {self.dof_names[dof]}: {ex.to_text(node)!r}")
        lines = head + [
            "import numpy as np",
            "from contin.util.jit import njit",  # cached only in the private cache directory
            "",
            "",
            '@njit(cache=True, error_model="numpy")',
            "def evaluate(x, xd, tau, p, f, dfdx, dfdxd):",
        ]
        lines += self._loop(f_targets, "    ") if f_targets else ["    return"]
        lines += ["", "", '@njit(cache=True, error_model="numpy")', "def evaluate_dp(x, xd, tau, p, k, dfdp):"]
        for b, (k, targets) in enumerate(dp_branches):
            lines.append(f"    {'if' if b == 0 else 'elif'} k == {k}:")
            lines += self._loop(targets, "        ")
        lines.append("    return")
        src = "\n".join(lines) + "\n"
        compile(src, "<generated kernel>", "exec")  # syntax check only; the module is loaded by codegen
        return src

    def kernels(self):
        """The generated module (written to the kernel cache and imported on first use)."""
        if self._module is None:
            self._module = codegen.load_module(self.source)
        return self._module

    # -- ForceElement interface -----------------------------------------------
    def evaluate(self, x, xd, tau, p, f, dfdx, dfdxd):
        self.kernels().evaluate(x, xd, tau, np.asarray(p, dtype=float), f, dfdx, dfdxd)

    def evaluate_dp(self, x, xd, tau, p, k, dfdp):
        if int(k) in self._params:
            self.kernels().evaluate_dp(x, xd, tau, np.asarray(p, dtype=float), int(k), dfdp)

    def depends_on(self, k):
        return int(k) in self._params

    def tau_orders(self):
        return self._tau_orders

    def active_dofs(self):
        used = set().union(*(ex.free_names(t) for t in self.totals))
        return tuple(i for i, d in enumerate(self.dof_names)
                     if self.totals[i] != ex.ZERO or d in used or f"{d}_dot" in used)

    def describe(self, dof_names=None, param_names=None):
        dof_names = self.dof_names if dof_names is None else dof_names
        deg = "not polynomial" if self.degree is None else f"degree {self.degree}"
        parts = [f"{dof_names[d]}: +{ex.to_text(node)}" for d, node in self.exprs]
        return f"{self.label} (expressions, {deg}): " + "; ".join(parts)

    # -- scene -----------------------------------------------------------------
    scene_keys = (SceneKeys({"type": False, "dof": True, "expr": True}, example='{dof: x, expr: "g*x**3"}',
                            default=True),)

    @classmethod
    def from_scene(cls, item, key, scene):
        d = scene.dof(item["dof"], f"{key}.dof")
        node = scene.expression(item["expr"], f"{key}.expr", allow_state=True, allow_tau=True,
                                what="an expression of the dofs, their velocities NAME_dot, tau and parameters")
        return Joined(cls, (d, node))

    @classmethod
    def join(cls, parts, key, scene):
        try:
            return cls(scene.dofs, scene.param_names, parts, label="forces (expr)")
        except (RecursionError, SyntaxError, MemoryError) as exc:
            raise scene.error(key, "expressions that can be compiled", None,
                              f"; code generation failed: {type(exc).__name__}: {exc}") from None

    # -- time simulation ---------------------------------------------------------
    def compiled_form(self):
        return ExpressionForceForm(self)


class ExpressionForceForm(CompiledForm):
    """Expression forces in the generated simulation module: their totals and symbolic Jacobians as code."""

    def _name_of(self, name):
        e = self.element
        return array_names(e.param_names, e.dof_names, x="X[0, {}]", xd="V[0, {}]", tau="tau",
                           error=ValueError)(name)

    def force_lines(self, tag, c, m):
        w = ex.CodeWriter(self._name_of, f"{tag}t")
        targets = [(i, t) for i, t in enumerate(self.element.totals) if t != ex.ZERO]
        for _, t in targets:
            w.count(t)
        stmts = [f"F[0, {i}] += {w.emit(t)}" for i, t in targets]
        return list(w.lines) + stmts

    def jacobian_lines(self, tag, c, m):
        # the symbolic derivatives of the totals, as the harmonic-balance kernel has them
        e = self.element
        w = ex.CodeWriter(self._name_of, f"{tag}j")
        targets = []
        for i, t in enumerate(e.totals):
            for jn, d in enumerate(e.dof_names):
                for arr, name in (("DX", d), ("DXD", f"{d}_dot")):
                    dt = ex.diff(t, name)
                    if dt != ex.ZERO:
                        targets.append((f"{arr}[0, {i}, {jn}]", dt))
        for _, t in targets:
            w.count(t)
        stmts = [f"{a} += {w.emit(t)}" for a, t in targets]
        return list(w.lines) + stmts

    def force_dtau_lines(self, tag, c, m):
        # the symbolic derivatives of the totals in tau (nothing where they do not depend on it)
        w = ex.CodeWriter(self._name_of, f"{tag}d")
        targets = [(i, ex.diff(t, "tau")) for i, t in enumerate(self.element.totals)]
        targets = [(i, t) for i, t in targets if t != ex.ZERO]
        for _, t in targets:
            w.count(t)
        stmts = [f"F[0, {i}] += {w.emit(t)}" for i, t in targets]
        return list(w.lines) + stmts

    def notes(self):
        if any(_nonsmooth(t) for t in self.element.totals):
            return ["an expression force uses abs/sign/min/max/a condition: its switching is not located "
                    "(fixed-step error there is first order in h)"]
        return []


def _nonsmooth(node) -> bool:
    stack = [node]
    while stack:
        n = stack.pop()
        if isinstance(n, ex.Select) or (isinstance(n, ex.Call) and n.fn in ("abs", "sign", "min", "max")):
            return True
        stack.extend(n.children())
    return False
