"""Quasi-periodic harmonic balance: solutions on a two-torus, ``R(u, lambda)`` for the continuation engine.

A quasi-periodic solution of ``M x'' + C x' + K x + f_nl(x, x', tau) = f_ext(tau)``
has two base frequencies, ``Omega1 = w/nu`` of the forcing (``tau = nu theta1``)
and the unknown ``w2`` of a self-excited oscillation. With the series of
:mod:`contin.hb.qp_basis` (pairs ``(k1, k2)`` of frequencies
``f_j = k1 Omega1 + k2 w2``), ``d/dt = Omega1 d/dtheta1 + w2 d/dtheta2`` and the
residual is

    R(u, w2, lambda) = A(f) u + P2 f_nl(x(theta), xdot(theta), nu theta1) - P2 f_ext(nu theta1),

``A`` block diagonal with ``[[K - f_j^2 M, f_j C], [-f_j C, K - f_j^2 M]]`` on
pair ``j`` and ``P2`` the 2-D discrete Fourier projection of
:mod:`contin.hb.aft2d` (Kim & Noah, J. Appl. Mech. 63 (1996) 375; Guskov,
Sinou & Thouverez, Nonlinear Dyn. 54 (2008) 13; Schilder, Vogt, Schreiber
& Osinga, Int. J. Numer. Meth. Eng. 67 (2006) 629 for the torus view).

The torus is invariant under a shift of ``theta2``: one **phase condition**
pins it, the sine coefficient of a chosen pair and dof vanishing,
``b_{j*, i*} = 0``. The unknown vector is ``(u, w2)`` of length
``n (2P - 1) + 1`` and the residual ``(R, b_{j*, i*})`` of the same length.

Contact laws that switch are resolved along the lines of constant
``theta2`` (``crossings='interval'``, :mod:`contin.hb.crossings2d`: the
crossing located on the series inside its sample interval, second order in
``1/N1``, a residual continuous in the coefficients) or sampled plainly
(``'none'``: first order, and the residual jumps where a sample crosses the
surface if the law jumps there). The exact arc quadrature of the periodic
problem (:mod:`contin.hb.contact_quadrature`) integrates over arcs of one
phase; on a torus the contact set is a region of the ``(theta1, theta2)``
plane and is not carried over.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from contin.hb import aft2d, crossings2d
from contin.hb.harmonics import default_samples
from contin.hb.linear import LinearTerms
from contin.hb.factory import harmonic_balance
from contin.hb.problem import HBOptions
from contin.hb.qp_basis import QPBasis
from contin.model.base import Model
from contin.model.periodic import AllDofs
from contin.model.whirl import TORUS_WHIRL

__all__ = ["TorusOptions", "QuasiPeriodicBalance", "COMPONENTS", "torus_measure_names", "torus_measures"]


@dataclass(frozen=True)
class TorusOptions:
    """Discretisation of a quasi-periodic harmonic balance.

    Parameters
    ----------
    harmonics : int
        ``H1``, harmonics of the forcing's base frequency ``w/nu`` (>= 1).
    harmonics2 : int
        ``H2``, harmonics of the second frequency ``w2`` (>= 1).
    samples : int or None
        ``N1``, grid points along ``theta1`` (>= 2 H1 + 1); None: as the
        periodic problem's default for ``H1``.
    samples2 : int or None
        ``N2``, grid points along ``theta2`` (>= 2 H2 + 1); None: as the
        periodic default for ``H2``.
    subharmonic : int
        ``nu`` of the periodic branch the torus bifurcates from.
    crossings : {'interval', 'none'}
        How switching contact laws are integrated (see the module docstring).
    """

    harmonics: int = 5
    harmonics2: int = 3
    samples: int | None = None
    samples2: int | None = None
    subharmonic: int = 1
    crossings: str = "interval"

    def __post_init__(self):
        for name, lo in (("harmonics", 1), ("harmonics2", 1), ("subharmonic", 1)):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < lo:
                raise ValueError(f"TorusOptions.{name} must be an integer >= {lo}, got {v!r}")
        if self.crossings not in ("interval", "none"):
            raise ValueError(f"TorusOptions.crossings must be 'interval' or 'none', got {self.crossings!r}")
        for name, h in (("samples", self.harmonics), ("samples2", self.harmonics2)):
            v = getattr(self, name)
            if v is not None and (isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 2 * h + 1):
                raise ValueError(f"TorusOptions.{name} must be an integer >= {2 * h + 1} (2 x its harmonics + 1), "
                                 f"got {v!r}")


class QuasiPeriodicBalance(AllDofs):
    """The residual of a model's quasi-periodic solutions, with the second frequency as an unknown.

    Parameters
    ----------
    model : Model
    parameter : str
        The continuation parameter ``lambda``.
    options : TorusOptions
    params : dict, optional
        Parameter values overriding the model's.
    frequency : str, optional
        The excitation-frequency parameter ``w`` (default the model's).
    pin : (int, int)
        ``(j*, i*)``: pair and dof whose sine coefficient the phase condition
        sets to zero (default the pair ``(0, 1)``, dof 0).

    Attributes
    ----------
    n, nu, H1, H2, N1, N2 : int
    basis : QPBasis
    size : int
        ``n (2P - 1)``, the number of Fourier coefficients.
    m : int
        ``size + 1``, unknowns ``(u, w2)`` and equations.
    frequency_moves : bool
        The continuation parameter is ``w``.
    """

    def __init__(self, model: Model, parameter: str, options: TorusOptions = TorusOptions(), params=None,
                 frequency: str | None = None, pin: tuple[int, int] | None = None):
        self.model = model
        self.options = options
        self.n = model.n_dof
        self.nu = options.subharmonic
        self.H1, self.H2 = options.harmonics, options.harmonics2
        self.basis = QPBasis(self.H1, self.H2)
        deg = model.degree
        self.N1 = int(options.samples or max(default_samples(self.H1, deg), model.min_samples, 2 * self.H1 + 1))
        self.N2 = int(options.samples2 or max(default_samples(self.H2, deg), 2 * self.H2 + 1))
        # the periodic problem of the pairs (k, 0): parameters, frequency, excitation and their checks
        self.periodic = harmonic_balance(model, parameter, HBOptions(self.H1, self.nu, self.N1, options.crossings),
                                         params, frequency)
        self.parameter = parameter
        self.frequency = self.periodic.frequency
        self.k = self.periodic.k
        self.kw = self.periodic.kw
        self.frequency_moves = self.periodic.frequency_moves
        self.p0 = self.periodic.p0
        self.size = self.n * self.basis.rows
        self.m = self.size + 1
        j, i = (self.basis.pair(0, 1)[0], 0) if pin is None else pin
        if not (1 <= j < self.basis.P and 0 <= i < self.n and self.basis.pairs[j, 1] != 0):
            raise ValueError(f"pin must name a pair with k2 != 0 (1..{self.basis.P - 1}) and a dof (0..{self.n - 1}), "
                             f"got {pin!r}")
        self.pin = (int(j), int(i))
        self._pin_index = 2 * self.pin[0] * self.n + self.pin[1]
        theta1 = 2.0 * np.pi * np.arange(self.N1) / self.N1
        self.tau = np.tile(self.nu * theta1, self.N2)  # sample s = l N1 + i
        self._lin = LinearTerms(model, self.k, self.p0)
        self._dp_forces = [el for el in model.forces if el.depends_on(self.k)]
        self._switching = []
        if options.crossings == "interval":
            for el in model.forces:
                sw = el.switching_functions(np.zeros((0, self.n)), np.zeros((0, self.n)), np.zeros(0), self.p0)
                if sw is not None and sw.difference_x is not None:
                    self._switching.append(el)
        self.crossings: list = []  # (element, switching data, GridCrossings) of the last evaluation
        self._k1 = self.basis.pairs[:, 0] / self.nu  # d f_j / d w
        self._k2 = self.basis.pairs[:, 1].astype(float)  # d f_j / d w2
        self.evaluations = 0

    @property
    def H(self) -> int:
        """``H1`` (the periodic problems' name for the harmonic count)."""
        return self.H1

    @property
    def N(self) -> int:
        return self.N1

    # -- parameters and frequencies -------------------------------------
    def params_at(self, lam: float) -> np.ndarray:
        """Parameter vector with the continuation parameter at ``lam``."""
        return self.periodic.params_at(lam)

    def parameters(self) -> dict:
        return self.periodic.parameters()

    def base_frequency(self, p: np.ndarray) -> float:
        """``Omega1 = w/nu`` at ``p``."""
        return self.periodic.base_frequency(p)

    # -- the periodic-problem protocol (contin.model.periodic; full, condensed, dof_names from AllDofs) --
    def frequency_at(self, lam: float) -> float:
        """The excitation frequency ``w`` at ``lam``."""
        return self.periodic.frequency_at(lam)

    def period_at(self, lam: float) -> float:
        """``2 pi nu / w``, the period of the forced base frequency (the torus' first angle)."""
        return self.periodic.period_at(lam)

    def orbit(self, u: np.ndarray, lam: float, t):
        """:meth:`state_at` along the trajectory with ``theta2 = w2 t``, transposed: shape (n, len(t)) each."""
        x, xd = self.state_at(u, lam, t)
        return x.T.copy(), xd.T.copy()

    def frequencies(self, u: np.ndarray, lam: float) -> np.ndarray:
        """The pairs' frequencies ``k1 Omega1 + k2 w2`` at a point, shape (P,)."""
        return self.basis.frequencies(self.base_frequency(self.params_at(lam)), float(u[-1]))

    def blocks(self, u: np.ndarray) -> np.ndarray:
        """The coefficients of ``(u, w2)`` as the writable, C-ordered ``(2P-1, n)`` matrix ``U``."""
        return np.array(np.asarray(u, dtype=float)[: self.size].reshape(self.basis.rows, self.n))

    # -- time domain ----------------------------------------------------
    def samples_of(self, u: np.ndarray, lam: float):
        """Grid samples of the solution.

        Returns
        -------
        x, xd : ndarray, shape (N1 N2, n)
            Displacements and velocities (``d/dt``).
        x1, x2 : ndarray, shape (N1 N2, n)
            ``dx/dtheta1`` and ``dx/dtheta2``.
        """
        U = self.blocks(u)
        x, x1, x2 = aft2d.synthesize2(U, self.basis.pairs, self.N1, self.N2)
        Omega1 = self.base_frequency(self.params_at(lam))
        return x, Omega1 * x1 + float(u[-1]) * x2, x1, x2

    def state_at(self, u: np.ndarray, lam: float, t: np.ndarray, phase2: float = 0.0):
        """Displacements and velocities along the trajectory ``theta1 = Omega1 t``, ``theta2 = w2 t + phase2``.

        Parameters
        ----------
        t : ndarray, shape (T,)

        Returns
        -------
        x, xd : ndarray, shape (T, n)
        """
        U = self.blocks(u)
        f = self.frequencies(u, lam)
        t = np.atleast_1d(np.asarray(t, dtype=float))
        ph = np.outer(t, f) + phase2 * self.basis.pairs[:, 1][None, :]
        c, s = np.cos(ph[:, 1:]), np.sin(ph[:, 1:])
        A, B = U[1::2], U[2::2]
        x = U[0][None, :] + c @ A + s @ B
        xd = (-s * f[1:]) @ A + (c * f[1:]) @ B
        return x, xd

    def _forces(self, x, xd, p, U, freqs):
        """Force and derivatives at the grid samples, switches resolved along the lines (``self.crossings``)."""
        N = x.shape[0]
        f = np.zeros((N, self.n))
        dfdx = np.zeros((N, self.n, self.n))
        dfdxd = np.zeros((N, self.n, self.n))
        for el in self.model.forces:
            el.evaluate(x, xd, self.tau, p, f, dfdx, dfdxd)
        self.crossings = []
        for el in self._switching:
            sw = el.switching_functions(x, xd, self.tau, p)
            cr = crossings2d.locate_grid_crossings(el, sw, U, self.basis.pairs, freqs, self.N1, self.N2, self.nu, p,
                                                   f, dfdx, dfdxd)
            if cr is not None:
                self.crossings.append((el, sw, cr))
        return f, dfdx, dfdxd

    # -- residual and Jacobian -----------------------------------------
    def _excitation(self, p):
        fe, dfe = self.periodic.excitation(p)
        return self.basis.embed_periodic(fe, self.n), self.basis.embed_periodic(dfe, self.n)

    def residual(self, u: np.ndarray, lam: float) -> np.ndarray:
        """``(R, b_{j*, i*})``, shape (m,)."""
        p = self.params_at(lam)
        M, C, K = self._lin.at(p)
        U = self.blocks(u)
        freqs = self.frequencies(u, lam)
        R = aft2d.linear_apply2(M, C, K, freqs, U).reshape(-1) - self._excitation(p)[0]
        if self.model.forces:
            x, xd, _, _ = self.samples_of(u, lam)
            f, _, _ = self._forces(x, xd, p, U, freqs)
            R += aft2d.project2(f, self.basis.pairs, self.N1, self.N2).reshape(-1)
        self.evaluations += 1
        return np.append(R, u[self._pin_index])

    def linearize(self, u: np.ndarray, lam: float):
        """Residual and analytic Jacobians.

        Returns
        -------
        R : ndarray, shape (m,)
        Ju : ndarray, shape (m, m)
            ``d(R, phase)/d(u, w2)``.
        Jlam : ndarray, shape (m,)
        """
        p = self.params_at(lam)
        M, C, K = self._lin.at(p)
        U = self.blocks(u)
        freqs = self.frequencies(u, lam)
        pairs = self.basis.pairs
        fext, dfext = self._excitation(p)
        R = aft2d.linear_apply2(M, C, K, freqs, U).reshape(-1) - fext
        Jc = np.zeros((self.size, self.size))
        aft2d.linear_operator2(M, C, K, freqs, Jc)
        Jw2 = aft2d.linear_apply2_dfreq(M, C, freqs, self._k2, U).reshape(-1)
        Jlam = -dfext
        if self._lin.depends:
            dM, dC, dK = self._lin.dp(p)
            Jlam = Jlam + aft2d.linear_apply2(dM, dC, dK, freqs, U).reshape(-1)
        if self.frequency_moves:
            Jlam = Jlam + aft2d.linear_apply2_dfreq(M, C, freqs, self._k1, U).reshape(-1)
        if self.model.forces:
            x, xd, x1, x2 = self.samples_of(u, lam)
            f, dfdx, dfdxd = self._forces(x, xd, p, U, freqs)
            R += aft2d.project2(f, pairs, self.N1, self.N2).reshape(-1)
            for el, sw, cr in self.crossings:  # the crossings' places move with u, w2 and lambda
                cols = crossings2d.crossing_columns(cr, sw.difference, pairs, self.N1, self.N2).reshape(self.size, -1)
                Jc += cols @ cr.dtdU.reshape(cr.t.size, -1)
                Jw2 += cols @ cr.dtdw2
                if self.frequency_moves:
                    Jlam = Jlam + cols @ cr.dtdw
                if el.depends_on(self.k):
                    hp, Lp = el.switching_dp(x, xd, self.tau, p, self.k)
                    hpc, _ = el.switching_dp(cr.state[0], cr.state[1], cr.phase, p, self.k)
                    dt = -hpc[np.arange(cr.t.size), cr.intervals[:, 2]] / cr.slope
                    Jlam = Jlam + aft2d.project2(crossings2d.crossing_dp(cr, sw.difference, Lp, dt, x.shape[0],
                                                                         self.n), pairs, self.N1, self.N2).reshape(-1)
            aft2d.jacobian2(dfdx, dfdxd, pairs, freqs, self.N1, self.N2, Jc)
            Jw2 += aft2d.project2(np.einsum("sab,sb->sa", dfdxd, x2), pairs, self.N1, self.N2).reshape(-1)
            dfdp = np.zeros_like(f)
            for el in self._dp_forces:
                el.evaluate_dp(x, xd, self.tau, p, self.k, dfdp)
            if self.frequency_moves:  # xdot = (w/nu) x1 + w2 x2 moves with w
                dfdp += np.einsum("sab,sb->sa", dfdxd, x1) / self.nu
            Jlam = Jlam + aft2d.project2(dfdp, pairs, self.N1, self.N2).reshape(-1)
        J = np.zeros((self.m, self.m))
        J[: self.size, : self.size] = Jc
        J[: self.size, -1] = Jw2
        J[-1, self._pin_index] = 1.0
        self.evaluations += 1
        return np.append(R, u[self._pin_index]), J, np.append(Jlam, 0.0)

    # -- engine hints ---------------------------------------------------
    def unknown_scale(self):
        return None

    def unknown_groups(self) -> np.ndarray:
        """Each coefficient's dof, and the second frequency a group of its own."""
        return np.append(np.arange(self.size) % self.n, self.n)

    # -- measures -------------------------------------------------------
    def amplitudes(self, u: np.ndarray) -> np.ndarray:
        """Amplitude of every pair and dof, shape (P, n)."""
        return self.basis.amplitudes(self.blocks(u))


#: the components of a torus reported in ``branches.csv``: column prefix -> pair (k1, k2)
COMPONENTS = {"forced": (1, 0), "free": (0, 1), "comb": (1, -1)}


def torus_measure_names(dof_names, whirl_parts=()) -> list[str]:
    """The columns only torus rows fill: the second frequency, the components of every dof and the whirls of
    the node pairs ``whirl_parts`` (names) at ``+w2`` and ``w2 - w`` (:data:`contin.model.whirl.TORUS_WHIRL`)."""
    return (["frequency2"] + [f"{c}_{d}" for d in dof_names for c in COMPONENTS]
            + [f"{c}_{part}" for part in whirl_parts for c in TORUS_WHIRL])


def torus_measures(problem: QuasiPeriodicBalance, u: np.ndarray, lam: float, dof_names,
                   harmonic_columns: int = 5, whirl_parts=None) -> dict:
    """Measures of a torus point, in the columns of a periodic one and the torus' own.

    ``amp``, ``max``, ``min`` are taken over a grid of four times the
    problem's in each direction (the extrema of the torus surface, which a
    trajectory comes arbitrarily close to); ``rms`` is the time RMS of the
    oscillating part (Parseval over the pairs); ``hK`` the amplitude of the
    pair ``(K, 0)``; ``frequency2`` is ``w2``; ``forced``, ``free`` and
    ``comb`` the amplitudes of the pairs ``(1, 0)``, ``(0, 1)`` and ``(1, -1)``
    (frequencies ``w/nu``, ``w2`` and ``w/nu - w2``). With ``whirl_parts`` (part name -> dof indices
    ``(x, y)``) the rotor's whirl columns of each part as
    :func:`contin.timedomain.circle_measures.circle_measures` writes them (``nu = 1``).
    """
    U = problem.blocks(u)
    b = problem.basis
    x = aft2d.synthesize2(U, b.pairs, 4 * problem.N1, 4 * problem.N2)[0]
    amps = b.amplitudes(U)
    out = {"frequency2": float(u[-1])}
    for i, d in enumerate(dof_names):
        hi, lo = float(x[:, i].max()), float(x[:, i].min())
        out.update({f"amp_{d}": 0.5 * (hi - lo), f"max_{d}": hi, f"min_{d}": lo,
                    f"rms_{d}": float(np.sqrt(0.5 * np.sum(amps[1:, i] ** 2)))})
        out[f"h0_{d}"] = amps[0, i]
        for k in range(1, min(problem.H1, harmonic_columns) + 1):
            out[f"h{k}_{d}"] = amps[b.pair(k, 0)[0], i]
        for c, (k1, k2) in COMPONENTS.items():
            out[f"{c}_{d}"] = amps[b.pair(k1, k2)[0], i] if b.H1 >= k1 else 0.0
    w1, w2, nu = problem.frequency_at(lam) / problem.nu, float(u[-1]), problem.nu
    for part, (ix, iy) in (whirl_parts or {}).items():
        for label, k2 in (("half", nu), ("1", 2 * nu)):  # w/2 and w are the lines (k2/2, 0) of w/nu
            k = k2 // 2
            fwd, bwd = b.whirl(U, b.pair(k, 0)[0], w1, w2, ix, iy) if k2 % 2 == 0 and k <= b.H1 else (0.0, 0.0)
            out.update({f"whirl_fwd_{label}_{part}": float(fwd), f"whirl_bwd_{label}_{part}": float(bwd)})
        out[f"whirl_fwd_free_{part}"] = float(b.whirl(U, b.pair(0, 1)[0], w1, w2, ix, iy)[0])
        out[f"whirl_bwd_comb_{part}"] = float(b.whirl(U, b.pair(1, -1)[0], w1, w2, ix, iy)[1])
    return out
