"""Multiple shooting on the integrated flow: periodic orbits as a discretisation for the continuation engine.

The period ``T = nu 2 pi / w`` is cut into ``M`` segments at the RK4 step
indices ``k0 + k L``, ``L = S nu / M`` (``S`` steps per forcing period, ``k0``
the option ``start_step``, 0 by default), so segment ``k`` runs from
``t_k = t0 + k T / M`` to ``t_{k+1}``, ``t0 = k0 T / (S nu)``. The unknowns are the
states at the segment starts, ``u = (z_0, ..., z_{M-1})`` (``z = (x, x')``,
size ``2 n M``), and the residual is

    r_k = phi_{t_k -> t_{k+1}}(z_k) - z_{k+1 mod M},     k = 0 .. M-1,

with ``phi`` the flow map of the compiled integrator
(:mod:`contin.timedomain.integrator`: RK4, contact switches located in time).
A forced orbit needs no phase condition. ``M = 1`` is single shooting; more
segments keep each flow map well conditioned on a strongly unstable orbit.

Jacobians
---------
``dR/du`` is the cyclic block-bidiagonal matrix with the segment Jacobians
``Phi_k = d phi_k / d z_k`` on the diagonal and ``-I`` on the block
super-diagonal (wrapping round to the first block column). It is stored
dense, which suits ``2 n M`` up to about 200 (the engine factorises it
densely). ``Phi_k`` comes from the variational equations integrated with the
state (``jacobian="variational"``: the exact derivative of the discrete map,
the saltation matrix at every located switch; one integration per segment)
or by central differences of the flow map (``jacobian="differences"``, the
reference: ``4 n + 1`` integrations per segment).

``dR/dlam`` is integrated with the variational equations as one more
column, the sensitivity ``dz/dlam`` at fixed phases (the step ``h = T / S``
moves with ``w``; :mod:`contin.timedomain.variational`), when ``lam`` enters
only the damping and stiffness matrices, the excitations (linear in their
constants) and the forcing frequency: the common case, ``lam = w`` or an
amplitude. Where it enters the mass matrix or a force law (a clearance, a
contact stiffness) it is a central difference of the plain flow maps in
``lam`` (two more integrations of the period), accurate to its truncation
``O(step^2)`` and rounding ``O(eps / step)``, about 1e-10 relative at the
default step ``fd_step max(1, |lam|)``.

Multipliers
-----------
The monodromy at ``z_0`` is the product ``Phi_{M-1} ... Phi_0`` of the
segment Jacobians, each itself a product of factors over equal shares of
its steps. Its eigenvalues come from the factors by a periodic Schur
decomposition, never from the multiplied-out product, so that the small
multipliers of a strongly unstable orbit keep their relative accuracy. The
factors of the last linearisations are cached by ``(u, lam)``: the stability
monitor at a point the engine has just linearised costs no integration
(:mod:`contin.timedomain.shooting_bifurcations`: the stability monitor and the
start of the doubled branch at a period doubling).

Threads
-------
The segments' flows are independent: they run side by side
(:func:`contin.util.workers.map_ordered`, the kernels leave the GIL), and so
do the flows of many orbits at one ``lam`` (:meth:`ShootingProblem.flows_many`,
:meth:`~ShootingProblem.linearize_many`, :meth:`~ShootingProblem.flow_jacobians`:
the points of an invariant circle). Each writes only its own arrays, so the
numbers are the same bit for bit whatever the number of threads.
"""

from __future__ import annotations

import copy
import dataclasses
import math
from collections import OrderedDict
from typing import Mapping

import numpy as np
from scipy.interpolate import CubicSpline

from contin.stability.periodic_schur import product_eigenvalues
from contin.stability.saltation import orbit_state
from contin.timedomain.integrator import RK4_STABILITY, SimulationError, compile_model
from contin.timedomain.shooting_options import ShootingOptions
from contin.timedomain.shooting_events import graze_data, grid_graze, nearest_zero, start_graze
from contin.timedomain.variational import VariationalFlow, parameter_sensitivity
from contin.util.workers import map_ordered

__all__ = ["ShootingProblem", "flip_test"]

