"""Free conservative periodic solutions (backbone curves) as a continuation problem.

The continuation engine knows nothing about vibrations; this module turns a
model's harmonic-balance residual into a problem whose branch is a backbone
curve: the family of free, undamped periodic solutions of a mode, about the
static equilibrium, with the frequency unknown and the amplitude as the
continuation parameter.

Equations
---------
The model under its static load alone (:func:`contin.modal.equilibrium.static_model`:
the excitation replaced by its period mean, so the solutions oscillate about
the loaded static equilibrium) gives the harmonic-balance residual ``R(u, w)``
of period ``2 pi / w`` (:class:`contin.hb.problem.HarmonicBalance`, ``nu = 1``).
For a conservative system this residual is degenerate twice over:

- it is invariant under a time shift, so a phase condition is needed; here
  ``r . b_1 = 0`` with ``b_1`` the sine coefficients of harmonic 1 and
  ``r = M phi`` (``phi`` the linear mode followed);
- energy is conserved, ``<x', R> = 0`` for every periodic ``x``, so one
  equation of ``R = 0`` is implied by the others and the frequency is not
  fixed by them at a given amplitude. The standard cure (Munoz-Almaraz,
  Freire, Galan, Doedel & Vanderbauwhede, Physica D 181 (2003) 1-38) adds an
  unfolding term ``eps M x'`` with ``eps`` an extra unknown; on a periodic
  solution ``eps`` is zero (energy balance), and it makes the system regular.

The unknowns are ``v = (u, w, eps)`` (size ``n(2H+1) + 2``); the equations are

    R(u, w) + eps w (I (x) M) D u = 0,    r . b_1(u) = 0,    a(u) = A(lambda),

with ``D`` the ``d/dtheta`` operator, ``a`` the amplitude of the observed
quantity ``y = c . x`` (``peak``: ``(max y - min y)/2``; ``rms``: the RMS of the
oscillating part, the paper's ``w_rms`` of eq. 21) and ``A = exp(lambda)``
(log spacing) or ``A = lambda``. All Jacobians are analytic.

The branch starts at a small amplitude from the linear mode about the static
equilibrium (:func:`contin.modal.static_path.linear_modes`), so its first
frequency is the linear natural frequency.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from contin.engine.continuation import ContinuationOptions, continuation
from contin.engine.events import FunctionEvent
from contin.engine.newton import newton, solve_at_parameter
from contin.hb import aft
from contin.hb.harmonics import coefficient_blocks
from contin.hb.measures import extremum_angle
from contin.hb.factory import harmonic_balance
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.modal.equilibrium import ModalError, static_model
from contin.modal.static_path import linear_modes
from contin.model.base import Model

__all__ = ["observation_vector", "BackboneProblem", "BackboneError", "trace_backbone", "frequency_extremum_event",
           "subharmonic_guess"]


class BackboneError(ModalError):
    """A backbone problem that cannot be set up or traced; the message says why."""


def observation_vector(model: Model, name: str | None) -> tuple[str, np.ndarray]:
    """``(name, c)`` with ``y = c . x`` the named dof or linear observable.

    ``None`` takes the model's first linear observable, else its first dof.

    Raises
    ------
    BackboneError
        Naming the dofs and observables when ``name`` is neither.
    """
    obs = dict(getattr(model, "linear_observables", {}) or {})
    if name is None:
        name = next(iter(obs)) if obs else model.dof_names[0]
    if name in obs:
        return name, np.asarray(obs[name], dtype=float)
    if name in model.dof_names:
        c = np.zeros(model.n_dof)
        c[model.dof_names.index(name)] = 1.0
        return name, c
    raise BackboneError(f"'{name}' is neither a dof {list(model.dof_names)} nor a linear observable {list(obs)} "
                        f"of model '{model.name}'")


def _basis(theta: float, H: int) -> np.ndarray:
    """Row ``[1, cos t, sin t, ..., cos Ht, sin Ht]`` (the ordering of :mod:`contin.hb.harmonics`)."""
    out = np.empty(2 * H + 1)
    out[0] = 1.0
    k = np.arange(1, H + 1)
    out[1::2] = np.cos(k * theta)
    out[2::2] = np.sin(k * theta)
    return out


def _extremum(Y: np.ndarray, maximum: bool, samples: int) -> tuple[float, float]:
    """Extremum ``(value, theta)`` of the series with coefficients ``Y`` (2H+1,), polished by Newton."""
    H = (Y.shape[0] - 1) // 2
    y, _ = aft.synthesize(np.ascontiguousarray(Y.reshape(-1, 1)), samples)
    j = int(np.argmax(y[:, 0]) if maximum else np.argmin(y[:, 0]))
    th = extremum_angle(Y[1::2], Y[2::2], np.arange(1, H + 1), 2 * np.pi * j / samples)
    return float(_basis(th, H) @ Y), th


class BackboneProblem:
    """The backbone of one mode as ``R(v, lambda) = 0`` for the continuation engine.

    Parameters
    ----------
    model : Model
        A conservative model (no damping matrix); its excitation enters as
        the static load alone (:func:`contin.modal.equilibrium.static_model`).
    mode : int
        Linear mode about the static equilibrium, 1 = lowest frequency.
    observe : str, optional
        The dof or linear observable whose amplitude is the parameter
        (default: the first linear observable, else the first dof).
    harmonics : int
        ``H`` (>= 1).
    samples : int, optional
        AFT samples (default: exact for the model's polynomial degree).
    amplitude : {'peak', 'rms'}
        ``peak``: ``(max y - min y)/2`` over a period; ``rms``: RMS of the
        oscillating part of ``y``.
    log : bool
        ``lambda = ln A`` (log spacing of the points) or ``lambda = A``.
    params : dict, optional
        Parameter overrides.

    Raises
    ------
    BackboneError
        A bad argument, a damping matrix, a mode without a positive frequency
        or an observed point that does not move in it.
    ModalError
        From the static problem (:mod:`contin.modal.equilibrium`): a force
        that varies in time, no static equilibrium, or a model that is not
        conservative.

    Attributes
    ----------
    hb : HarmonicBalance
        The free (autonomous) problem with its frequency ``w`` as its parameter.
    m : int
        Number of HB coefficients; the unknown ``v`` has ``m + 2`` entries.
    x0 : ndarray, shape (n,)
        Static equilibrium.
    omega0 : float
        Linear natural frequency of the mode.
    phi : ndarray, shape (n,)
        Its mass-normalised shape.
    """

    def __init__(self, model: Model, mode: int = 1, observe: str | None = None, harmonics: int = 5,
                 samples: int | None = None, amplitude: str = "peak", log: bool = True, params=None):
        if amplitude not in ("peak", "rms"):
            raise BackboneError(f"amplitude must be 'peak' or 'rms', got {amplitude!r}")
        if isinstance(harmonics, bool) or not isinstance(harmonics, (int, np.integer)) or harmonics < 1:
            raise BackboneError(f"harmonics must be an integer >= 1 for a backbone, got {harmonics!r}")
        auto = static_model(model)
        p = auto.parameter_vector(params)
        _, C, _ = auto.linear(p)
        if np.any(C != 0.0):
            raise BackboneError(f"model '{model.name}' has a damping matrix: a backbone is traced on the "
                                f"conservative system (disable the damping effects)")
        self.model = auto
        self.params = params
        self.hb = harmonic_balance(auto, options=HBOptions(harmonics=int(harmonics), samples=samples), params=params)
        omega, phi, x0 = linear_modes(auto, params)
        if not 1 <= mode <= len(omega):
            raise BackboneError(f"mode must be from 1 to {len(omega)} (the number of dofs), got {mode}")
        if omega[mode - 1] <= 0:
            raise BackboneError(f"mode {mode} has no positive natural frequency about the static equilibrium "
                                f"(omega^2 = {-omega[mode - 1] ** 2:.4g}): the equilibrium is unstable")
        self.mode = int(mode)
        self.omega_all = omega
        self.omega0 = float(omega[mode - 1])
        self.phi = phi[:, mode - 1].copy()
        self.x0 = x0
        self.observe, self.c = observation_vector(auto, observe)
        if abs(self.c @ self.phi) < 1e-10 * np.abs(self.phi).max() * max(np.abs(self.c).max(), 1e-300):
            raise BackboneError(f"'{self.observe}' does not move in mode {mode} (a node of the mode shape): "
                                f"observe another dof or point")
        self.amplitude = amplitude
        self.log = bool(log)
        n, H = self.hb.n, self.hb.H
        self.n, self.H = n, H
        self.m = self.hb.size
        M, _, _ = auto.linear(p)
        self.M = M
        self.r = M @ self.phi
        self._MD = np.kron(np.eye(2 * H + 1), M) @ self.hb.derivative_operator()
        self._phase_rows = slice(2 * n, 3 * n)  # sine coefficients of harmonic 1
        self._fine = max(256, 8 * H + 1)

    # -- pieces ------------------------------------------------------------
    def split(self, v: np.ndarray):
        """``(u, w, eps)`` of the unknown vector ``v``."""
        return v[: self.m], float(v[self.m]), float(v[self.m + 1])

    def amplitude_target(self, lam: float) -> tuple[float, float]:
        """``A(lambda)`` and ``dA/dlambda``."""
        if self.log:
            A = math.exp(lam)
            return A, A
        return float(lam), 1.0

    def parameter_of(self, A: float) -> float:
        """``lambda`` for the amplitude ``A``."""
        if self.log:
            if A <= 0:
                raise BackboneError(f"amplitudes on a log scale must be positive, got {A}")
            return math.log(A)
        return float(A)

    def observed(self, u: np.ndarray) -> np.ndarray:
        """Coefficients of ``y = c . x``, shape (2H+1,)."""
        return coefficient_blocks(u, self.n) @ self.c

    def amplitude_of(self, u: np.ndarray) -> tuple[float, np.ndarray]:
        """The amplitude ``a(u)`` and its gradient (shape (m,))."""
        Y = self.observed(u)
        H = self.H
        if self.amplitude == "rms":
            a = math.sqrt(0.5 * float(Y[1:] @ Y[1:]))
            gY = np.zeros_like(Y)
            if a > 0:
                gY[1:] = 0.5 * Y[1:] / a
        else:
            hi, th_hi = _extremum(Y, True, self._fine)
            lo, th_lo = _extremum(Y, False, self._fine)
            a = 0.5 * (hi - lo)
            gY = 0.5 * (_basis(th_hi, H) - _basis(th_lo, H))
        return a, np.outer(gY, self.c).reshape(-1)

    # -- the problem protocol ---------------------------------------------
    def linearize(self, v: np.ndarray, lam: float):
        """Residual (m+2,), ``dR/dv`` (m+2, m+2) and ``dR/dlambda`` (m+2,)."""
        m = self.m
        u, w, eps = self.split(v)
        R, Ju, Jw = self.hb.linearize(u, w)
        Du = self._MD @ u
        F = np.empty(m + 2)
        J = np.zeros((m + 2, m + 2))
        F[:m] = R + eps * w * Du
        J[:m, :m] = Ju + (eps * w) * self._MD
        J[:m, m] = Jw + eps * Du
        J[:m, m + 1] = w * Du
        F[m] = self.r @ u[self._phase_rows]
        J[m, self._phase_rows] = self.r
        a, ga = self.amplitude_of(u)
        A, dA = self.amplitude_target(lam)
        F[m + 1] = a - A
        J[m + 1, :m] = ga
        Jlam = np.zeros(m + 2)
        Jlam[m + 1] = -dA
        return F, J, Jlam

    def residual(self, v: np.ndarray, lam: float) -> np.ndarray:
        return self.linearize(v, lam)[0]

    def unknown_scale(self):
        return None

    def at_frequency(self, v: np.ndarray, lam: float, w: float, tol: float = 1e-10, max_iter: int = 30):
        """The point of the backbone at frequency ``w``, by Newton from ``(v, lam)`` with the amplitude free.

        Returns
        -------
        v : ndarray, shape (m+2,)
        lam : float

        Raises
        ------
        BackboneError
            If Newton does not converge.
        """
        m = self.m
        z0 = np.array(v, dtype=float)
        z0[m] = lam  # the frequency slot carries lambda; w is fixed

        def fj(z):
            vv = z.copy()
            vv[m] = w
            F, J, Jlam = self.linearize(vv, float(z[m]))
            J = J.copy()
            J[:, m] = Jlam
            return F, J

        res = newton(fj, z0, tol, max_iter)
        if not res.converged:
            raise BackboneError(f"no point of the backbone of mode {self.mode} at frequency {w:.6g}: {res.message}")
        out = res.x.copy()
        lam_out = float(out[m])
        out[m] = w
        return out, lam_out

    # -- start ----------------------------------------------------------------
    def linear_guess(self, A: float) -> np.ndarray:
        """``x0 + a phi cos(theta)`` with ``a`` such that the amplitude is ``A``, at the linear frequency."""
        U = np.zeros((2 * self.H + 1, self.n))
        U[0] = self.x0
        U[1] = self.phi
        a1, _ = self.amplitude_of(U.reshape(-1))
        sign = 1.0 if self.c @ self.phi >= 0 else -1.0
        U[1] = sign * (A / a1) * self.phi
        return np.concatenate([U.reshape(-1), [self.omega0, 0.0]])

    def start(self, A: float, options: ContinuationOptions | None = None) -> np.ndarray:
        """A converged point at amplitude ``A``.

        Newton from :meth:`linear_guess` at ``A``; if that fails (``A`` too
        large for the linear shape), the branch is traced from ``A/1000`` to
        ``A`` first.

        Raises
        ------
        BackboneError
        """
        opts = options or ContinuationOptions()
        lam = self.parameter_of(A)

        def fj(v):
            F, J, _ = self.linearize(v, lam)
            return F, J

        # the residual is of the order of the amplitude: an absolute tolerance would leave a tiny start loose
        tol = opts.newton_tol * min(1.0, A / max(1.0, float(np.abs(self.c @ self.x0))))
        res = newton(fj, self.linear_guess(A), tol, max(opts.newton_max_iter, 20))
        if res.converged:
            return res.x
        A_small = A * 1e-3
        lo = self.parameter_of(A_small)
        v0 = self.linear_guess(A_small)
        res0 = newton(lambda v: self.linearize(v, lo)[:2], v0, opts.newton_tol, max(opts.newton_max_iter, 20))
        if not res0.converged:
            raise BackboneError(f"no free periodic solution of mode {self.mode} near the linear mode at amplitude "
                                f"{A_small:.3g}: {res0.message}")
        br = continuation(self, res0.x, lo, tuple(sorted((lo, lam))), opts.replace(direction=1 if lam > lo else -1),
                          parameter_name="amplitude")
        if not len(br) or br.parameter[-1] != lam:
            raise BackboneError(f"the backbone of mode {self.mode} from amplitude {A_small:.3g} did not reach "
                                f"{A:.3g}: {br.message}")
        return br.unknowns[-1]


def frequency_extremum_event(problem: BackboneProblem) -> FunctionEvent:
    """Event at the turning points of the frequency along the backbone (e.g. softening to hardening)."""
    m = problem.m

    def describe(p):
        return {"frequency": float(p.u[m])}

    return FunctionEvent(lambda p: float(p.tangent[m]), name="frequency extremum", describe=describe)


def trace_backbone(model: Model, mode: int = 1, amplitude_range=(1e-3, 1.0), *, observe: str | None = None,
                   harmonics: int = 5, samples: int | None = None, amplitude: str = "peak", log: bool = True,
                   params=None, options: ContinuationOptions | dict | None = None, callback=None):
    """Trace the backbone of ``mode`` over an amplitude range.

    Returns
    -------
    branch : Branch
        Unknowns ``(u, w, eps)`` per point; parameter ``ln A`` or ``A``.
    problem : BackboneProblem
    """
    prob = BackboneProblem(model, mode, observe, harmonics, samples, amplitude, log, params)
    if isinstance(options, dict):
        options = ContinuationOptions.from_dict(options)
    opts = options or ContinuationOptions(ds=0.01, ds_max=0.05)
    A0, A1 = (float(a) for a in amplitude_range)
    lam0, lam1 = prob.parameter_of(A0), prob.parameter_of(A1)
    v0 = prob.start(A0, opts)
    opts = opts.replace(direction=1 if lam1 > lam0 else -1)
    br = continuation(prob, v0, lam0, tuple(sorted((lam0, lam1))), opts, parameter_name="amplitude",
                      events=[frequency_extremum_event(prob)], callback=callback, solve_start=False)
    return br, prob


def subharmonic_guess(hb: HarmonicBalance, lam0: float, mode: int = 1, *, phases: int = 8,
                      harmonics: int | None = None) -> np.ndarray:
    """A converged solution of order ``nu = hb.nu`` from the free vibration of ``mode`` at ``w/nu``.

    The backbone of ``mode`` is traced (in the peak amplitude of the first
    linear observable or dof) until its frequency reaches ``Omega = w/nu``;
    that free periodic solution, whose base frequency is the solution's base
    frequency ``w/nu``, plus the forced linear response about the static
    equilibrium is the Newton guess, tried at ``phases`` time shifts over
    ``2 pi / nu`` of the forcing (the subharmonic locks to the forcing at
    discrete phases). The first guess that converges to a solution with a
    non-zero subharmonic part is returned.

    Parameters
    ----------
    hb : HarmonicBalance
        Problem of order ``nu >= 2``; its parameter must be the frequency.
    lam0 : float
        The frequency ``w`` of the start.
    mode : int
    phases : int
    harmonics : int, optional
        Harmonics of the backbone (default ``hb.H``).

    Raises
    ------
    BackboneError
        If the backbone does not reach ``w/nu`` or no guess converges to a
        subharmonic solution.
    """
    if not hb.frequency_moves:
        raise BackboneError("a subharmonic guess needs the frequency as the continuation parameter")
    nu, n = hb.nu, hb.n
    Omega = hb.base_frequency(hb.params_at(lam0))
    params = hb.parameters()
    # undamped, with the problem's frequency as the backbone's
    free = dataclasses.replace(hb.model, damping=dataclasses.replace(hb.model.damping, terms=()),
                               frequency=hb.frequency)
    prob = BackboneProblem(free, mode, None, harmonics or hb.H, None, "peak", True, params)
    opts = ContinuationOptions(ds=0.002, ds_max=0.01)
    A0 = 1e-4 * max(1.0, float(np.abs(prob.c @ prob.x0)))
    lam_a = prob.parameter_of(A0)
    v0 = prob.start(A0, opts)
    target = {}

    gap = abs(prob.omega0 - Omega)

    def stop_at_frequency(branch, i):
        w = branch.unknowns[i][prob.m]
        if (w - Omega) * (prob.omega0 - Omega) <= 0:
            target["v"] = branch.unknowns[i].copy()
            target["lam"] = float(branch.parameter[i])
            return False
        # the frequency runs away from w/nu (e.g. a hardening mode above it): it will not come back
        return bool(abs(w - Omega) <= 2.0 * gap + 0.5 * prob.omega0)

    br = continuation(prob, v0, lam_a, (lam_a, lam_a + 25.0), opts, parameter_name="amplitude",
                      callback=stop_at_frequency, solve_start=False)
    if "v" not in target:
        last = br.unknowns[-1][prob.m] if len(br) else prob.omega0
        why = "" if br.status.value == "interrupted" else f" ({br.message})"
        raise BackboneError(f"the backbone of mode {mode} (linear frequency {prob.omega0:.6g}) does not reach "
                            f"w/nu = {Omega:.6g}: its frequency runs away to {last:.6g}{why}")
    v, _ = prob.at_frequency(target["v"], target["lam"], Omega)
    u_free = v[: prob.m]
    # forced linear response about the equilibrium, on the harmonics nu*k of the base frequency
    U0 = np.zeros((2 * hb.H + 1, n))
    U0[0] = prob.x0
    u_eq = U0.reshape(-1)
    R, J, _ = hb.linearize(u_eq, lam0)
    try:
        u_forced = u_eq + np.linalg.solve(J, -R)
    except np.linalg.LinAlgError:
        u_forced = u_eq
    Uf = coefficient_blocks(u_free, n)
    Hb = (Uf.shape[0] - 1) // 2
    best = None
    for j in range(phases):
        # the forcing repeats after a base-phase shift of 2 pi / nu: shifts in [0, 2 pi / nu) cover every phase
        shift = 2 * np.pi * j / (phases * nu)
        V = np.zeros((2 * hb.H + 1, n))
        for k in range(1, min(Hb, hb.H) + 1):
            a, b = Uf[2 * k - 1], Uf[2 * k]
            c, s = math.cos(k * shift), math.sin(k * shift)
            V[2 * k - 1] = a * c - b * s
            V[2 * k] = a * s + b * c
        guess = u_forced + V.reshape(-1)
        res = solve_at_parameter(hb, guess, lam0, ContinuationOptions(newton_max_iter=40))
        if not res.converged:
            continue
        U = coefficient_blocks(res.x, n)
        sub = sum(float(np.abs(U[2 * k - 1: 2 * k + 1]).max()) for k in range(1, hb.H + 1) if k % nu)
        if sub > 1e-6 * max(1.0, float(np.abs(U).max())):
            return res.x
        best = res
    raise BackboneError(f"no subharmonic solution of order {nu} near the free vibration of mode {mode} at "
                        f"w = {lam0:.6g}" + ("" if best is None else " (Newton fell back onto the harmonic solution)"))
