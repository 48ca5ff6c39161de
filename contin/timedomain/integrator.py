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
Limitations: a grazing contact that starts and ends within one step is not
seen (its effect is of the order of the penetration, ``O(h^2)`` at most);
switching inside expression forces (``abs``, ``sign``, ``min``, ``max``) is
not located.
"""

from __future__ import annotations

import functools
import hashlib
import inspect

import numpy as np

from contin.model import codegen
from contin.model.base import Model
from contin.model.elements.registry import CompiledForm, kinds_with_compiled_form
from contin.timedomain.variational_source import jacobian_functions

__all__ = ["SimulationError", "CompiledModel", "compile_model", "RK4_STABILITY", "SIMULATION_TEMPLATE_VERSION"]

#: bumped when the integrator template changes meaning
SIMULATION_TEMPLATE_VERSION = "1"
#: largest h*|lambda| accepted (classical RK4 is stable up to 2 sqrt 2 on the imaginary axis)
RK4_STABILITY = 2.8


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
            "from contin.util.jit import njit",  # cached only in the private cache directory
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

    def jacobian_source(self) -> str:
        """The generated functions of the variational equations (appended to :attr:`source`).

        ``jac(y, tau, p, Minv, C, K, cst, mode, X, V, TAU, F, DX, DXD, B)``
        writes ``B = -M^-1 [K + df/dx, C + df/dx']`` (shape (n, 2n)), the lower
        block rows of the state matrix in the frozen ``mode``;
        ``switch_grad(y, p, cst, X, V, G)`` the gradients of the switching
        functions (shape (NS, 2n));
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
        jac, grad, missing = [], [], []
        ftau, etau, untimed = [], [], []
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
                grad += ["    " + s for s in glines]
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
        return jacobian_functions(jac, grad, ftau, etau)

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
