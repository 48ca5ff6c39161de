"""The generated simulation module of a model: its right-hand side, switching functions and RK4 loop.

Compiled right-hand side
------------------------
For each model *structure* (dofs, element kinds, dof indices, exponents,
expression texts, excitation orders and phases) a small module is generated
and imported with :func:`contin.model.codegen.load_module`, so numba's
``cache=True`` works across processes. It holds the right-hand side, the
switching functions and the integrator loop, all compiled together: no Python
call is made per step. Parameter values (matrices, clearances, stiffnesses,
amplitudes) are arguments, so a parameter sweep reuses the compiled code.

Each element gives its *compiled form*
(:class:`contin.model.elements.registry.CompiledForm`, from the element's
``compiled_form()``, in the element's own file): polynomial forces call their
element kernel (:func:`contin.model.elements.polynomial._poly_kernel`) on 1-sample
views; expression forces and excitations are emitted as code from their
expression trees (their symbolic Jacobians too, for the variational equations of
:mod:`contin.timedomain.variational`); harmonic excitations are a cosine
line; gap and radial-gap contacts call mode-aware kernels of their own files.
This module only assembles the forms: it knows no element kind.

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

A switching function can also leave its side and come back within one step
(a contact arc, or a flight arc, born at a grazing and still shorter than a
step); the signs at the step ends do not show it. Where a function is near
zero (within twice its second difference over the last steps, or at the start
of a run or after an event), the cubic through its values and its slopes
``s' = grad s . y'`` at both ends of the step (Hermite) gives its turn; a turn
past the surface is tried by an RK4 step to it, and if the function has
crossed there, the first crossing is located in ``[0, turn]`` as above (the
second by the sign change at the end). The flow map then stays continuous at
a grazing up to dips of depth ``O(h^4)`` the cubic cannot see (Leine &
Nijmeijer, *Dynamics and Bifurcations of Non-Smooth Mechanical Systems*, 2004,
ch. 7, on why the flow map itself is continuous there). Switching inside
expression forces (``abs``, ``sign``, ``min``, ``max``) is not located.
"""

from __future__ import annotations

import functools
import hashlib
import inspect
import re

import numpy as np

from contin.model import codegen
from contin.model.base import Model
from contin.model.elements.registry import CompiledForm, kinds_with_compiled_form
from contin.timedomain.integrator_source import INTEGRATOR, MINV_TIMES_R
from contin.timedomain.variational_source import jacobian_functions

__all__ = ["SimulationError", "CompiledModel", "compile_model", "RK4_STABILITY", "SIMULATION_TEMPLATE_VERSION"]

#: bumped when the integrator template changes meaning
SIMULATION_TEMPLATE_VERSION = "3"

#: largest h*|lambda| accepted (classical RK4 is stable up to 2 sqrt 2 on the imaginary axis)
RK4_STABILITY = 2.8


def _structurally_diagonal(mass) -> bool:
    """Whether every term of the mass matrix (a :class:`contin.model.base.ParametricMatrix`) is diagonal."""
    terms = getattr(mass, "terms", None)
    if terms is None:
        return False
    return all(np.count_nonzero(np.asarray(A) - np.diag(np.diag(np.asarray(A)))) == 0 for _, A in terms)


class SimulationError(ArithmeticError):
    """A simulation that cannot go on (non-finite state, unsupported element)."""