#: factors asked of the flow per period (at least), so that the small multipliers survive the product
MIN_FACTORS = 8
#: linearisations kept (by (u, lam)) for the monitors and the stability verdict
CACHE_SIZE = 8
#: a linearisation's cost in plain flows of the same segments: the variational flow (scripts/bench/
#: bench_shooting.py), with dR/dlam integrated in it or, for a parameter of the mass or a force law, two flows
#: more; the engine's Newton solves then evaluate the iterates by the plain flows alone (a lazy Jacobian,
#: contin.engine.problem.LAZY_COST)
VARIATIONAL_COST = 9.0
#: parameter values whose integration setup is kept
SETUP_CACHE = 4
#: the relative step of the differences of the damping and stiffness matrices and the compiled constants in lam
#: (parameter_sensitivity): exact for their dependence, at most quadratic, up to rounding eps / step
SENSITIVITY_STEP = 1e-4


def flip_test(mu: np.ndarray) -> float:
    """``det(Phi + I) = prod (mu_i + 1)`` from the multipliers: changes sign where a real one crosses -1."""
    return float(np.real(np.prod(np.asarray(mu) + 1.0)))


def _factor_count(steps: int, want: int) -> int:
    """The largest divisor of ``steps`` not above ``want`` (factors over equal shares of the steps)."""
    return max(d for d in range(1, max(1, want) + 1) if steps % d == 0)


@dataclasses.dataclass(eq=False)
class _Linearisation:
    residual: np.ndarray
    Ju: np.ndarray
    Jlam: np.ndarray
    factors: np.ndarray  # (K_total, 2n, 2n), in time order from the section t0
    graze: np.ndarray  # (n_switch,)
    switches: int  # located switches along the orbit


