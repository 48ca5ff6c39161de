"""External forces written as expressions in ``tau`` and parameters (custom scene models).

:class:`ExpressionExcitation` (excitation kind ``expr``) evaluates a
right-hand side in ``tau`` and parameters with numpy; the harmonic balance
evaluates it once per parameter value. Its scene items are
``{dof: x, expr: "F*cos(tau)"}``; all of them (and harmonic items whose
amplitude is no product of parameter powers) join into one element. Its
compiled time-domain form (:class:`ExpressionExcitationForm`) emits the
expressions as code.
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from contin.model import expressions as ex
from contin.model.base import ExcitationElement, register_excitation
from contin.model.codegen import array_names
from contin.model.elements.expression import as_node
from contin.model.elements.registry import CompiledForm, Joined, SceneKeys

__all__ = ["ExpressionExcitation", "ExpressionExcitationForm"]


@register_excitation("expr")
class ExpressionExcitation(ExcitationElement):
    """External forces given by expressions in ``tau`` and parameters.

    Parameters
    ----------
    dof_names, param_names : sequence of str
    exprs : sequence of (int, Node or str)
        Target dof index and expression (no dofs or velocities).
    label : str
    """

    def __init__(self, dof_names: Sequence[str], param_names: Sequence[str], exprs, label: str = "excitation"):
        self.dof_names = tuple(dof_names)
        self.param_names = tuple(param_names)
        self.label = label
        names = set(self.param_names) | {"tau"}
        self.exprs = [(int(d), as_node(e, f"excitation {i}", names)) for i, (d, e) in enumerate(exprs)]
        used = set().union(*(ex.free_names(node) for _, node in self.exprs)) if self.exprs else set()
        self._uses = {q: self.param_names.index(q) for q in used if q in self.param_names}
        self._params = frozenset(self._uses.values())
        self._dnodes: dict = {}
        bounds = [ex.harmonic_bound(node) for _, node in self.exprs]
        # unknown content (e.g. exp(cos(tau))) is simply projected on the retained harmonics
        self._max_order = max([b for b in bounds if b is not None] + [0.0])

    def _env(self, tau, p):
        env = {q: float(p[i]) for q, i in self._uses.items()}
        env["tau"] = tau
        return env

    def evaluate(self, tau, p, f):
        env = self._env(tau, p)
        for dof, node in self.exprs:
            f[:, dof] += np.broadcast_to(ex.evaluate(node, env), tau.shape)

    def evaluate_dp(self, tau, p, k, dfdp):
        if k not in self._params:
            return
        env = self._env(tau, p)
        name = self.param_names[k]
        for i, (dof, node) in enumerate(self.exprs):
            key = (i, k)
            if key not in self._dnodes:
                self._dnodes[key] = ex.diff(node, name)
            d = self._dnodes[key]
            if d != ex.ZERO:
                dfdp[:, dof] += np.broadcast_to(ex.evaluate(d, env), tau.shape)

    def depends_on(self, k):
        return k in self._params

    def max_order(self):
        return float(self._max_order) if math.isfinite(self._max_order) else 0.0

    def describe(self, dof_names=None, param_names=None):
        dof_names = self.dof_names if dof_names is None else dof_names
        return f"{self.label}: " + "; ".join(f"{dof_names[d]} += {ex.to_text(node)}" for d, node in self.exprs)

    # -- scene -----------------------------------------------------------------
    scene_keys = (SceneKeys({"dof": True, "expr": True}, example='{dof: x, expr: "F*cos(tau)"}', marker="expr"),)

    @classmethod
    def from_scene(cls, item, key, scene):
        d = scene.dof(item["dof"], f"{key}.dof")
        node = scene.expression(item["expr"], f"{key}.expr", allow_tau=True, what="an expression of tau and parameters")
        return Joined(cls, (d, node))

    @classmethod
    def join(cls, parts, key, scene):
        return cls(scene.dofs, scene.param_names, parts, label="excitation (expr)")

    # -- time simulation ---------------------------------------------------------
    def compiled_form(self):
        return ExpressionExcitationForm(self)


class ExpressionExcitationForm(CompiledForm):
    """Expression excitations in the generated simulation module: each expression as code."""

    def _name_of(self, name):
        return array_names(self.element.param_names, tau="tau", error=ValueError)(name)

    def excitation_lines(self, tag, c):
        w = ex.CodeWriter(self._name_of, f"{tag}t")
        for _, node in self.element.exprs:
            w.count(node)
        stmts = [f"R[{d}] += {w.emit(node)}" for d, node in self.element.exprs]
        return list(w.lines) + stmts

    def excitation_dtau_lines(self, tag, c):
        # the symbolic derivatives in tau, emitted as the values are
        w = ex.CodeWriter(self._name_of, f"{tag}d")
        targets = [(d, ex.diff(node, "tau")) for d, node in self.element.exprs]
        targets = [(d, t) for d, t in targets if t != ex.ZERO]
        for _, t in targets:
            w.count(t)
        stmts = [f"R[{d}] += {w.emit(t)}" for d, t in targets]
        return list(w.lines) + stmts
