"""The compiled variational flow: the RK4 flow map of a model and its exact derivative, switches included.

:class:`VariationalFlow` integrates the state ``z = (x, x')`` over RK4 steps
``k0 .. k1`` of the forcing-phase grid of :func:`contin.timedomain.simulation.simulate`
(the phase of step ``k`` is ``2 pi (k mod S) / S``), with the same located
contact switching, and, with ``jacobian=True``, the matrix
``Phi = d z(k1) / d z(k0)`` (shape (2n, 2n)) in the same compiled loop.

Variational equations
---------------------
Between switches each RK4 step is a smooth map of one frozen contact mode, and
``Phi`` is propagated through the *same* stages,

    K1 = A(y) Phi,  K2 = A(y + h/2 k1) (Phi + h/2 K1),  K3 = A(y + h/2 k2) (Phi + h/2 K2),
    K4 = A(y + h k3) (Phi + h K3),  Phi <- Phi + h/6 (K1 + 2 K2 + 2 K3 + K4),

``A = [[0, I], [-M^-1 (K + df/dx), -M^-1 (C + df/dx')]]`` evaluated at the
stage states with the frozen mode's law: ``Phi`` is the exact derivative of
the discrete RK4 map (not of an approximation of it). The Jacobians come from
the elements' compiled forms
(:meth:`contin.model.elements.registry.CompiledForm.jacobian_lines`); an
element without them is refused by name when a Jacobian is asked.

Located switches
----------------
At a located switch (the state just past the surface, see
:mod:`contin.timedomain.integrator`) ``Phi`` stays the derivative of the
discrete map: the event time depends on the state, and so does the start of
the sub-step after it. Each accepted sub-step is an RK4 step
``R(y, t0, t1)`` of length ``t1 - t0`` from the phase ``omega t0``; besides
``Phi`` the loop carries the row ``g = d t0 / dz`` of the current sub-step's
start (zero at grid times). With ``P = dR/dy`` (the stages above),
``a = dR/dt0`` and ``b = dR/dt1``:

- a sub-step ending at a grid time: ``Phi <- P Phi + a g^T``, ``g <- 0``;
- a sub-step ending at a located switch ``t_e`` (``s(y_b) = 0``, ``n`` the
  gradient of the switching function, which does not depend on the phase):
  ``dt_e = -n^T (P Phi + a g^T) / (n^T b)``,
  ``Phi <- P Phi + a g^T + b dt_e``, ``g <- dt_e``; the next sub-step, an
  RK4 step of the new mode, carries the switch on through its own ``a``.

``a`` and ``b`` are the RK4 formulas differentiated exactly (stage ``i`` at
``Y_i = y + c_i h k_{i-1}``, phase ``tau0 + c_i omega h``, ``c = (0, 1/2, 1/2, 1)``,
``J_i``, ``f_tau,i`` the right-hand side's derivatives in ``y`` and ``tau``
there):

    b = (k1 + 2 k2 + 2 k3 + k4)/6 + h/6 (dk1 + 2 dk2 + 2 dk3 + dk4),
        dk1 = 0,  dk_i = J_i c_i (k_{i-1} + h dk_{i-1}) + c_i omega f_tau,i;
    a = -b + h/6 (ek1 + 2 ek2 + 2 ek3 + ek4),
        ek1 = omega f_tau,1,  ek_i = J_i c_i h ek_{i-1} + omega f_tau,i

(the second term is the derivative in ``t0`` at fixed length). ``f_tau``
comes from the compiled forms' tau-derivative lines
(:meth:`contin.model.elements.registry.CompiledForm.excitation_dtau_lines`,
:meth:`~contin.model.elements.registry.CompiledForm.force_dtau_lines`); a
phase-dependent element without them is refused by name when a Jacobian is
asked. ``a`` and ``b`` are evaluated only for sub-steps that end at a switch
or start at one, so a run costs what it did without them.

In the limit of short steps this is the saltation matrix of the continuous
flow, ``I + (f+ - f-) n^T / (n^T f-)`` (Aizerman & Gantmakher, PMM 22 (1958);
Leine & Nijmeijer, *Dynamics and Bifurcations of Non-Smooth Mechanical
Systems*, Springer 2004, ch. 7; the harmonic-balance orbit's version is
:mod:`contin.stability.saltation`), with ``b`` for ``f-`` and ``-a`` of the
next sub-step for ``f+``. The two differ by the RK4 error in the rate of the
sub-steps, of order ``(h |lambda|)^4 |f|`` against ``n^T f-``: far below
the orbit's RK4 error where the surface is crossed transversally, not where
a stiff contact is left slowly (the bearing rotor at ``f0 = 0.2``,
``w = 2``, 4096 steps: the discrete map's derivative is 1.6e-2 off the
flow's over the step of the switch). There the saltation matrix would leave
Newton on the discrete map converging linearly; ``Phi`` is the discrete
map's (``tests/timedomain/test_variational.py``).

Parameter sensitivity
---------------------
With ``sensitivity`` (:func:`parameter_sensitivity`) ``Phi`` carries one more
column, ``q = dy/dlambda`` at fixed phases (the phase grid does not move with
``lambda``; the step ``h = 2 pi / (w S)`` does, at the rate
``d ln h / d lambda``). Through the same stages,

    dY_i = q + c_i (dh k_{i-1} + h dk_{i-1}),  dk_i = A_i dY_i + f_lambda,i,
    q <- q + dh/6 (k1 + 2 k2 + 2 k3 + k4) + h/6 (dk1 + 2 dk2 + 2 dk3 + dk4),

with ``f_lambda = (0, M^-1 (f_ext,lambda - C_lambda v - K_lambda x))`` from
the compiled ``rhs_lam`` (the mass and the force laws must not depend on
``lambda``). At a located switch ``q`` is one more column of the updates
above: the event's phase moves with ``lambda`` as its time with the state,
and the factors of ``w`` in ``a``, ``b`` and ``dt_e`` cancel. Each factor's
column gathers the sensitivity over its steps; the run carries them through
the later factors (:attr:`VariationalRun.sensitivity`).

Residuals. The Illinois iteration stops with a bracket below ``1e-13`` of the
step and accepts the state just past the surface (``s(y_b)`` of the order of
``1e-13 h |n^T b|``), not the root: the map differs from the one with the
exact event time by about ``1e-13 h |b|``, which ``Phi`` (the implicit
derivative at the root) does not see; in central differences with a relative
step ``e`` it is noise of order ``1e-13 h / e``. A start already past a
surface (round-off at an earlier event) is switched at once with the
derivative of a located switch of zero length (``P = I``, ``b = -a = f-``),
the limit of the located one. Where ``n^T b = 0`` (grazing incidence) the
event time is taken as fixed (counted in ``undefined_saltations``).

The derivative over ``k1 - k0`` steps is returned as ``K`` factors, each over
an equal consecutive share of the steps (``Phi = F[K-1] ... F[0]``), for
periodic Schur and multiple shooting: over many periods the product
under- or overflows where its factors do not.

Grazing measure
---------------
For each switching function ``s`` and every (sub-)step the loop takes the
cubic through ``s`` and its slope ``s' = grad s . y'`` at both ends of the
step (Hermite; the simulation module's ``_turns``); where the slopes differ
in sign it has one turn inside the step, and the turn's value is kept when it
is the nearest to zero so far (``run.graze``, ``+inf`` where no turn was
seen). Its sign changes where a contact arc appears or vanishes. The
interpolant's error is ``O(h^4)`` (the fourth derivative of ``s``), and the
measure is continuous in the initial state: when a turn passes a step end,
``s'`` is zero there and the cubics on both sides give the value of ``s``
itself. Sub-steps ending at a located switch are taken in their own contact
mode, so the turn of a short arc between two switches is seen. On a whole
step where no dip through a surface is possible (the simulation module's
``_near``) the slopes at its end are those the next step's first stage gives
(the same state and mode; the run's last step evaluates them once more), so
such a step costs one switching gradient and no extra right-hand side.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from contin.model import codegen
from contin.model.base import Model
from contin.timedomain.integrator import RK4_STABILITY, SimulationError, compile_model
from contin.timedomain.variational_source import NO_JACOBIAN, VARIATIONAL

__all__ = ["VariationalFlow", "VariationalRun"]


@dataclasses.dataclass(frozen=True, eq=False)
class VariationalRun:
    """One run of :meth:`VariationalFlow.run`.

    Attributes
    ----------
    state : ndarray, shape (2n,)
        ``z(k1)``.
    factors : ndarray, shape (K, 2n, 2n)
        ``d z(k1) / d z(k0) = factors[K-1] @ ... @ factors[0]``, each over
        ``(k1 - k0) / K`` consecutive steps; shape (0, 2n, 2n) without Jacobian.
    jacobian : ndarray, shape (2n, 2n), or None
        The product of the factors (None without Jacobian).
    switches : int
        Switches located.
    mode : ndarray of int, shape (n_switch,)
        Contact mode at ``k1``.
    graze : ndarray, shape (n_switch,)
        For each switching function the signed value of its local extremum
        nearest to zero along the run (``+inf`` where none; module docstring).
    unresolved : int
        Sign changes taken without location (more than ``max_events``
        in a step, or a start already past a surface).
    undefined_saltations : int
        Switches where ``n^T dR/dt1 = 0`` (grazing incidence): the event time
        taken as independent of the state there.
    sensitivity : ndarray, shape (2n,), or None
        ``d z(k1) / d lambda`` at fixed ``z(k0)`` and fixed phases (with ``sensitivity`` asked of
        :meth:`VariationalFlow.run`).
    """

    state: np.ndarray
    factors: np.ndarray
    jacobian: np.ndarray | None
    switches: int
    mode: np.ndarray
    graze: np.ndarray
    unresolved: int = 0
    undefined_saltations: int = 0
    sensitivity: np.ndarray | None = None


def parameter_sensitivity(compiled, p_lo: np.ndarray, p_hi: np.ndarray, step: float, kw: int):
    """The ``sensitivity`` argument of :meth:`VariationalFlow.run` for a parameter ``lambda``.

    From the model's parameter vectors at ``lambda -+ step`` (shape (P,)): central differences of the
    damping and stiffness matrices and of the compiled constants (exact for their dependence on the
    parameters, at most quadratic in the built-in and scene elements, up to rounding ``eps / step``), and
    ``d ln h / d lambda = -(dw / dlambda) / w`` with ``w = p[kw]``, the forcing frequency.

    Returns
    -------
    tuple or None
        ``(dC, dK, dcst, rate)``; None where no sensitivity is integrated (``dR/dlambda`` is then taken by
        differences of the flow): the mass matrix or a force law (its constants, or a parameter its lines read)
        moves with ``lambda``, or an excitation's lines are not linear in its constants.
    """
    if not compiled.linear_excitations or compiled.force_parameters & set(np.flatnonzero(p_lo != p_hi).tolist()):
        return None
    M_lo, C_lo, K_lo = compiled.model.linear(p_lo)
    M_hi, C_hi, K_hi = compiled.model.linear(p_hi)
    nf = compiled.n_force_constants
    cst_lo, cst_hi = (compiled.arguments(q)[3] for q in (p_lo, p_hi))
    if not (np.array_equal(M_lo, M_hi) and np.array_equal(cst_lo[:nf], cst_hi[:nf])):
        return None
    d = 2.0 * step
    w = 0.5 * (p_lo[kw] + p_hi[kw])
    return ((np.asarray(C_hi, dtype=float) - C_lo) / d, (np.asarray(K_hi, dtype=float) - K_lo) / d,
            (cst_hi - cst_lo) / d, -float(p_hi[kw] - p_lo[kw]) / d / w)


class VariationalFlow:
    """The compiled RK4 flow of a model with the exact derivative of its discrete map (module docstring).

    Parameters
    ----------
    model : Model
    steps_per_period : int
        ``S``: RK4 steps per forcing period ``2 pi / w`` (the grid of
        :func:`contin.timedomain.simulation.simulate`).
    max_events : int
        Switches located within one step before the rest is taken as is.

    Raises
    ------
    SimulationError
        An element without compiled form (as :func:`simulate`).
    ValueError
        ``steps_per_period`` not an integer >= 4.

    Notes
    -----
    The module is generated per model *structure* and cached on disk with
    the simulation module's (:func:`contin.model.codegen.load_module`):
    parameter values are arguments, so a sweep reuses it.
    """

    def __init__(self, model: Model, steps_per_period: int = 4096, max_events: int = 8):
        S = steps_per_period
        if isinstance(S, bool) or not isinstance(S, (int, np.integer)) or S < 4:
            raise ValueError(f"VariationalFlow: steps_per_period must be an integer >= 4, got {S!r}")
        if isinstance(max_events, bool) or not isinstance(max_events, (int, np.integer)) or max_events < 1:
            raise ValueError(f"VariationalFlow: max_events must be a positive integer, got {max_events!r}")
        self.model = model
        self.steps_per_period = int(S)
        self.max_events = int(max_events)
        self.compiled = compile_model(model)
        self.n = model.n_dof
        self.n_switch = self.compiled.n_switch
        try:
            self._source = self.compiled.source + self.compiled.jacobian_source() + VARIATIONAL
            self._missing = None
        except SimulationError as exc:
            # state-only runs still work (the Jacobian functions are never called); a Jacobian is refused
            self._source = self.compiled.source + NO_JACOBIAN + VARIATIONAL
            self._missing = exc
        self._module = None
        self._checked = None
        self._kw = model.parameter_index(model.frequency)

    @property
    def module(self):
        """The generated module (simulation module, Jacobians and the variational loop)."""
        if self._module is None:
            self._module = codegen.load_module(self._source)
        return self._module

    def _arguments(self, p: np.ndarray):
        key = p.tobytes()
        if self._checked is not None and self._checked[0] == key:
            return self._checked[1]
        w = float(p[self._kw])
        if not (math.isfinite(w) and w > 0):
            raise ValueError(f"VariationalFlow: the forcing frequency {self.model.frequency} must be positive, "
                             f"got {w}")
        h = 2.0 * math.pi / w / self.steps_per_period
        args = self.compiled.arguments(p)
        rate = self.compiled.fastest_rate(p)
        if rate * h > RK4_STABILITY:
            need = int(math.ceil(rate * h * self.steps_per_period / RK4_STABILITY))
            raise SimulationError(
                f"variational flow of '{self.model.name}': the step h = T/{self.steps_per_period} = {h:.3g} is "
                f"too large for the stiffest mode (h*|lambda| = {rate * h:.3g} > {RK4_STABILITY}); use "
                f"steps_per_period >= {need}")
        self._checked = (key, (h, args))
        return h, args

    def run(self, z, p, k0: int, k1: int, jacobian: bool = True, factors: int = 1, mode=None,
            sensitivity=None) -> VariationalRun:
        """Integrate from step ``k0`` to step ``k1`` (module docstring).

        Parameters
        ----------
        z : array_like, shape (2n,)
            State ``(x, x')`` at step ``k0``.
        p : array_like, shape (P,)
            The model's parameter vector (``model.parameter_vector(params)``).
        k0, k1 : int
            Step indices, ``k0 < k1``; the phase of step ``k`` is ``2 pi (k mod S) / S``.
        jacobian : bool
            Integrate the variational equations too.
        factors : int
            ``K``, the number of factors; it must divide ``k1 - k0``.
        mode : array_like of int, shape (n_switch,), optional
            Contact mode at ``k0`` (default: the state's own).
        sensitivity : tuple, optional
            ``(dC, dK, dcst, rate)``: the derivatives in a parameter ``lambda`` of the damping and stiffness
            matrices (n, n) and of the compiled constants, and ``d ln h / d lambda`` (``-(dw/dlambda) / w``);
            with ``jacobian``, ``d z(k1) / d lambda`` is integrated with ``Phi`` through the same stages and
            switches (module docstring). The mass matrix and the force laws' constants must not depend on
            ``lambda``, and every excitation's lines must be linear in its constants (the caller's check:
            :meth:`sensitivity_ready`).

        Returns
        -------
        VariationalRun

        Raises
        ------
        ValueError
            Bad shapes, ``k0 >= k1``, ``factors`` not a positive divisor of ``k1 - k0``.
        SimulationError
            The flow blows up (non-finite state or derivative), the step is
            beyond RK4's stability, or a Jacobian is asked of a model with an
            element kind that has no Jacobian lines or, depending on the
            phase, no tau-derivative lines (named).
        """
        n2 = 2 * self.n
        z = np.array(z, dtype=float).reshape(-1)
        if z.shape != (n2,):
            raise ValueError(f"VariationalFlow.run: z must have shape ({n2},) = (x, x') of model "
                             f"'{self.model.name}', got {z.shape}")
        if not np.all(np.isfinite(z)):
            raise ValueError("VariationalFlow.run: the state z is not finite")
        p = np.ascontiguousarray(p, dtype=float).reshape(-1)
        if p.shape != (len(self.model.param_names),):
            raise ValueError(f"VariationalFlow.run: p must have {len(self.model.param_names)} entries "
                             f"({list(self.model.param_names)}), got {p.size}")
        for name, v in (("k0", k0), ("k1", k1), ("factors", factors)):
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)):
                raise ValueError(f"VariationalFlow.run: {name} must be an integer, got {v!r}")
        k0, k1 = int(k0), int(k1)
        if not 0 <= k0 < k1:
            raise ValueError(f"VariationalFlow.run: need 0 <= k0 < k1, got k0 = {k0}, k1 = {k1}")
        K = int(factors)
        if K < 1 or (k1 - k0) % K != 0:
            raise ValueError(f"VariationalFlow.run: factors K = {K} must be a positive divisor of the number of "
                             f"steps k1 - k0 = {k1 - k0}")
        if jacobian and self._missing is not None:
            raise self._missing
        h, (Minv, C, Kmat, cst) = self._arguments(p)
        ns = self.n_switch
        if mode is None:
            m = self.compiled.mode_of(z, p) if ns else np.zeros(0, dtype=np.int64)
        else:
            m = np.asarray(mode).reshape(-1)
            if m.shape != (ns,) or not np.all((m == 0) | (m == 1)):
                raise ValueError(f"VariationalFlow.run: mode must have {ns} entries of 0 or 1, got {mode!r}")
        m = np.ascontiguousarray(m, dtype=np.int64).copy()
        if m.size == 0:
            m = np.zeros(1, dtype=np.int64)
        want = bool(jacobian)
        lam = want and sensitivity is not None
        nc = n2 + 1 if lam else n2
        P = np.eye(n2, nc)
        fac = np.zeros((K if want else 0, n2, nc))
        graze = np.full(max(ns, 1), np.inf)
        stats = np.zeros(6, dtype=np.int64)
        y = z.copy()
        if lam:
            dC, dK, dcst, rate = sensitivity
            dC, dK = np.ascontiguousarray(dC, dtype=float), np.ascontiguousarray(dK, dtype=float)
            dcst, rate = np.ascontiguousarray(dcst, dtype=float), float(rate)
        else:
            dC, dK, dcst, rate = C, Kmat, cst, 0.0  # not read
        if want:
            status = self.module.flow(y, m, P, k0, k1, self.steps_per_period, h, p, Minv, C, Kmat, cst, dC, dK,
                                      dcst, rate, self.max_events, True, (k1 - k0) // K, fac, graze, stats)
        else:
            status = self.module.flow(y, m, P, k0, k1, self.steps_per_period, h, p, Minv, C, Kmat, cst, dC, dK,
                                      dcst, rate, self.max_events, False, k1 - k0, np.zeros((1, n2, n2)), graze,
                                      stats)
        if status != 0:
            kf = int(stats[2])
            text = ", ".join(f"{a}={v:.6g}" for a, v in zip(self.model.param_names, p))
            raise SimulationError(f"variational flow of '{self.model.name}' blew up: non-finite state or "
                                  f"derivative at step {kf} ({kf / self.steps_per_period:.2f} periods) with {text}")
        jac = sens = None
        if lam:
            # each factor's last column is the sensitivity gathered over its steps: carried through the later ones
            sens = np.zeros(n2)
            for f in fac:
                sens = f[:, :n2] @ sens + f[:, n2]
            fac = np.ascontiguousarray(fac[:, :, :n2])
        if want:
            jac = fac[0].copy()
            for f in fac[1:]:
                jac = f @ jac
        return VariationalRun(state=y, factors=fac, jacobian=jac, switches=int(stats[0]), mode=m[:ns].copy(),
                              graze=graze[:ns].copy(), unresolved=int(stats[1]), undefined_saltations=int(stats[5]),
                              sensitivity=sens)