class ShootingProblem:
    """``R(u, lam)``: multiple shooting of the integrated flow for the continuation engine (module docstring).

    The unknowns are the segment starts ``u = (z_0, ..., z_{M-1})``; ``dR/du``
    is returned dense, which suits ``2 n M`` up to about 200.

    Parameters
    ----------
    model : Model
    parameter : str
        The continuation parameter (the forcing frequency or another).
    params : dict, optional
        The other parameter overrides.
    options : ShootingOptions

    Attributes
    ----------
    jacobian : str
        The Jacobian in use: ``options.jacobian``, or ``"differences"`` when
        an element of the model has no Jacobian lines in its compiled form
        (said in ``notes``).
    notes : list of str
    n : int
        Dofs of the model.
    nu : int
        Subharmonic order.
    segments : int
        ``M``.
    size : int
        Unknowns, ``2 n M``.
    """

    def __init__(self, model, parameter: str, params: Mapping[str, float] | None = None,
                 options: ShootingOptions = ShootingOptions()):
        if parameter not in model.parameters:
            raise ValueError(f"unknown parameter {parameter!r} of model '{model.name}'; "
                             f"valid: {list(model.parameters)}")
        self.model, self.parameter, self.options = model, parameter, options
        self.base = dict(params or {})
        self.n = model.n_dof
        self.nu = options.subharmonic
        self.segments = options.segments
        self.size = 2 * self.n * self.segments
        # the flow map integrates the model's excitation at its declared frequency
        self.frequency = model.frequency
        self._kw = model.parameter_index(self.frequency)
        self._cm = compile_model(model)
        self.n_switch = self._cm.n_switch
        self._steps = options.steps_per_period * options.subharmonic  # steps per orbit period
        self._seg_steps = self._steps // self.segments
        self._k0 = int(options.start_step)  # the section: the first segment starts at this step of the grid
        # with one segment the flow still hands its Jacobian in factors, so the small multipliers survive
        self._factors = _factor_count(self._seg_steps, -(-MIN_FACTORS // self.segments))
        self._flow = None
        self._cache: OrderedDict = OrderedDict()
        self._passes: OrderedDict = OrderedDict()  # (graze, switches) of orbits not linearised
        self._setups: OrderedDict = OrderedDict()
        #: the Jacobian in use, and why it is not the one asked for
        self.jacobian, self.notes = options.jacobian, []
        if self.jacobian == "variational":
            try:
                self._cm.jacobian_source()  # an element kind without Jacobian lines is named here
            except SimulationError as exc:
                self.jacobian = "differences"
                self.notes.append(f"central differences of the flow map instead of the variational equations: {exc}")

    # ------------------------------------------------------------ the protocol's members
    @property
    def jacobian_cost(self) -> float:
        """A linearisation's cost in residuals (:data:`VARIATIONAL_COST`; by differences ``4 n + 2`` flows)."""
        return VARIATIONAL_COST if self.jacobian == "variational" else 4.0 * self.n + 2.0

    @property
    def full(self) -> "ShootingProblem":
        """The problem itself: shooting holds every dof."""
        return self

    condensed = False

    def with_params(self, params: Mapping[str, float]) -> "ShootingProblem":
        """The same problem with other values of the fixed parameters (``params`` updates the overrides):
        the compiled model and the variational flow are shared, the caches of orbits and setups are not."""
        if self.parameter in params:
            raise ValueError(f"{self.parameter!r} is the problem's own parameter, not a fixed one")
        self._variational()  # created once, shared by the copies
        out = copy.copy(self)
        out.base = {**self.base, **{k: float(v) for k, v in params.items()}}
        out._cache, out._passes, out._setups = OrderedDict(), OrderedDict(), OrderedDict()
        return out

    @property
    def dof_names(self) -> tuple:
        return tuple(self.model.dof_names)

    def frequency_at(self, lam: float) -> float:
        """The forcing frequency at ``lam`` (the parameter itself, or fixed by the overrides)."""
        params = {**self.base, self.parameter: float(lam)}
        return float(self.model.parameter_vector(params)[self._kw])

    def period_at(self, lam: float) -> float:
        """The orbit's period, ``subharmonic`` forcing periods ``2 pi / w``, at ``lam``."""
        return self.nu * 2.0 * math.pi / self.frequency_at(lam)

    def params_at(self, lam: float) -> dict:
        """Parameter overrides at ``lam``; a Newton iterate with no positive forcing period fails the evaluation."""
        w = self.frequency_at(lam)
        if not w > 0.0:
            raise ArithmeticError(f"the iterate has {self.frequency} = {w:g}: no positive forcing period")
        return {**self.base, self.parameter: float(lam)}

    # ------------------------------------------------------------ integration
    def _setup(self, lam: float, checked: bool = True):
        """``(p, h, arguments)`` at ``lam``; with ``checked``, a step beyond RK4's stability raises
        ArithmeticError.

        The last few are kept: a lazy Newton solve evaluates many iterates at one ``lam``. The residual
        alone skips the check (an eigenvalue problem, a fifth of a plain flow's cost): every converged
        point is linearised, checked there, and a step beyond stability blows the flow up before.
        """
        lam = float(lam)
        hit = self._setups.get(lam)
        if hit is None:
            hit = self._setups[lam] = [self._make_setup(lam), False]
            if len(self._setups) > SETUP_CACHE:
                self._setups.popitem(last=False)
        setup = hit[0]
        if checked and not hit[1]:
            p, h = setup[0], setup[1]
            if self._cm.fastest_rate(p) * h > RK4_STABILITY:
                raise ArithmeticError(f"the step T/{self.options.steps_per_period} at {self.parameter} = "
                                      f"{lam:.10g} is beyond RK4's stability for the stiffest mode of "
                                      f"'{self.model.name}': raise steps_per_period")
            hit[1] = True
        return setup

    def _make_setup(self, lam: float):
        params = self.params_at(lam)
        p = self.model.parameter_vector(params)
        w = float(p[self._kw])
        h = 2.0 * math.pi / w / self.options.steps_per_period
        try:
            args = self._cm.arguments(p)
        except SimulationError as exc:
            raise ArithmeticError(str(exc)) from None
        return p, h, args

    def _mode(self, y, p, cst):
        X, V = np.zeros((1, self.n)), np.zeros((1, self.n))
        s = np.zeros(max(self.n_switch, 1))
        if self.n_switch:
            self._cm.module.switch(y, p, cst, X, V, s)
        return (s > 0.0).astype(np.int64)

    def _run(self, z, setup, k, record=False, steps=None, first=None):
        """The plain flow over segment ``k`` from ``z`` (or its first ``steps`` steps; from the grid's step ``first``
        if given): the end state, the states at every step if ``record`` and the number of located switches."""
        p, h, (Minv, C, K, cst) = setup
        y = np.array(z, dtype=float)
        mode = self._mode(y, p, cst)
        k0 = self._k0 + k * self._seg_steps if first is None else first
        k1 = k0 + (self._seg_steps if steps is None else steps)
        S = self.options.steps_per_period
        out = np.zeros((k1 - k0 if record else 0, y.size))
        sec = np.zeros((k1 // S + 1, y.size))
        stats = np.zeros(5, dtype=np.int64)
        status = self._cm.module.integrate(y, mode, k0, k1, S, h, p, Minv, C, K, cst, True, 8,
                                           k0 + 1 if record else k1 + 1, 1, out, sec, stats)
        if status != 0 or not np.all(np.isfinite(y)):
            raise ArithmeticError(f"the flow of '{self.model.name}' blew up on segment {k} at "
                                  f"{self.parameter} = {float(p[self.model.parameter_index(self.parameter)]):.10g}")
        return y, out, int(stats[0])

    def _switching(self, states, p, cst) -> np.ndarray:
        """Switching-function values at the states (K, 2n): shape (K, n_switch)."""
        X, V = np.zeros((1, self.n)), np.zeros((1, self.n))
        s = np.zeros(max(self.n_switch, 1))
        out = np.empty((len(states), self.n_switch))
        for i, y in enumerate(states):
            self._cm.module.switch(np.ascontiguousarray(y), p, cst, X, V, s)
            out[i] = s[: self.n_switch]
        return out

    def switching_values(self, states: np.ndarray, lam: float) -> np.ndarray:
        """The switching functions at the states ``states`` (K, 2n) at ``lam``: shape (K, n_switch)."""
        p, _, (_, _, _, cst) = self._setup(lam)
        return self._switching(np.asarray(states, dtype=float), p, cst)

    def _variational(self):
        if self.jacobian == "variational" and self._flow is None:
            self._flow = VariationalFlow(self.model, steps_per_period=self.options.steps_per_period)
        return self._flow if self.jacobian == "variational" else None

    def kernels(self) -> list:
        """``(module, function name)`` of the generated kernels its flows call (contin.app.compile_ahead)."""
        flow = self._variational()
        return [(self._cm.module, "integrate")] + ([(flow.module, "flow")] if flow is not None else [])

    def _segment(self, z, setup, k, sensitivity=None):
        """Segment ``k`` from ``z``: end state, its factors (K, 2n, 2n), the graze per switching function, the
        number of located switches and, with ``sensitivity`` (:func:`parameter_sensitivity`), ``d end /
        d lam`` (else None)."""
        flow = self._variational()
        if flow is None:
            return (*self._segment_differences(z, setup, k), None)
        try:
            k0 = self._k0 + k * self._seg_steps
            run = flow.run(z, setup[0], k0, k0 + self._seg_steps, jacobian=True,
                           factors=self._factors, sensitivity=sensitivity)
        except SimulationError as exc:
            raise ArithmeticError(str(exc)) from None
        return (run.state, np.asarray(run.factors), np.asarray(run.graze, dtype=float).reshape(-1), run.switches,
                run.sensitivity)

    def _segment_differences(self, z, setup, k):
        """:meth:`_segment` by central differences of the flow map (the reference): one factor per segment."""
        end, states, switches = self._run(z, setup, k, record=self.n_switch > 0)
        m = z.size
        step = self.options.fd_step * max(1.0, float(np.max(np.abs(z))))
        Phi = np.empty((m, m))
        for j in range(m):
            e = np.zeros(m)
            e[j] = step
            Phi[:, j] = (self._run(z + e, setup, k)[0] - self._run(z - e, setup, k)[0]) / (2.0 * step)
        graze = np.full(self.n_switch, math.inf)
        if self.n_switch:
            s = self._switching(np.vstack([z[None], states]), setup[0], setup[2][3])
            graze = nearest_zero([grid_graze(s, periodic=False), start_graze(s[:3])])
        return end, Phi[None], graze, switches

    def _blocks(self, u):
        u = np.asarray(u, dtype=float)
        if u.shape != (self.size,):
            raise ValueError(f"the unknowns must have shape ({self.size},) = {self.segments} segment start(s) of "
                             f"(x, x') of model '{self.model.name}', got {u.shape}")
        return u.reshape(self.segments, 2 * self.n)

    def _loaded(self):
        """Load the generated modules here, not inside the threads that run their kernels."""
        self._cm.module
        if self._variational() is not None:
            self._flow.module

    def flows(self, u: np.ndarray, lam: float, checked: bool = True) -> np.ndarray:
        """The segment end states ``phi_k(z_k)``, shape (M, 2n) (``checked``: see :meth:`_setup`)."""
        return self.flows_many(np.asarray(u, dtype=float)[None], lam, checked)[0]

    def flows_many(self, U: np.ndarray, lam: float, checked: bool = True) -> np.ndarray:
        """:meth:`flows` at each row of ``U`` (K, 2nM), shape (K, M, 2n); the segments run in threads
        (:func:`contin.util.workers.map_ordered`)."""
        Z = np.stack([self._blocks(u) for u in U]) if len(U) else np.empty((0, self.segments, 2 * self.n))
        setup = self._setup(lam, checked)
        self._loaded()
        M = self.segments
        ends = map_ordered(lambda i: self._run(Z[i // M, i % M], setup, i % M)[0], len(Z) * M)
        return np.array(ends).reshape(Z.shape)

    def residual(self, u: np.ndarray, lam: float) -> np.ndarray:
        """``r_k = phi_k(z_k) - z_{k+1 mod M}``, shape (2 n M,)."""
        Z = self._blocks(u)
        return (self.flows(u, lam, checked=False) - np.roll(Z, -1, axis=0)).reshape(-1)

    def _sensitivity(self, lam: float):
        """The derivatives in ``lam`` the variational flow integrates ``dR/dlam`` from, or None where it
        cannot (then central differences of the plain flows; module docstring)."""
        if self._variational() is None:
            return None
        try:  # the matrices and constants at most quadratic in lam: a wider step, exact but for rounding
            dp = SENSITIVITY_STEP * max(1.0, abs(float(lam)))
            p_lo, p_hi = (self.model.parameter_vector(self.params_at(lam + s)) for s in (-dp, dp))
            return parameter_sensitivity(self._cm, p_lo, p_hi, dp, self._kw)
        except (ArithmeticError, SimulationError):
            return None

    def linearize(self, u: np.ndarray, lam: float):
        """Residual (2nM,), ``dR/du`` (2nM, 2nM, dense) and ``dR/dlam`` (2nM,) (module docstring)."""
        key = (np.asarray(u, dtype=float).tobytes(), float(lam))
        hit = self._cache.get(key)
        if hit is None:
            hit = self._cache[key] = self._linearisations(np.asarray(u, dtype=float)[None], lam)[0]
            if len(self._cache) > CACHE_SIZE:
                self._cache.popitem(last=False)
        else:
            self._cache.move_to_end(key)
        return hit.residual.copy(), hit.Ju.copy(), hit.Jlam.copy()

    def linearize_many(self, U: np.ndarray, lam: float) -> list[tuple]:
        """:meth:`linearize` at each row of ``U`` (K, 2nM), the segments in threads; not cached."""
        return [(lin.residual, lin.Ju, lin.Jlam) for lin in self._linearisations(np.asarray(U, dtype=float), lam)]

    def _linearisations(self, U: np.ndarray, lam: float) -> list[_Linearisation]:
        M, m = self.segments, 2 * self.n
        Z = [self._blocks(u) for u in U]
        setup = self._setup(lam)
        sens = self._sensitivity(lam)
        self._loaded()
        runs = map_ordered(lambda i: self._segment(Z[i // M][i % M], setup, i % M, sens), len(Z) * M)
        out = []
        for u, Zu, segs in zip(U, Z, (runs[i * M:(i + 1) * M] for i in range(len(Z)))):
            ends, factors, graze, switches = np.empty((M, m)), [], [], 0
            Ju = np.zeros((M * m, M * m))
            Jlam = np.empty(M * m) if sens is not None else None
            for k, (end, f, g, n_sw, dz) in enumerate(segs):
                ends[k] = end
                if Jlam is not None:
                    Jlam[k * m:(k + 1) * m] = dz
                switches += n_sw
                Phi = f[0]
                for F in f[1:]:
                    Phi = F @ Phi
                Ju[k * m:(k + 1) * m, k * m:(k + 1) * m] = Phi
                j = (k + 1) % M
                Ju[k * m:(k + 1) * m, j * m:(j + 1) * m] -= np.eye(m)
                factors.append(f)
                graze.append(g)
            if not (np.all(np.isfinite(ends)) and np.all(np.isfinite(Ju))):
                raise ArithmeticError(f"non-finite flow map at {self.parameter} = {lam:.10g}")
            if Jlam is None:
                step = self.options.fd_step * max(1.0, abs(float(lam)))
                Jlam = ((self.flows(u, lam + step) - self.flows(u, lam - step)) / (2.0 * step)).reshape(-1)
            R = (ends - np.roll(Zu, -1, axis=0)).reshape(-1)
            out.append(_Linearisation(R, Ju, Jlam, np.concatenate(factors, axis=0), nearest_zero(graze), switches))
        return out

    def flow_jacobian(self, z: np.ndarray, lam: float) -> tuple[np.ndarray, np.ndarray]:
        """The first segment's end state from ``z`` (2n,) and its Jacobian ``Phi`` (2n, 2n): the variational flow
        alone, without ``dR/dlam`` (for iterating the map; with one segment, over the whole period)."""
        ends, Phis = self.flow_jacobians(np.asarray(z, dtype=float)[None], lam)
        return ends[0], Phis[0]

    def flow_jacobians(self, Z: np.ndarray, lam: float) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`flow_jacobian` from each row of ``Z`` (K, 2n), in threads: shapes (K, 2n) and (K, 2n, 2n)."""
        Z = np.asarray(Z, dtype=float)
        setup = self._setup(lam)
        self._loaded()
        runs = map_ordered(lambda i: self._segment(Z[i], setup, 0), len(Z))
        ends, Phis = np.empty(Z.shape), np.empty((len(Z), Z.shape[1], Z.shape[1]))
        for i, (end, factors, _, _, _) in enumerate(runs):
            Phi = factors[0]
            for F in factors[1:]:
                Phi = F @ Phi
            ends[i], Phis[i] = end, Phi
        if not (np.all(np.isfinite(ends)) and np.all(np.isfinite(Phis))):
            raise ArithmeticError(f"non-finite flow map at {self.parameter} = {lam:.10g}")
        return ends, Phis

    def _linearisation(self, u, lam) -> _Linearisation:
        key = (np.asarray(u, dtype=float).tobytes(), float(lam))
        if key not in self._cache:
            self.linearize(u, lam)
        return self._cache[key]

    def factors(self, u: np.ndarray, lam: float) -> np.ndarray:
        """The factors of the monodromy at ``z_0``, in time order, shape (K, 2n, 2n) (cached by ``(u, lam)``)."""
        return self._linearisation(u, lam).factors.copy()

    def multipliers(self, u: np.ndarray, lam: float) -> np.ndarray:
        """Floquet multipliers of the orbit, by decreasing modulus: periodic Schur of the segment factors."""
        mu = np.asarray(product_eigenvalues(self._linearisation(u, lam).factors), dtype=complex)
        return mu[np.argsort(-np.abs(mu), kind="stable")]

    def _contacts(self, u, lam) -> tuple[np.ndarray, int]:
        """``(graze, switches)`` of the orbit: its linearisation's when it was linearised, else from the flow
        without the variational equations (the same steps and switches bit for bit, at a fraction of the cost)."""
        key = (np.asarray(u, dtype=float).tobytes(), float(lam))
        hit = self._cache.get(key)
        if hit is not None:
            return hit.graze, hit.switches
        hit = self._passes.get(key)
        if hit is None:
            flow = self._variational()
            if flow is None:  # the differences' reference: its graze comes with its linearisation
                lin = self._linearisation(u, lam)
                return lin.graze, lin.switches
            Z, setup = self._blocks(u), self._setup(lam)
            self._loaded()
            try:
                k0, L = self._k0, self._seg_steps
                runs = map_ordered(lambda k: flow.run(Z[k], setup[0], k0 + k * L, k0 + (k + 1) * L, jacobian=False),
                                   self.segments)
            except SimulationError as exc:
                raise ArithmeticError(str(exc)) from None
            graze = [np.asarray(run.graze, dtype=float).reshape(-1) for run in runs]
            switches = sum(run.switches for run in runs)
            hit = self._passes[key] = (nearest_zero(graze), switches)
            if len(self._passes) > CACHE_SIZE:
                self._passes.popitem(last=False)
        return hit

    def graze(self, u: np.ndarray, lam: float) -> np.ndarray:
        """Per switching function, the signed extremum nearest to zero along the orbit (+inf: none), shape (n_switch,)."""
        return self._contacts(u, lam)[0].copy()

    def switches(self, u: np.ndarray, lam: float) -> int:
        """The number of switches located along the orbit (a grazing changes it by two)."""
        return self._contacts(u, lam)[1]

    def monitor(self, u, lam, Ju=None, Jlam=None) -> dict:
        """Engine monitor: the largest multiplier, the flip test and, with contacts, the graze (no integration)."""
        mu = self.multipliers(u, lam)
        return {"max_multiplier": float(np.abs(mu).max()), "flip_test": flip_test(mu), **graze_data(self, u, lam)}

    # ------------------------------------------------------------ starts and orbits
    def start_unknowns(self, z0, lam: float) -> np.ndarray:
        """The unknowns from the state ``z0`` (2n,) at ``t = 0``: the section's state and each segment start by
        integrating the previous."""
        z = np.asarray(z0, dtype=float)
        if z.shape != (2 * self.n,):
            raise ValueError(f"z0 must have shape ({2 * self.n},) = (x, x') of model '{self.model.name}', got {z.shape}")
        if self._k0:  # from t = 0 to the section
            z = self._run(z, self._setup(lam), 0, steps=self._k0, first=0)[0]
        return self.section_unknowns(z, lam)

    def section_unknowns(self, z, lam: float) -> np.ndarray:
        """The unknowns from the state ``z`` (2n,) at the section ``t0`` (``start_step``; ``t = 0`` by default):
        each segment start by integrating the previous."""
        z = np.asarray(z, dtype=float)
        setup = self._setup(lam)
        out = [z]
        for k in range(self.segments - 1):
            out.append(self._run(out[-1], setup, k)[0])
        return np.concatenate(out)

    def from_coefficients(self, hb, c: np.ndarray, lam: float) -> np.ndarray:
        """The unknowns from a harmonic-balance point: its orbit's states at the segment starts ``k T / M``.

        ``hb`` may be a condensed problem: ``c`` is then expanded to the full coefficients first.
        """
        full = hb.full  # the periodic-problem protocol (contin.model.periodic)
        coeffs = hb.expand(c, lam) if hb.condensed else np.asarray(c, dtype=float)
        T = self.period_at(lam)
        t = (self._k0 / self._steps + np.arange(self.segments) / self.segments) * T
        return np.asarray(orbit_state(full, coeffs, lam, t), dtype=float).reshape(-1)

    def step_states(self, u: np.ndarray, lam: float) -> np.ndarray:
        """The states ``(x, x')`` of the orbit ``u`` at every RK4 step over its period, the integrator's own:
        shape (nu * steps_per_period, 2n), the first the start, the period's end left out."""
        return self._states(u, lam)[:-1]

    def _states(self, u, lam: float) -> np.ndarray:
        """The states at every step over the period from ``t = 0``, its end included: shape (nu * steps_per_period
        + 1, 2n); with a section elsewhere the period integrated from it, rotated to start at ``t = 0`` (its first
        and last rows then both the state at the period's end)."""
        Z = self._blocks(u)
        setup = self._setup(lam)
        self._loaded()
        Y = np.vstack([Z[:1]] + map_ordered(lambda k: self._run(Z[k], setup, k, record=True)[1], self.segments))
        k0 = self._k0
        if not k0:
            return Y
        n = self._steps
        return np.vstack([Y[n - k0:n], Y[:n - k0 + 1]])

    def orbit(self, u: np.ndarray, lam: float, t):
        """Displacements and velocities of the orbit ``u`` at times ``t`` in ``[0, period]``.

        The segments are integrated again, recording every step; between steps
        a cubic spline (periodic when the orbit closes).

        Returns
        -------
        x, xd : ndarray, shape (n, len(t))
        """
        T = self.period_at(lam)
        t = np.atleast_1d(np.asarray(t, dtype=float))
        if t.size and (np.min(t) < 0.0 or np.max(t) > T * (1 + 1e-12)):
            raise ValueError(f"orbit: the times must lie in [0, {T:.10g}] (one period), got "
                             f"[{np.min(t):.10g}, {np.max(t):.10g}]")
        Y = self._states(u, lam)
        grid = np.arange(Y.shape[0]) * T / self._steps
        closes = np.allclose(Y[-1], Y[0], rtol=0.0, atol=1e-8 * max(1.0, float(np.abs(Y).max())))
        if closes:
            Y = Y.copy()
            Y[-1] = Y[0]
        y = CubicSpline(grid, Y, axis=0, bc_type="periodic" if closes else "not-a-knot")(np.clip(t, 0.0, T))
        return y[:, :self.n].T.copy(), y[:, self.n:].T.copy()
