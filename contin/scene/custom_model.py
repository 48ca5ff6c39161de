"""Custom models from the ``model:`` section of a scene (SPEC 4.2).

A custom model is

    M(p) x'' + C(p) x' + K(p) x + sum(forces) = sum(excitation)

with dof names, parameters, matrices whose entries are numbers or
expressions of parameters, optional gyroscopic terms ``speed * G`` added to
the damping matrix, internal forces and external forces. Expressions are
parsed by :mod:`contin.model.expressions`, never evaluated as Python.

The items of ``forces`` and ``excitation`` are built by the registered
element kinds (:mod:`contin.model.elements.registry`): a force item's
``type`` names its kind (``expr`` when absent, ``gap``, ``radial_gap`` or a
kind registered by the user), an excitation item's form is named by its one
marker key (``expr``, ``amplitude``, ``constant``). Each kind lists its keys
and checks and builds its item in its own file, through this module's
builder; this module knows no kind.

Parameters are resolved by :mod:`contin.scene.custom_parameters`: only the
independent ones form the model's parameter vector, the dependent ones are
inlined where they are used and kept in ``model.dependent_parameters``.

Every problem is reported as a :class:`contin.scene.parse.SceneError` naming the
dotted key (``model.forces[2].clearance``), with the YAML line where known.
"""

from __future__ import annotations

import keyword
import math
from typing import Any

import numpy as np

from contin.model import expressions as ex
from contin.model.base import Model, Monomial, ParametricMatrix
from contin.model.elements.expression import ExpressionCoefficient, state_names
from contin.model.elements.registry import Joined, SceneContext, scene_forms, shorten
from contin.scene.custom_parameters import (RESERVED, check_continuation_parameter, check_size,
                                            resolve_parameters)
from contin.scene.parse import Scene, SceneError
from contin.util.naming import is_finite_real, suggest

__all__ = ["build_custom_model", "check_continuation_parameter", "resolve_parameters"]


def _parent(key: str) -> str | None:
    if key.endswith("]"):
        return key[: key.rindex("[")]
    if "." in key:
        return key.rsplit(".", 1)[0]
    return None