def _form_of(el) -> CompiledForm:
    form = el.compiled_form()
    if form is None:
        raise SimulationError(
            f"element '{getattr(el, 'kind', '') or type(el).__name__}' ({type(el).__name__}) has no compiled form "
            f"for time simulation; element kinds with one: {kinds_with_compiled_form()}. Give its class a "
            f"compiled_form() method returning a contin.model.elements.registry.CompiledForm."
        )
    return form




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
        self.model = model
        self.n = model.n_dof
        self.forces = [_form_of(el) for el in model.forces]
        self.excitations = [_form_of(el) for el in model.excitations]
        self.notes = [t for f in self.forces + self.excitations for t in f.notes()]
        #: the mass matrix is diagonal whatever the parameters (each of its terms is)
        self.diagonal_mass = _structurally_diagonal(model.mass)
        self.source = self._source()
        self._module = None
        self._minv = None  # (M's bytes, M^-1): the mass matrix rarely moves with the continuation parameter

    def _source(self) -> str:
        p0 = self.model.parameter_vector()
        n = self.n
        imports, globals_, force, switch, excite, grad = set(), [], [], [], [], []
        no_grad = False
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
            gl = f.switch_gradient_lines(tag, c, m)
            if gl is None:
                no_grad = True
            else:
                grad += ["    " + s for s in gl]
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
        self.n_force_constants = sum(len(f.constants(p0)) for f in self.forces)
        #: the parameters the force laws and switching functions read directly (``p[k]`` in their lines, as an
        #: expression force does) besides their constants
        self.force_parameters = frozenset(int(k) for line in force + switch + grad
                                          for k in _PARAMETER_READ.findall(line))
        #: every excitation's lines are linear in its constants (a parameter sensitivity can be integrated)
        self.linear_excitations = all(f.linear_in_constants for f in self.excitations)
        head = [
            f"# contin generated simulation module (codegen {codegen.CODEGEN_VERSION}, "
            f"template {SIMULATION_TEMPLATE_VERSION}, kernels {_fingerprint(kernels)})",
            # no model name here: models of the same structure share one module (and its compiled code)
            f"# {n} dofs, {len(self.forces)} force elements, {len(self.excitations)} excitation elements",
            "import numpy as np",
            "from contin.util.jit import njit",  # cached only in the private cache directory
        ] + sorted(imports) + ["", f"N = {n}", f"NS = {m}",
                               # dips through a surface inside a step are found where every surface has a gradient
                               f"DIP = {0 if no_grad or not m else 1}",
                               # a mass matrix diagonal for every parameter value: M^-1 is, and its products
                               # skip the exact zeros (the same numbers)
                               f"MDIAG = {1 if self.diagonal_mass else 0}"] + globals_
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
        ] + MINV_TIMES_R + [
            "",
            "",
            '@njit(cache=True, error_model="numpy")',
            "def switch(y, p, cst, X, V, S):",
            "    for i in range(N):",
            "        X[0, i] = y[i]",
            "        V[0, i] = y[N + i]",
        ] + (switch or ["    return"]) + [
            "",
            "",
            '@njit(cache=True, error_model="numpy")',
            "def switch_grad(y, p, cst, X, V, G):",
            "    # the switching functions' gradients in y, shape (NS, 2N)",
            "    for i in range(N):",
            "        X[0, i] = y[i]",
            "        V[0, i] = y[N + i]",
            "    for i in range(G.shape[0]):",
            "        for j in range(G.shape[1]):",
            "            G[i, j] = 0.0",
        ] + ([] if no_grad else grad)
        src = "\n".join(head + rhs) + "\n" + INTEGRATOR
        _check_syntax(src)
        return src

    def jacobian_source(self) -> str:
        """The generated functions of the variational equations (appended to :attr:`source`).

        ``jac(y, tau, p, Minv, C, K, cst, mode, X, V, TAU, F, DX, DXD, B)``
        writes ``B = -M^-1 [K + df/dx, C + df/dx']`` (shape (n, 2n)), the lower
        block rows of the state matrix in the frozen ``mode``;
        ``rhs_tau(y, tau, p, Minv, C, K, cst, mode, X, V, TAU, F, R, out)``
        the right-hand side's derivative in the phase ``tau`` (for the
        derivative of a step in its start and end times at a located switch).

        Raises
        ------
        SimulationError
            Naming the element kinds whose compiled form has no Jacobian,
            gradient or (for a phase-dependent element) tau-derivative lines
            (a Jacobian is never taken as zero silently).
        """
        p0 = self.model.parameter_vector()
        jac, missing = [], []
        ftau, etau, untimed, elam = [], [], [], []
        c = m = 0

        def name(f):
            el = f.element
            return f"'{getattr(el, 'kind', '') or type(el).__name__}' ({type(el).__name__})"

        for i, f in enumerate(self.forces):
            tag = f"_f{i}_"
            lines = f.jacobian_lines(tag, c, m)
            glines = f.switch_gradient_lines(tag, c, m)
            tlines = f.force_dtau_lines(tag, c, m)
            if lines is None or glines is None:
                missing.append(name(f))
            else:
                jac += [f"    # force {i}: {type(f.element).__name__}"] + ["    " + s for s in lines]
            if tlines is None:
                untimed.append(name(f))
            else:
                ftau += ["    " + s for s in tlines]
            c += len(f.constants(p0))
            m += f.n_switch
        for i, f in enumerate(self.excitations):
            tlines = f.excitation_dtau_lines(f"_e{i}_", c)
            if tlines is None:
                untimed.append(name(f))
            else:
                etau += ["    " + s for s in tlines]
            if f.linear_in_constants:  # (the others: shooting's dR/dlambda by differences, sensitivity_ready)
                elam += ["    " + s.replace("cst[", "dcst[") for s in f.excitation_lines(f"_e{i}_", c)]
            c += len(f.constants(p0))
        if missing:
            raise SimulationError(
                f"model '{self.model.name}': the element kind(s) {', '.join(missing)} have no Jacobian lines in "
                f"their compiled form, so the variational equations cannot be integrated; give the form "
                f"jacobian_lines() (and switch_gradient_lines() for a contact), or use central differences")
        if untimed:
            # the derivative of a step in its start and end times (at located switches) needs d rhs / d tau
            raise SimulationError(
                f"model '{self.model.name}': the element kind(s) {', '.join(untimed)} depend on the phase tau and "
                f"have no tau-derivative lines in their compiled form (force_dtau_lines() or "
                f"excitation_dtau_lines()), so the variational equations cannot be integrated; use central "
                f"differences")
        return jacobian_functions(jac, ftau, etau, elam)

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
        key = np.ascontiguousarray(M, dtype=float).tobytes()
        if self._minv is not None and self._minv[0] == key:
            Minv = self._minv[1]
        else:
            try:
                Minv = np.linalg.inv(M)
            except np.linalg.LinAlgError:
                raise SimulationError(f"model '{self.model.name}': the mass matrix is singular, "
                                      f"time simulation needs an invertible M") from None
            if not np.all(np.isfinite(Minv)) or np.linalg.cond(M) > 1e14:
                raise SimulationError(f"model '{self.model.name}': the mass matrix is singular "
                                      f"(cond {np.linalg.cond(M):.3g})")
            Minv = np.ascontiguousarray(Minv)  # shared by the calls with the same M (the kernels only read it)
            self._minv = (key, Minv)
        cst = []
        for f in self.forces + self.excitations:
            cst += [float(v) for v in f.constants(p)]
        cst = np.array(cst if cst else [0.0], dtype=float)
        return (Minv, np.ascontiguousarray(C, dtype=float),
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


_PARAMETER_READ = re.compile(r"\bp\[(\d+)\]")


def compile_model(model: Model) -> CompiledModel:
    """The :class:`CompiledModel` of ``model``.

    Models of the same structure produce the same source text, hence the
    same module (:func:`contin.model.codegen.load_module` caches it by content).
    """
    return CompiledModel(model)
