"""Time simulation of a model: compiled fixed-step RK4 with located contact switching.

The equations of motion of a :class:`contin.model.base.Model`,

    M x'' + C x' + K x + f_nl(x, x', tau) = f_ext(tau),    tau = w t,

are integrated as the first-order system ``y = (x, x')``,
``y' = (x', M^-1 (f_ext - C x' - K x - f_nl))``, by the classical Runge-Kutta
scheme with the fixed step ``h = T / steps_per_period``, ``T = 2 pi / w`` (the
rotor paper integrates its eq. 11 this way with 4096 steps per revolution).
Because ``steps_per_period`` is an integer, the step grid meets the phases
``tau = 2 pi m`` exactly: the state at every ``steps_per_period``-th step is a
point of the Poincare section, and the excitation is evaluated at phases
``2 pi (k mod S + theta) / S`` that repeat exactly every period.

Compiled right-hand side
------------------------
For each model *structure* (dofs, element kinds, dof indices, exponents,
expression texts, excitation orders and phases) a small module is generated
and imported with :func:`contin.model.codegen.load_module`, so numba's
``cache=True`` works across processes. It holds the right-hand side, the
switching functions and the integrator loop, all compiled together: no Python
call is made per step. Parameter values (matrices, clearances, stiffnesses,
amplitudes) are arguments, so a parameter sweep reuses the compiled code.

Each element kind has a *compiled form* (:class:`CompiledForm`), looked up in
a registry (:func:`register_compiled_form`): polynomial forces call their
element kernel (:func:`contin.model.elements.polynomial._poly_kernel`) on 1-sample
views; expression forces and excitations are emitted as code from their
expression trees (value only, no Jacobian); harmonic excitations are a cosine
line; gap and radial-gap contacts call the mode-aware kernels of this module.

Switching (contact) events
--------------------------
A contact element exposes switching functions ``s(x, x')``, positive where its
force law is active: ``x - g`` and ``-x - g`` for a gap, ``r - delta`` for a
radial clearance (with ``clip``, ``min(penetration, F/k)``, so the end of
contact where the clipped force reaches zero is an event too). The force law
jumps across ``s = 0`` (the damping term ``c v`` switches on with a non-zero
velocity), which costs a fixed-step scheme its order: an RK4 step across the
jump has an ``O(h)`` local error, so the global error is ``O(h)``.

With ``locate_events`` the contact state (the *mode*) is frozen during a step:
each element applies the law of the mode at the start of the step, even if a
stage leaves its region, so the step is a smooth RK4 step of one vector field.
When a switching function has changed sign at the end of the step, the
crossing is located by an Illinois (modified regula falsi) iteration on the
fraction ``theta`` of the step, each trial being an RK4 step of length
``theta h`` from the start of the step in the frozen mode; the state just past
the surface is accepted, the mode of the crossing element is flipped, and the
rest of the step is integrated from there (further events are located the
same way). The step grid is kept, so recorded samples and Poincare sections
stay on ``t = k h``. The global error is then ``O(h^4)`` again (the tests
measure both orders against an independent event-driven DOP853 integration).
Limitations: a grazing contact that starts and ends within one step is not
seen (its effect is of the order of the penetration, ``O(h^2)`` at most);
switching inside expression forces (``abs``, ``sign``, ``min``, ``max``) is
not located.

Non-finite states stop the run with :class:`SimulationError` naming the time
and the parameter values. A fixed step too large for a stiff contact is
refused before the run: RK4 is stable for ``h |lambda| <= 2.8`` only, and in
an unstable contact mode the event location would otherwise chop the steps
and return a wrong answer instead of blowing up (:meth:`CompiledModel.fastest_rate`).
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import inspect
import math
import time
from typing import Callable, Mapping

import numba as nb
import numpy as np

from contin.model import codegen
from contin.model.codegen import array_names
from contin.model import expressions as ex
from contin.model.base import Model

__all__ = [
    "SimulationError",
    "SimulationResult",
    "CompiledForm",
    "CompiledModel",
    "compile_model",
    "register_compiled_form",
    "simulate",
]

#: bumped when the integrator template changes meaning
SIMULATION_TEMPLATE_VERSION = "1"
#: largest h*|lambda| accepted (classical RK4 is stable up to 2 sqrt 2 on the imaginary axis)
RK4_STABILITY = 2.8


class SimulationError(ArithmeticError):
    """A simulation that cannot go on (non-finite state, unsupported element)."""


# ---------------------------------------------------------------- mode-aware contact kernels
@nb.njit(cache=True)
def _gap_force(X, V, d, g, k, c, side, active_plus, active_minus, F):
    """Gap force of the frozen mode on a 1-sample view (law of :class:`GapForce`)."""
    x = X[0, d]
    v = V[0, d]
    if side >= 0 and active_plus != 0:
        F[0, d] += k * (x - g) + c * v
    if side <= 0 and active_minus != 0:
        F[0, d] += k * (x + g) + c * v


@nb.njit(cache=True)
def _gap_switch(X, V, d, g, k, c, side, clip, S, off):
    """Switching functions of a gap: ``x - g`` (side +) and ``-x - g`` (side -); -1 for an absent side."""
    x = X[0, d]
    v = V[0, d]
    kref = k if k > 0.0 else 1.0
    if side >= 0:
        pen = x - g
        val = pen
        if clip:
            val = min(pen, (k * pen + c * v) / kref)
        S[off] = val
    else:
        S[off] = -1.0
    if side <= 0:
        pen = -x - g
        val = pen
        if clip:
            val = min(pen, (k * pen - c * v) / kref)
        S[off + 1] = val
    else:
        S[off + 1] = -1.0


@nb.njit(cache=True)
def _radial_force(X, V, ix, iy, delta, k, c, active, F):
    """Radial contact force of the frozen mode (law of :class:`RadialGapForce`, paper eq. 3)."""
    if active == 0:
        return
    x = X[0, ix]
    y = X[0, iy]
    r = np.sqrt(x * x + y * y)
    if r == 0.0:
        return
    ex_ = x / r
    ey_ = y / r
    vn = V[0, ix] * ex_ + V[0, iy] * ey_
    Fn = k * (r - delta) + c * vn
    F[0, ix] += Fn * ex_
    F[0, iy] += Fn * ey_


@nb.njit(cache=True)
def _radial_switch(X, V, ix, iy, delta, k, c, clip, S, off):
    """Switching function ``r - delta`` (with ``clip``: ``min(r - delta, Fn/k)``)."""
    x = X[0, ix]
    y = X[0, iy]
    r = np.sqrt(x * x + y * y)
    pen = r - delta
    if clip and r > 0.0:
        kref = k if k > 0.0 else 1.0
        vn = (V[0, ix] * x + V[0, iy] * y) / r
        pen = min(pen, (k * pen + c * vn) / kref)
    S[off] = pen


# ---------------------------------------------------------------- compiled forms of elements
class CompiledForm:
    """How one element appears in the generated simulation module.

    Subclasses fill in the parts; the code generator calls them with ``tag``
    (a unique identifier prefix for module globals), ``c`` (index of the
    element's first entry in the constants vector ``cst``) and ``m`` (index of
    its first switching function / mode flag).

    Inside the generated right-hand side the names are: ``X``, ``V`` (shape
    (1, n) displacement and velocity), ``tau`` (float), ``TAU`` (shape (1,)),
    ``F`` (shape (1, n), internal force, accumulated), ``R`` (shape (n,),
    external force, accumulated), ``DUM`` (shape (1, n, n) scratch), ``p``
    (parameter vector), ``cst`` (constants), ``mode`` (int64 flags, 1 where a
    switching function's law is active). In the switching function the
    output is ``S`` (shape (n_switch_total,)).
    """

    #: number of switching functions of the element
    n_switch = 0
    #: ``from ... import ...`` lines the code needs
    imports: tuple = ()
    #: helper kernels whose source is fingerprinted into the module (cache invalidation)
    kernels: tuple = ()

    def __init__(self, element):
        self.element = element

    def constants(self, p: np.ndarray) -> list:
        """Parameter-dependent numbers, in the order the code reads them from ``cst``."""
        return []

    def globals(self, tag: str) -> list:
        """Module-level lines (structure arrays, frozen into the compiled code)."""
        return []

    def force_lines(self, tag: str, c: int, m: int) -> list:
        """Statements accumulating the internal force into ``F`` (or excitation into ``R``)."""
        return []

    def excitation_lines(self, tag: str, c: int) -> list:
        """Statements accumulating the external force into ``R``."""
        return []

    def switch_lines(self, tag: str, c: int, m: int) -> list:
        """Statements writing the switching functions ``S[m:m+n_switch]``."""
        return []

    def notes(self) -> list:
        """Caveats reported with the result (e.g. unlocated non-smooth terms)."""
        return []

    def contact_matrices(self, p: np.ndarray, n: int):
        """Stiffness and damping the element adds where its law is active, shape (n, n) each, or None.

        Used to check before a run that the fixed step keeps RK4 stable in contact.
        """
        return None


_FORMS: dict[type, type] = {}
_BUILTIN_FORMS: list = []  # non-empty once the built-in element kinds are registered (on first use)


def register_compiled_form(element_class: type):
    """Class decorator: the :class:`CompiledForm` of ``element_class`` (and its subclasses)."""

    def deco(form_cls):
        _FORMS[element_class] = form_cls
        return form_cls

    return deco


def _builtin_form(element_class: type):
    # a form registered by the user for a built-in element class takes precedence
    def deco(form_cls):
        _FORMS.setdefault(element_class, form_cls)
        return form_cls

    return deco


def _form_of(el) -> CompiledForm:
    for cls in type(el).__mro__:
        if cls in _FORMS:
            return _FORMS[cls](el)
    known = sorted(getattr(c, "kind", c.__name__) or c.__name__ for c in _FORMS)
    raise SimulationError(
        f"element '{getattr(el, 'kind', type(el).__name__)}' ({type(el).__name__}) has no compiled form for time "
        f"simulation; element kinds with one: {known}. Register one with "
        f"contin.timedomain.simulation.register_compiled_form."
    )


def _lit(v) -> str:
    return repr(float(v))


def _int_array(a) -> str:
    return "np.array(" + repr(np.asarray(a, dtype=np.int64).tolist()) + ", dtype=np.int64)"


def _float_array(a) -> str:
    return "np.array(" + repr([float(v) for v in np.asarray(a, dtype=float).ravel()]) + ", dtype=np.float64)"


def _register_builtin_forms():
    from contin.model.elements.expression import ExpressionExcitation, ExpressionForce
    from contin.model.elements.gap import GapForce, RadialGapForce
    from contin.model.elements.harmonic import HarmonicExcitation
    from contin.model.elements.polynomial import PolynomialForce, _poly_kernel

    @_builtin_form(GapForce)
    class GapForm(CompiledForm):
        n_switch = 2
        imports = ("from contin.timedomain.simulation import _gap_force, _gap_switch",)
        kernels = (_gap_force, _gap_switch)

        def constants(self, p):
            return list(self.element._values(p)) + [1.0 if self.element.clip else 0.0]

        def force_lines(self, tag, c, m):
            e = self.element
            return [f"_gap_force(X, V, {e.dof}, cst[{c}], cst[{c + 1}], cst[{c + 2}], {e.side}, mode[{m}], "
                    f"mode[{m + 1}], F)"]

        def contact_matrices(self, p, n):
            _, k, c = self.element._values(p)
            Kc, Cc = np.zeros((n, n)), np.zeros((n, n))
            Kc[self.element.dof, self.element.dof] = k
            Cc[self.element.dof, self.element.dof] = c
            return Kc, Cc

        def switch_lines(self, tag, c, m):
            e = self.element
            return [f"_gap_switch(X, V, {e.dof}, cst[{c}], cst[{c + 1}], cst[{c + 2}], {e.side}, "
                    f"cst[{c + 3}] != 0.0, S, {m})"]

    @_builtin_form(RadialGapForce)
    class RadialForm(CompiledForm):
        n_switch = 1
        imports = ("from contin.timedomain.simulation import _radial_force, _radial_switch",)
        kernels = (_radial_force, _radial_switch)

        def constants(self, p):
            return list(self.element._values(p)) + [1.0 if self.element.clip else 0.0]

        def force_lines(self, tag, c, m):
            e = self.element
            return [f"_radial_force(X, V, {e.ix}, {e.iy}, cst[{c}], cst[{c + 1}], cst[{c + 2}], mode[{m}], F)"]

        def contact_matrices(self, p, n):
            _, k, c = self.element._values(p)
            Kc, Cc = np.zeros((n, n)), np.zeros((n, n))
            for i in (self.element.ix, self.element.iy):  # the radial direction may point along either dof
                Kc[i, i] = k
                Cc[i, i] = c
            return Kc, Cc

        def switch_lines(self, tag, c, m):
            e = self.element
            return [f"_radial_switch(X, V, {e.ix}, {e.iy}, cst[{c}], cst[{c + 1}], cst[{c + 2}], "
                    f"cst[{c + 3}] != 0.0, S, {m})"]

    @_builtin_form(PolynomialForce)
    class PolynomialForm(CompiledForm):
        imports = ("from contin.model.elements.polynomial import _poly_kernel",)
        kernels = (_poly_kernel,)

        def constants(self, p):
            return list(self.element._coef(p))

        def globals(self, tag):
            e = self.element
            return [f"{tag}target = {_int_array(e.target)}",
                    f"{tag}ex = {_int_array(e.ex)}",
                    f"{tag}ev = {_int_array(e.ev)}",
                    f"{tag}torder = {_float_array(e.torder)}",
                    f"{tag}tphase = {_float_array(e.tphase)}"]

        def force_lines(self, tag, c, m):
            T = len(self.element.coefs)
            return [f"_poly_kernel(X, V, TAU, {tag}target, cst[{c}:{c + T}], {tag}ex, {tag}ev, {tag}torder, "
                    f"{tag}tphase, F, DUM, DUM, False)"]

    @_builtin_form(ExpressionForce)
    class ExpressionForceForm(CompiledForm):
        def _name_of(self, name):
            e = self.element
            return array_names(e.param_names, e.dof_names, x="X[0, {}]", xd="V[0, {}]", tau="tau",
                               error=SimulationError)(name)

        def force_lines(self, tag, c, m):
            w = ex.CodeWriter(self._name_of, f"{tag}t")
            targets = [(i, t) for i, t in enumerate(self.element.totals) if t != ex.ZERO]
            for _, t in targets:
                w.count(t)
            stmts = [f"F[0, {i}] += {w.emit(t)}" for i, t in targets]
            return list(w.lines) + stmts

        def notes(self):
            if any(_nonsmooth(t) for t in self.element.totals):
                return ["an expression force uses abs/sign/min/max/a condition: its switching is not located "
                        "(fixed-step error there is first order in h)"]
            return []

    @_builtin_form(HarmonicExcitation)
    class HarmonicForm(CompiledForm):
        def constants(self, p):
            e = self.element
            A = e.amplitude.value(p)
            return [A * math.cos(e.phase) if e.order == 0.0 else A]

        def excitation_lines(self, tag, c):
            e = self.element
            if e.order == 0.0:
                return [f"R[{e.dof}] += cst[{c}]"]
            return [f"R[{e.dof}] += cst[{c}] * np.cos({_lit(e.order)} * tau + {_lit(e.phase)})"]

    @_builtin_form(ExpressionExcitation)
    class ExpressionExcitationForm(CompiledForm):
        def _name_of(self, name):
            return array_names(self.element.param_names, tau="tau", error=SimulationError)(name)

        def excitation_lines(self, tag, c):
            w = ex.CodeWriter(self._name_of, f"{tag}t")
            for _, node in self.element.exprs:
                w.count(node)
            stmts = [f"R[{d}] += {w.emit(node)}" for d, node in self.element.exprs]
            return list(w.lines) + stmts


def _nonsmooth(node) -> bool:
    stack = [node]
    while stack:
        n = stack.pop()
        if isinstance(n, ex.Select) or (isinstance(n, ex.Call) and n.fn in ("abs", "sign", "min", "max")):
            return True
        stack.extend(n.children())
    return False


# ---------------------------------------------------------------- generated module
_INTEGRATOR = '''

@njit(cache=True, error_model="numpy", inline="always")
def _step(y, tau0, dtau, hs, p, Minv, C, K, cst, mode, X, V, TAU, F, DUM, R, k1, k2, k3, k4, yt, out):
    # one classical RK4 step of length hs (phase advance dtau) in the frozen mode
    n2 = y.shape[0]
    rhs(y, tau0, p, Minv, C, K, cst, mode, X, V, TAU, F, DUM, R, k1)
    for i in range(n2):
        yt[i] = y[i] + 0.5 * hs * k1[i]
    rhs(yt, tau0 + 0.5 * dtau, p, Minv, C, K, cst, mode, X, V, TAU, F, DUM, R, k2)
    for i in range(n2):
        yt[i] = y[i] + 0.5 * hs * k2[i]
    rhs(yt, tau0 + 0.5 * dtau, p, Minv, C, K, cst, mode, X, V, TAU, F, DUM, R, k3)
    for i in range(n2):
        yt[i] = y[i] + hs * k3[i]
    rhs(yt, tau0 + dtau, p, Minv, C, K, cst, mode, X, V, TAU, F, DUM, R, k4)
    for i in range(n2):
        out[i] = y[i] + hs / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])


@njit(cache=True)
def _gfun(s, mode, crossed):
    # > 0 once any crossed switching function is past its surface
    g = -np.inf
    for j in range(NS):
        if crossed[j]:
            d = -s[j] if mode[j] != 0 else s[j]
            if d > g:
                g = d
    return g


@njit(cache=True, error_model="numpy")
def integrate(y, mode, k0, k1, S, h, p, Minv, C, K, cst, locate, max_events, rec_start, rec_every,
              out_y, sec_y, stats):
    """Steps k0..k1-1 in place on y (2n,) and mode (NS,); 0 = done, 1 = non-finite state."""
    n2 = y.shape[0]
    X = np.zeros((1, N))
    V = np.zeros((1, N))
    TAU = np.zeros(1)
    F = np.zeros((1, N))
    DUM = np.zeros((1, N, N))
    R = np.zeros(N)
    q1 = np.empty(n2)
    q2 = np.empty(n2)
    q3 = np.empty(n2)
    q4 = np.empty(n2)
    yt = np.empty(n2)
    ym = np.empty(n2)
    yb = np.empty(n2)
    ns = max(NS, 1)
    s0 = np.zeros(ns)
    sm = np.zeros(ns)
    sb = np.zeros(ns)
    crossed = np.zeros(ns, dtype=np.bool_)
    dphi = 2.0 * np.pi / S
    if NS > 0:
        switch(y, p, cst, X, V, s0)
    for k in range(k0, k1):
        kk = k % S
        theta = 0.0  # fraction of the step done
        nev = 0
        searching = False
        a = 0.0
        b = 1.0
        ga = 0.0
        gb = 0.0
        side = 0
        it = 0
        while True:
            frac = 1.0 - theta
            tau0 = (kk + theta) * dphi
            # one trial per pass: the rest of the step, or a point of the Illinois iteration on a crossing
            mth = 1.0
            if searching:
                mth = b - gb * (b - a) / (gb - ga)
                if not (mth > a and mth < b):
                    mth = 0.5 * (a + b)
            # the only call site of _step: it is inlined, and every copy costs compile time
            _step(y, tau0, mth * frac * dphi, mth * frac * h, p, Minv, C, K, cst, mode, X, V, TAU, F, DUM, R,
                  q1, q2, q3, q4, yt, ym)
            if NS == 0:
                for i in range(n2):
                    y[i] = ym[i]
                stats[3] += 1
                break
            switch(ym, p, cst, X, V, sm)
            if searching:
                stats[4] += 1
                it += 1
                gm = _gfun(sm, mode, crossed)
                if gm >= 0.0:
                    b = mth
                    gb = gm
                    for i in range(n2):
                        yb[i] = ym[i]
                    for j in range(NS):
                        sb[j] = sm[j]
                    if side == 1:
                        ga *= 0.5
                    side = 1
                else:
                    a = mth
                    ga = gm
                    if side == -1:
                        gb *= 0.5
                    side = -1
                if b - a > 1e-13 and it < 200:
                    continue
                # accept the state just past the surface and switch the crossing laws
                searching = False
                for j in range(NS):
                    if crossed[j]:
                        d = -sb[j] if mode[j] != 0 else sb[j]
                        if d >= 0.0:
                            mode[j] = 1 - mode[j]
                for i in range(n2):
                    y[i] = yb[i]
                for j in range(NS):
                    s0[j] = sb[j]
                theta = theta + b * frac
                nev += 1
                stats[0] += 1
                if theta >= 1.0 - 1e-12:
                    break
                continue
            stats[3] += 1
            ncross = 0
            for j in range(NS):
                crossed[j] = (sm[j] > 0.0) != (mode[j] != 0)
                if crossed[j]:
                    ncross += 1
            if ncross == 0:
                for i in range(n2):
                    y[i] = ym[i]
                for j in range(NS):
                    s0[j] = sm[j]
                break
            if (not locate) or nev >= max_events:
                # take the step as it is and follow the state's own contact state
                for i in range(n2):
                    y[i] = ym[i]
                for j in range(NS):
                    s0[j] = sm[j]
                    mode[j] = 1 if sm[j] > 0.0 else 0
                if locate:
                    stats[1] += 1
                break
            ga = _gfun(s0, mode, crossed)
            gb = _gfun(sm, mode, crossed)
            if ga > 0.0:
                # the start is already past a surface (round-off at an earlier event): resynchronise
                for j in range(NS):
                    if crossed[j]:
                        mode[j] = 1 if s0[j] > 0.0 else 0
                nev += 1
                stats[1] += 1
                continue
            # bracket [0, 1] of the remaining step: locate the first crossing in the frozen mode
            a = 0.0
            b = 1.0
            side = 0
            it = 0
            for i in range(n2):
                yb[i] = ym[i]
            for j in range(NS):
                sb[j] = sm[j]
            searching = True
        for i in range(n2):
            if not np.isfinite(y[i]):
                stats[2] = k + 1
                return 1
        kn = k + 1
        if kn % S == 0:
            for i in range(n2):
                sec_y[kn // S, i] = y[i]
        if kn >= rec_start and (kn - rec_start) % rec_every == 0:
            r = (kn - rec_start) // rec_every
            for i in range(n2):
                out_y[r, i] = y[i]
    return 0
'''


@functools.lru_cache(maxsize=None)
def _source_of(fn) -> bytes:
    # reading and tokenising the source file is most of the cost of a CompiledModel
    py = getattr(fn, "py_func", fn)
    try:
        return inspect.getsource(py).encode()
    except (OSError, TypeError):
        return repr(py).encode()


def _fingerprint(functions) -> str:
    h = hashlib.sha256()
    for fn in functions:
        h.update(_source_of(fn))
    return h.hexdigest()[:16]


@functools.lru_cache(maxsize=256)
def _check_syntax(src: str) -> None:
    compile(src, "<generated simulation module>", "exec")  # loaded by codegen


class CompiledModel:
    """A model's generated simulation module and how to fill its arguments.

    Parameters
    ----------
    model : Model

    Attributes
    ----------
    source : str
        The generated module source.
    n_switch : int
        Number of switching functions (contact surfaces) of the model.
    notes : list of str
    """

    def __init__(self, model: Model):
        if not _BUILTIN_FORMS:
            _register_builtin_forms()
            _BUILTIN_FORMS.append(True)
        self.model = model
        self.n = model.n_dof
        self.forces = [_form_of(el) for el in model.forces]
        self.excitations = [_form_of(el) for el in model.excitations]
        self.notes = [t for f in self.forces + self.excitations for t in f.notes()]
        self.source = self._source()
        self._module = None

    def _source(self) -> str:
        p0 = self.model.parameter_vector()
        n = self.n
        imports, globals_, force, switch, excite = set(), [], [], [], []
        kernels = []
        c = m = 0
        for i, f in enumerate(self.forces):
            tag = f"_f{i}_"
            imports.update(f.imports)
            kernels += list(f.kernels)
            globals_ += f.globals(tag)
            force += [f"    # force {i}: {type(f.element).__name__}"] + ["    " + s for s in f.force_lines(tag, c, m)]
            sw = f.switch_lines(tag, c, m)
            if sw:
                switch += ["    " + s for s in sw]
            c += len(f.constants(p0))
            m += f.n_switch
        self.n_switch = m
        for i, f in enumerate(self.excitations):
            tag = f"_e{i}_"
            imports.update(f.imports)
            kernels += list(f.kernels)
            globals_ += f.globals(tag)
            excite += [f"    # excitation {i}: {type(f.element).__name__}"] + \
                      ["    " + s for s in f.excitation_lines(tag, c)]
            c += len(f.constants(p0))
        self.n_constants = c
        head = [
            f"# contin generated simulation module (codegen {codegen.CODEGEN_VERSION}, "
            f"template {SIMULATION_TEMPLATE_VERSION}, kernels {_fingerprint(kernels)})",
            # no model name here: models of the same structure share one module (and its compiled code)
            f"# {n} dofs, {len(self.forces)} force elements, {len(self.excitations)} excitation elements",
            "import numpy as np",
            "from numba import njit",
        ] + sorted(imports) + ["", f"N = {n}", f"NS = {m}"] + globals_
        rhs = [
            "",
            "",
            # inlined into the integrator: a call per stage with a dozen array arguments costs more than the
            # right-hand side itself (reference counting of every array argument)
            '@njit(cache=True, error_model="numpy", inline="always")',
            "def rhs(y, tau, p, Minv, C, K, cst, mode, X, V, TAU, F, DUM, R, out):",
            "    # y' = (v, M^-1 (f_ext - C v - K x - f_nl)) in the frozen contact mode",
            "    for i in range(N):",
            "        X[0, i] = y[i]",
            "        V[0, i] = y[N + i]",
            "        F[0, i] = 0.0",
            "    TAU[0] = tau",
        ] + force + [
            "    for i in range(N):",
            "        s = -F[0, i]",
            "        for j in range(N):",
            "            s -= C[i, j] * V[0, j] + K[i, j] * X[0, j]",
            "        R[i] = s",
        ] + excite + [
            "    for i in range(N):",
            "        out[i] = V[0, i]",
            "        a = 0.0",
            "        for j in range(N):",
            "            a += Minv[i, j] * R[j]",
            "        out[N + i] = a",
            "",
            "",
            '@njit(cache=True, error_model="numpy")',
            "def switch(y, p, cst, X, V, S):",
            "    for i in range(N):",
            "        X[0, i] = y[i]",
            "        V[0, i] = y[N + i]",
        ] + (switch or ["    return"])
        src = "\n".join(head + rhs) + "\n" + _INTEGRATOR
        _check_syntax(src)
        return src

    @property
    def module(self):
        """The generated module, imported (and written to the kernel cache) on first use."""
        if self._module is None:
            self._module = codegen.load_module(self.source)
        return self._module

    def arguments(self, p: np.ndarray):
        """``(Minv, C, K, cst)`` at the parameter vector ``p``.

        Raises
        ------
        SimulationError
            If the mass matrix is singular.
        """
        M, C, K = self.model.linear(p)
        try:
            Minv = np.linalg.inv(M)
        except np.linalg.LinAlgError:
            raise SimulationError(f"model '{self.model.name}': the mass matrix is singular, "
                                  f"time simulation needs an invertible M") from None
        if not np.all(np.isfinite(Minv)) or np.linalg.cond(M) > 1e14:
            raise SimulationError(f"model '{self.model.name}': the mass matrix is singular "
                                  f"(cond {np.linalg.cond(M):.3g})")
        cst = []
        for f in self.forces + self.excitations:
            cst += [float(v) for v in f.constants(p)]
        cst = np.array(cst if cst else [0.0], dtype=float)
        return (np.ascontiguousarray(Minv), np.ascontiguousarray(C, dtype=float),
                np.ascontiguousarray(K, dtype=float), cst)

    def fastest_rate(self, p: np.ndarray) -> float:
        """Largest ``|lambda|`` of the linear part with every contact law active.

        The eigenvalues of ``[[0, I], [-M^-1 (K + Kc), -M^-1 (C + Cc)]]``, with the
        contact stiffness and damping of the elements added; classical RK4 is
        stable for ``h |lambda| <= 2.8`` (its stability boundary on the imaginary
        axis is ``2 sqrt 2``).
        """
        n = self.n
        M, C, K = self.model.linear(p)
        K, C = K.astype(float).copy(), C.astype(float).copy()
        for f in self.forces:
            mats = f.contact_matrices(p, n)
            if mats is not None:
                K += mats[0]
                C += mats[1]
        Minv = np.linalg.inv(M)
        A = np.zeros((2 * n, 2 * n))
        A[:n, n:] = np.eye(n)
        A[n:, :n] = -Minv @ K
        A[n:, n:] = -Minv @ C
        lam = np.linalg.eigvals(A)
        return float(np.max(np.abs(lam))) if lam.size else 0.0

    def _work(self):
        n = self.n
        return (np.zeros((1, n)), np.zeros((1, n)), np.zeros(1), np.zeros((1, n)), np.zeros((1, n, n)), np.zeros(n))

    def switching(self, y: np.ndarray, p: np.ndarray) -> np.ndarray:
        """Switching function values at the state ``y`` (2n,); shape (n_switch,)."""
        Minv, C, K, cst = self.arguments(p)
        X, V, _, _, _, _ = self._work()
        S = np.zeros(max(self.n_switch, 1))
        self.module.switch(np.ascontiguousarray(y, dtype=float), p, cst, X, V, S)
        return S[: self.n_switch]

    def mode_of(self, y: np.ndarray, p: np.ndarray) -> np.ndarray:
        """Contact mode (1 where a switching function is positive) at the state ``y``."""
        return (self.switching(y, p) > 0.0).astype(np.int64)

    def rhs(self, y: np.ndarray, tau: float, p: np.ndarray, mode=None) -> np.ndarray:
        """The compiled right-hand side ``y'`` at one state (for checks; shape (2n,)).

        Parameters
        ----------
        y : ndarray, shape (2n,)
        tau : float
            Excitation phase.
        p : ndarray, shape (P,)
        mode : ndarray of int, optional
            Frozen contact mode; default: the state's own (:meth:`mode_of`).
        """
        y = np.ascontiguousarray(y, dtype=float)
        p = np.ascontiguousarray(p, dtype=float)
        Minv, C, K, cst = self.arguments(p)
        if mode is None:
            mode = self.mode_of(y, p)
        mode = np.ascontiguousarray(mode, dtype=np.int64).reshape(-1)
        if mode.size == 0:
            mode = np.zeros(1, dtype=np.int64)
        out = np.zeros(2 * self.n)
        self.module.rhs(y, float(tau), p, Minv, C, K, cst, mode, *self._work(), out)
        return out


def compile_model(model: Model) -> CompiledModel:
    """The :class:`CompiledModel` of ``model``.

    Models of the same structure produce the same source text, hence the
    same module (:func:`contin.model.codegen.load_module` caches it by content).
    """
    return CompiledModel(model)


# ---------------------------------------------------------------- results and driver
@dataclasses.dataclass(eq=False)
class SimulationResult:
    """A simulated time history.

    Attributes
    ----------
    t : ndarray, shape (K,)
        Recorded times (``t = k h`` on the step grid).
    x, v : ndarray, shape (K, n)
        Displacements and velocities at ``t``.
    section : ndarray, shape (P + 1, 2n)
        State ``(x, x')`` at ``t = m T``, ``m = 0..P`` (the Poincare section
        ``tau = 0 mod 2 pi``) over the whole run, transient included.
    w : float
        Forcing frequency (the model's frequency parameter).
    period : float
        ``T = 2 pi / w``.
    steps_per_period : int
    h : float
        Step ``T / steps_per_period``.
    steps : int
        Steps taken.
    events : int
        Switching events located.
    unresolved_events : int
        Sign changes taken without location (only with ``locate_events``:
        more than ``max_events_per_step`` in one step, or a start already
        past a surface).
    extra_evaluations : int
        RK4 trial steps spent locating events.
    wall_time : float
        Seconds spent integrating (compilation excluded).
    compile_time : float
        Seconds spent loading or compiling the generated module.
    params : dict
        Parameter values used.
    dof_names : tuple of str
    final_state : ndarray, shape (2n,)
    final_mode : ndarray, shape (n_switch,)
    notes : list of str
    """

    t: np.ndarray
    x: np.ndarray
    v: np.ndarray
    section: np.ndarray
    w: float
    period: float
    steps_per_period: int
    h: float
    steps: int
    events: int
    unresolved_events: int
    extra_evaluations: int
    wall_time: float
    compile_time: float
    params: dict
    dof_names: tuple
    final_state: np.ndarray
    final_mode: np.ndarray
    locate_events: bool = True
    notes: list = dataclasses.field(default_factory=list)

    @property
    def periods(self) -> float:
        """Revolutions (forcing periods) simulated."""
        return self.steps / self.steps_per_period

    @property
    def cost_per_period_us(self) -> float:
        """Wall time per forcing period in microseconds."""
        return 1e6 * self.wall_time / max(self.periods, 1e-300)

    @property
    def state(self) -> np.ndarray:
        """Recorded states ``(x, x')``, shape (K, 2n)."""
        return np.concatenate([self.x, self.v], axis=1)


def _param_text(model: Model, p: np.ndarray) -> str:
    return ", ".join(f"{k}={v:.6g}" for k, v in zip(model.param_names, p))


def simulate(model: Model, params: Mapping[str, float] | None = None, x0=None, v0=None, *, t_end: float | None = None,
             periods: float | None = None, steps_per_period: int = 4096, record_every: int | None = None,
             record_from: float = 0.0, locate_events: bool = True, max_events_per_step: int = 8,
             progress: Callable[[float, float], None] | None = None, should_stop: Callable[[], bool] | None = None,
             mode0=None, check_step: bool = True) -> SimulationResult:
    """Integrate a model in time with fixed-step RK4 (event-located contact switching).

    Parameters
    ----------
    model : Model
    params : dict, optional
        Parameter overrides by name (the model's values otherwise).
    x0, v0 : array_like, shape (n,), optional
        Initial displacements and velocities (default zeros), at ``t = 0``
        (``tau = 0``).
    t_end : float, optional
        End time; rounded up to the step grid.
    periods : float, optional
        Or the number of forcing periods ``T = 2 pi / w`` (one of the two).
    steps_per_period : int
        ``S``; the step is ``h = T / S`` (the rotor paper: 4096).
    record_every : int, optional
        Record every this many steps (default ``max(1, S // 128)``).
    record_from : float
        Start recording after this many periods (the transient is not stored).
    locate_events : bool
        Locate contact switching in time (4th order) or step across it (1st order).
    max_events_per_step : int
        Events located within one step before the rest of the step is taken as is.
    progress : callable, optional
        ``progress(done_periods, total_periods)``, called between chunks.
    should_stop : callable, optional
        Polled between chunks; when true the run ends early (the result holds
        what was integrated).
    mode0 : array_like of int, optional
        Initial contact mode (default: from the signs of the switching functions).
    check_step : bool
        Refuse a step beyond RK4's stability limit for the linear part with
        the contacts closed (``h |lambda|max > 2.8``, :meth:`CompiledModel.fastest_rate`).

    Returns
    -------
    SimulationResult

    Raises
    ------
    SimulationError
        Non-finite state (with the time, step and parameter values), a step
        too large for the contact stiffness, or a model that cannot be
        simulated (singular mass matrix, element without compiled form).
    ValueError
        Bad arguments (non-positive frequency, both or neither of ``t_end`` and
        ``periods``, shapes).
    """
    model.check_variable(None, params)
    cm = compile_model(model)
    n = model.n_dof
    p = model.parameter_vector(params)
    kw = model.parameter_index(model.frequency)
    w = float(p[kw])
    if not (math.isfinite(w) and w > 0):
        raise ValueError(f"simulate: the forcing frequency {model.frequency} must be positive, got {w}")
    S = int(steps_per_period)
    if S != steps_per_period or S < 4:
        raise ValueError(f"simulate: steps_per_period must be an integer >= 4, got {steps_per_period!r}")
    T = 2.0 * math.pi / w
    h = T / S
    if (t_end is None) == (periods is None):
        raise ValueError("simulate: give exactly one of t_end and periods")
    if periods is not None:
        if not (periods > 0 and math.isfinite(periods)):
            raise ValueError(f"simulate: periods must be positive, got {periods}")
        nsteps = int(math.ceil(periods * S - 1e-9))
    else:
        if not (t_end > 0 and math.isfinite(t_end)):
            raise ValueError(f"simulate: t_end must be positive, got {t_end}")
        nsteps = int(math.ceil(t_end / h - 1e-9))
    rec_every = max(1, S // 128) if record_every is None else int(record_every)
    if rec_every < 1:
        raise ValueError(f"simulate: record_every must be >= 1, got {record_every}")
    rec_start = int(math.ceil(record_from * S - 1e-9))
    if not 0 <= rec_start <= nsteps:
        raise ValueError(f"simulate: record_from ({record_from} periods) must lie within the run "
                         f"({nsteps / S:g} periods)")
    y = np.zeros(2 * n)
    for arr, sl, name in ((x0, slice(0, n), "x0"), (v0, slice(n, 2 * n), "v0")):
        if arr is not None:
            a = np.asarray(arr, dtype=float).reshape(-1)
            if a.shape != (n,):
                raise ValueError(f"simulate: {name} must have {n} entries (dofs {list(model.dof_names)}), got {a.size}")
            y[sl] = a
    if not np.all(np.isfinite(y)):
        raise ValueError("simulate: the initial state is not finite")
    Minv, C, K, cst = cm.arguments(p)
    rate = cm.fastest_rate(p)
    if check_step and rate * h > RK4_STABILITY:
        need = int(math.ceil(rate * T / RK4_STABILITY))
        raise SimulationError(
            f"simulation of '{model.name}': the step h = T/{S} = {h:.3g} is too large for the stiffest mode "
            f"(|lambda| = {rate:.4g} with the contacts closed: h*|lambda| = {rate * h:.3g} > {RK4_STABILITY}, RK4 "
            f"would blow up or, with event location, chop its steps into a wrong answer); use steps_per_period >= "
            f"{need} ({_param_text(model, p)})")
    tc = time.perf_counter()
    mod = cm.module
    if mode0 is None:
        mode = cm.mode_of(y, p)
    else:
        mode = np.asarray(mode0, dtype=np.int64).reshape(-1).copy()
        if mode.shape != (cm.n_switch,):
            raise ValueError(f"simulate: mode0 must have {cm.n_switch} entries")
    if mode.size == 0:
        mode = np.zeros(1, dtype=np.int64)
    n_rec = (nsteps - rec_start) // rec_every + 1
    out_y = np.zeros((n_rec, 2 * n))
    n_sec = nsteps // S + 1
    sec_y = np.zeros((n_sec, 2 * n))
    sec_y[0] = y
    if rec_start == 0:
        out_y[0] = y
    stats = np.zeros(5, dtype=np.int64)
    # compile (or load from the cache) outside the timed region: a zero-step call
    mod.integrate(y.copy(), mode.copy(), 0, 0, S, h, p, Minv, C, K, cst, bool(locate_events), int(max_events_per_step),
                  rec_start, rec_every, out_y[:0], sec_y[:0], stats.copy())
    compile_time = time.perf_counter() - tc
    chunk = max(S, min(1 << 18, 64 * S))
    t0 = time.perf_counter()
    k = 0
    while k < nsteps:
        k1 = min(nsteps, k + chunk)
        status = mod.integrate(y, mode, k, k1, S, h, p, Minv, C, K, cst, bool(locate_events),
                               int(max_events_per_step), rec_start, rec_every, out_y, sec_y, stats)
        if status != 0:
            kf = int(stats[2])
            raise SimulationError(
                f"simulation of '{model.name}' blew up: non-finite state at t = {kf * h:.6g} (step {kf}, "
                f"{kf / S:.2f} periods) with {_param_text(model, p)}; the step h = T/{S} = {h:.3g} may be too "
                f"large for the stiffest force (RK4 needs h*omega_max < 2.8: raise steps_per_period)"
            )
        k = k1
        if progress is not None:
            progress(k / S, nsteps / S)
        if should_stop is not None and k < nsteps and should_stop():
            break
    wall = time.perf_counter() - t0
    done = k
    n_done = 0 if done < rec_start else (done - rec_start) // rec_every + 1
    out_y = out_y[:n_done]
    sec_y = sec_y[: done // S + 1]
    t = (rec_start + rec_every * np.arange(n_done)) * h
    return SimulationResult(
        t=t, x=out_y[:, :n].copy(), v=out_y[:, n:].copy(), section=sec_y, w=w, period=T, steps_per_period=S, h=h,
        steps=done, events=int(stats[0]), unresolved_events=int(stats[1]), extra_evaluations=int(stats[4]),
        wall_time=wall, compile_time=compile_time, params=dict(zip(model.param_names, map(float, p))),
        dof_names=tuple(model.dof_names), final_state=y.copy(), final_mode=mode[: cm.n_switch].copy(),
        locate_events=bool(locate_events), notes=list(cm.notes),
    )