class _Builder(SceneContext):
    """Builds the model of a custom ``model:`` section; elements build themselves through it (:class:`SceneContext`)."""

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
        self.param_names = tuple(self.pnames)
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
            raise self.error(key, what, shorten(value), "; " + exc.reason) from None
        node = ex.substitute(node, self.dependent)
        check_size(node, key, self.error)
        return node

    def coefficient(self, value, key: str, what="a number or an expression of parameters"):
        """A Monomial when the expression is a product of parameter powers, else an ExpressionCoefficient."""
        if value is None or isinstance(value, bool) or not isinstance(value, (int, float, str)):
            raise self.error(key, what, shorten(value))
        return self.coefficient_of(self.expression(value, key, what=what), key, value)

    def coefficient_of(self, node, key: str, original):
        """Coefficient object of a parameter expression, checked finite at the default parameters."""
        mono = _monomial(node, self.pnames)
        coef = mono if mono is not None else ExpressionCoefficient(node, self.pnames, key)
        with np.errstate(all="ignore"):
            v = float(coef.value(self.p0))
        if not math.isfinite(v):
            raise self.error(key, "a finite value at the default parameters", shorten(original),
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
            raise self.error(key, self.shape_text() + " as a list of rows", shorten(value))
        if len(value) != n:
            raise self.error(key, self.shape_text(), None, f", found {len(value)} row{'s' if len(value) != 1 else ''}")
        terms, used = [], set()
        for i, row in enumerate(value):
            rkey = f"{key}[{i}]"
            if not isinstance(row, list):
                raise self.error(rkey, f"a row of {n} entries (numbers or expressions of parameters)", shorten(row))
            if len(row) != n:
                raise self.error(rkey, f"a row of {n} entries ({n} dofs: {', '.join(self.dofs)})", None,
                                 f", found {len(row)} entr{'ies' if len(row) != 1 else 'y'}")
            for j, e in enumerate(row):
                ekey = f"{rkey}[{j}]"
                if e is None or isinstance(e, bool) or not isinstance(e, (int, float, str)):
                    raise self.error(ekey, "a number or an expression of parameters", shorten(e))
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
            raise self.error(key, f"the name of a dof (one of {', '.join(self.dofs)})", shorten(value), hint)
        return self.dofs.index(value)

    def number(self, value, key, default, minimum=None):
        if value is None:
            return default
        if not is_finite_real(value) or (minimum is not None and value < minimum):
            exp = "a finite number" if minimum is None else f"a number >= {minimum}"
            raise self.error(key, exp, shorten(value))
        return float(value)

    def boolean(self, value, key, default=False):
        if value is None:
            return default
        if not isinstance(value, bool):
            raise self.error(key, "true or false", shorten(value))
        return value

    # -- items: each element kind checks and builds its own (contin.model.elements.registry) ----------
    def items(self, section: str, kind_of):
        """The elements of ``model.<section>``, built by the registered kinds.

        ``kind_of(item, key, forms)`` names the form of an item. Items whose
        kind joins its parts into one element (expressions) give that element
        once, before the others; the rest keep the scene's order.
        """
        forms = scene_forms(section)
        examples = [keys.example for _, keys in forms.values()]
        mapping = ", ".join(examples[:-1]) + " or " + examples[-1] if len(examples) > 1 else "".join(examples)
        elements, joined = [], {}
        for i, item in enumerate(self.m[section]):
            key = f"model.{section}[{i}]"
            if not isinstance(item, dict):
                raise self.error(key, "a mapping such as " + mapping, shorten(item))
            form = kind_of(item, key, forms)
            cls, keys = forms[form]
            self.keys_of(item, key, keys.keys, f"'{form}' {'force' if section == 'forces' else 'excitation'}")
            made = cls.from_scene(item, key, self)
            if isinstance(made, Joined):
                joined.setdefault(made.cls, []).append(made.part)
            else:
                elements.append(made)
        return [cls.join(parts, f"model.{section}", self) for cls, parts in joined.items()] + elements

    def force_type(self, item, key, forms):
        kind = item.get("type")
        if kind is None:
            kind = next(name for name, (_, keys) in forms.items() if keys.default)
        if not isinstance(kind, str) or kind not in forms:
            raise self.error(f"{key}.type", "one of " + ", ".join(repr(k) for k in forms), shorten(kind),
                             suggest(kind, forms) if isinstance(kind, str) else "")
        return kind

    def excitation_marker(self, item, key, forms):
        present = [k for k in forms if k in item]
        if len(present) != 1:
            raise self.error(key, f"exactly one of the keys {', '.join(forms)}", None,
                             f"; found {', '.join(present) if present else 'none'} "
                             f"(keys: {', '.join(map(str, item))})")
        return present[0]

    def forces(self):
        elements = self.items("forces", self.force_type)
        return elements, [el.kind for el in elements]

    def excitations(self):
        return self.items("excitation", self.excitation_marker)

    def check_mass(self, Mv: np.ndarray) -> None:
        """A mass matrix is symmetric positive definite: refuse one that is not (at the default parameters)."""
        given_as_rows = isinstance(self.m["mass"], list)
        for i in range(self.n):
            if not Mv[i, i] > 0:
                key = f"model.mass[{i}][{i}]" if given_as_rows else "model.mass"
                raise self.error(key, f"a positive mass on the diagonal (the inertia of dof {self.dofs[i]}: a mass "
                                 "matrix is positive definite)", shorten(self.m["mass"][i][i] if given_as_rows
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
            raise self.error("model.mass", "a nonsingular matrix at the default parameters", shorten(Mv.tolist()))
        s = 1.0 / np.sqrt(np.diag(Mv))  # scaled, so masses of 1e-8 and 1e8 side by side are fine
        lowest = float(np.linalg.eigvalsh(Mv * s[:, None] * s[None, :]).min())
        if not lowest > 0:
            raise self.error("model.mass", "a positive definite matrix (a mass matrix: every motion has kinetic "
                             "energy > 0)", shorten(Mv.tolist()),
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
                                 shorten(s))
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
            symbols=self.symbols(),
        )
        model.dependent_parameters = {q: ExpressionCoefficient(node, self.pnames, f"model.parameters.{q}")
                                      for q, node in self.dependent.items()}
        a = self.scene.data.get("analysis") or {}
        for k in ("parameter", "frequency"):
            name = a.get(k)
            if isinstance(name, str):
                check_continuation_parameter(model, name, f"analysis.{k}", self.lines)
        return model


    def symbols(self) -> dict:
        """``model.symbols``: dof or parameter name -> how figures write it (:mod:`contin.output.labels`).

        Each value is mathtext without dollars (``'\\Omega'``) or a phrase with ``$...$``;
        it is checked by matplotlib's mathtext parser, so that a figure cannot fail after the run.
        """
        from matplotlib.mathtext import MathTextParser

        names = list(self.dofs) + list(self.all_params)
        parser = MathTextParser("path")
        out = {}
        for name, text in (self.m.get("symbols") or {}).items():
            key = f"model.symbols.{name}"
            if name not in names:
                raise self.error(key, "the name of a dof or parameter of the model", name,
                                 hint=suggest(str(name), names))
            if not isinstance(text, str) or not text.strip():
                raise self.error(key, "mathtext such as '\\Omega' or 'x_1', or a phrase with $...$", shorten(text))
            try:
                parser.parse(text if "$" in text else f"${text}$", 72)
            except ValueError as exc:
                raise self.error(key, "mathtext such as '\\Omega' or 'x_1', or a phrase with $...$", shorten(text),
                                 hint=f" ({' '.join(str(exc).split())})") from None
            out[name] = text
        return out


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
