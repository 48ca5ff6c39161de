"""Harmonic balance with AFT: a model, H, nu and N turned into R(u, lambda).

For ``M x'' + C x' + K x + f_nl(x, x', tau) = f_ext(tau)`` and the ansatz of
:mod:`contin.hb.harmonics` (base phase ``theta = w t / nu``, base frequency
``Omega = w/nu``), the residual is

    R(u, lambda) = A(Omega, p) u + P f_nl(x(theta_j), Omega x'(theta_j), nu theta_j) - P f_ext(nu theta_j),

where ``P`` is the discrete Fourier projection of :func:`contin.hb.aft.project`
and ``A`` is block diagonal: ``K`` on the mean and, for harmonic ``k``,

    [ K - (k Omega)^2 M     k Omega C        ]  acting on (a_k, b_k).
    [ -k Omega C            K - (k Omega)^2 M ]

The residual is in force units with the same normalisation as the
coefficients, so a linear system's residual is ``Z(k Omega) X - F``. The
kernels of ``A`` live in :mod:`contin.hb.linear`.

The frequency
-------------
Which parameter is the excitation frequency ``w`` is decided once, when the
problem is made: the model's declared frequency (``Model.frequency``), or
the ``frequency`` argument, which overrides it for this problem alone (the
model is not changed). Everything that needs ``w``, ``Omega = w/nu`` or the
period ``2 pi nu / w`` asks the problem (:meth:`HarmonicBalance.excitation_frequency`,
:meth:`HarmonicBalance.base_frequency`, :meth:`HarmonicBalance.period`), and
:attr:`HarmonicBalance.frequency_moves` says whether the continuation
parameter is that frequency (then ``Omega`` moves with ``lambda`` and the
``lambda`` derivatives carry ``dOmega/dlambda = 1/nu``).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from contin.hb import aft, contact_quadrature, crossings
from contin.hb.harmonics import coefficient_blocks, default_samples, derivative_coefficients, sample_phases
from contin.hb.linear import LinearTerms, linear_apply, linear_apply_dOmega, linear_operator, split_operator
from contin.hb.periodic import SeriesMembers
from contin.model.base import Model
from contin.model.elements.harmonic import HarmonicExcitation
from contin.util.options import from_mapping

__all__ = ["HBOptions", "HarmonicBalance", "CROSSINGS"]

#: values of :attr:`HBOptions.crossings`
CROSSINGS = ("exact", "interval", "none")


@dataclass(frozen=True)
class HBOptions:
    """Discretisation of the harmonic-balance problem.

    Parameters
    ----------
    harmonics : int
        ``H``, number of harmonics of the base frequency ``w/nu`` (>= 0).
        ``H = 0`` is the static problem ``K x + f_nl(x, 0) = f_0`` (only
        constant excitation allowed); its ``Ju`` is the tangent stiffness.
    subharmonic : int
        ``nu``, the solution period is ``2 pi nu / w`` (>= 1).
    samples : int or None
        AFT sample count ``N`` per period (>= 2H+1). ``None`` takes
        :func:`contin.hb.harmonics.default_samples` for the model's degree
        (``4H+1`` for cubic forces) and at least the model's ``min_samples``.
    crossings : {'exact', 'interval', 'none'}
        How the harmonic balance integrates contact laws that switch (force
        elements with switching data, :class:`contin.model.base.Switching`):
        ``'exact'`` locates the contact and flight arcs on the series and
        integrates the law over them by Gauss quadrature
        (:mod:`contin.hb.contact_quadrature`: smooth through contact onset and
        tangential touches); ``'interval'`` resolves each switch inside its
        sample interval by linear interpolation (:mod:`contin.hb.crossings`:
        continuous, second order); ``'none'`` samples the law plainly, whose
        residual jumps when a sample crosses the surface if the law jumps.
    """

    harmonics: int = 5
    subharmonic: int = 1
    samples: int | None = None
    crossings: str = "exact"

    def __post_init__(self):
        for name, lo in (("harmonics", 0), ("subharmonic", 1)):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < lo:
                raise ValueError(f"HBOptions.{name} must be an integer >= {lo}, got {v!r}")
        if self.samples is not None:
            s = self.samples
            if isinstance(s, bool) or not isinstance(s, (int, np.integer)) or s < 2 * self.harmonics + 1:
                raise ValueError(
                    f"HBOptions.samples must be an integer >= 2*harmonics+1 = {2 * self.harmonics + 1}, got {s!r}"
                )
        if self.crossings not in CROSSINGS:
            raise ValueError(f"HBOptions.crossings must be one of {list(CROSSINGS)}, got {self.crossings!r}")

    @classmethod
    def from_dict(cls, d: dict) -> "HBOptions":
        """From a mapping (:func:`contin.util.options.from_mapping`); an unknown key raises ``ValueError``
        naming it and the nearest valid one."""
        return from_mapping(cls, d)


class HarmonicBalance(SeriesMembers):
    """The residual ``R(u, lambda)`` of a model's periodic solutions.

    Parameters
    ----------
    model : Model
    parameter : str
        Name of the continuation parameter ``lambda`` (any model parameter:
        the frequency ``w``, a force amplitude, a stiffness, ...).
    options : HBOptions
    params : dict, optional
        Values overriding the model's parameters.
    frequency : str, optional
        The excitation-frequency parameter ``w`` (``tau = w t``); default the
        model's declared frequency.

    Attributes
    ----------
    n : int
        Degrees of freedom.
    H, nu, N : int
        Harmonics, subharmonic order, samples.
    size : int
        ``n*(2H+1)``, length of ``u``.
    frequency : str
        The excitation-frequency parameter.
    kw : int
        Its index in the parameter vector.
    frequency_moves : bool
        The continuation parameter is the frequency (``lambda = w``).
    """

    def __init__(self, model: Model, parameter: str, options: HBOptions = HBOptions(), params=None,
                 frequency: str | None = None):
        self.model = model
        self.options = options
        self.n = model.n_dof
        self.H = options.harmonics
        self.nu = options.subharmonic
        N = options.samples
        if N is None:
            N = max(default_samples(self.H, model.degree), model.min_samples)
        self.N = int(N)
        self.size = self.n * (2 * self.H + 1)
        self.parameter = parameter
        self.k = model.parameter_index(parameter)
        model.check_variable(parameter, params)
        self.frequency = model.frequency if frequency is None else frequency
        self.kw = model.parameter_index(self.frequency)
        self.frequency_moves = self.k == self.kw
        self.p0 = model.parameter_vector(params)
        self.theta = sample_phases(self.N)
        self.tau = self.nu * self.theta
        for el in model.excitations:
            q = el.max_order() * self.nu
            if abs(q - round(q)) > 1e-12 or round(q) > self.H:
                raise ValueError(
                    f"excitation of order {el.max_order():g} in tau needs harmonic {q:g} of w/nu with nu={self.nu}; "
                    f"it must be an integer <= harmonics={self.H}"
                )
        for el in model.forces:
            for o in el.tau_orders():
                if abs(o * self.nu - round(o * self.nu)) > 1e-12:
                    raise ValueError(
                        f"force '{el.kind}' varies as cos({o:g}*tau), which is not periodic with the solution "
                        f"period 2*pi*nu/w for nu={self.nu}"
                    )
        self._fext_key = None
        self._fext_shapes = None
        # M, C, K are fixed during a run unless they depend on lambda; the dense split of A for
        # linear_matrix() is made on first use (the Newton path works block by block)
        self._lin = LinearTerms(model, self.k, self.p0)
        self._lin_parts = None
        self._work = (
            np.zeros((self.N, self.n)),
            np.zeros((self.N, self.n, self.n)),
            np.zeros((self.N, self.n, self.n)),
        )
        # elements whose switches are resolved between samples (their law may jump on the surface)
        self._switching = []
        if options.crossings != "none" and self.H > 0:
            for el in model.forces:
                sw = el.switching_functions(np.zeros((0, self.n)), np.zeros((0, self.n)), np.zeros(0), self.p0)
                if sw is not None and sw.difference_x is not None:
                    self._switching.append(el)
        self._crossings = []
        self._laws = []
        # forces with an explicit lambda dependence, found once rather than at every linearisation
        # (those integrated over their arcs differentiate there instead)
        exact = options.crossings == "exact"
        self._dp_forces = [el for el in model.forces
                           if el.depends_on(self.k) and not (exact and el in self._switching)]
        self.evaluations = 0

    # -- parameters -------------------------------------------------------
    def params_at(self, lam: float) -> np.ndarray:
        """Parameter vector with the continuation parameter set to ``lam``."""
        p = self.p0.copy()
        p[self.k] = lam
        return p

    def with_options(self, **changes) -> "HarmonicBalance":
        """A new problem with changed :class:`HBOptions` (same model, parameters and frequency)."""
        if "harmonics" in changes and "samples" not in changes:
            changes = {**changes, "samples": None}  # the default for the new H, not the old count
        opts = dataclasses.replace(self.options, **changes)
        return HarmonicBalance(self.model, self.parameter, opts, self.parameters(), self.frequency)

    def parameters(self) -> dict:
        """The parameter values of the problem by name (``lambda`` at its value in ``p0``)."""
        return dict(zip(self.model.param_names, self.p0))

    # -- frequency --------------------------------------------------------
    def excitation_frequency(self, p: np.ndarray) -> float:
        """The excitation frequency ``w`` at the parameter vector ``p`` (``tau = w t``)."""
        return float(p[self.kw])

    def base_frequency(self, p: np.ndarray) -> float:
        """The base frequency ``Omega = w/nu`` of the solution at ``p``.

        A Python float: numba types numpy scalars slowly, and the kernels take it as is.
        """
        return float(p[self.kw]) / self.nu

    def period(self, p: np.ndarray) -> float:
        """The solution period ``2 pi nu / w = 2 pi / Omega`` at ``p``."""
        return 2.0 * np.pi / self.base_frequency(p)

    # -- linear part ------------------------------------------------------
    def linear_matrix(self, p: np.ndarray) -> np.ndarray:
        """The linear operator ``A(Omega, p)``, shape (size, size)."""
        Omega = self.base_frequency(p)
        if self._lin.depends:
            M, C, K = self.model.linear(p)
            A = np.zeros((self.size, self.size))
            linear_operator(M, C, K, Omega, self.H, A, False)
            return A
        if self._lin_parts is None:
            self._lin_parts = split_operator(*self.model.linear(self.p0), self.H)
        A0, A1, A2 = self._lin_parts
        return A0 + Omega * A1 + Omega * Omega * A2

    def _linear_mck(self, p: np.ndarray):
        """``(M, C, K)`` at ``p = params_at(lambda)``, from the parts split at construction."""
        return self._lin.at(p)

    def _linear_dp_times(self, p: np.ndarray, U: np.ndarray, MCK=None):
        """``(dA/dlambda) u``, shape (size,), block by block from ``U`` (the ``(2H+1, n)`` view of ``u``)
        without forming ``dA``; None if ``A`` does not depend on lambda."""
        Omega = self.base_frequency(p)
        out = None
        if self._lin.depends:
            dM, dC, dK = self._lin.dp(p)
            out = linear_apply(dM, dC, dK, Omega, U)
        if self.frequency_moves:
            M, C, _ = self._linear_mck(p) if MCK is None else MCK
            dw = linear_apply_dOmega(M, C, Omega, U)
            dw /= self.nu  # dOmega/dw
            out = dw if out is None else out + dw
        return None if out is None else out.reshape(-1)

    # -- excitation -------------------------------------------------------
    def excitation(self, p: np.ndarray):
        """Fourier coefficients of ``f_ext`` and their ``lambda`` derivative, shape (size,)."""
        key = p.tobytes()
        if key != self._fext_key:
            if self._fext_shapes is None:
                # a harmonic excitation is an amplitude A(p) times a fixed shape of tau: project the shape once,
                # so that a parameter change (lambda = w for the rotor's unbalance e w^2) costs no transform
                self._fext_shapes = []
                for el in self.model.excitations:
                    shape = None
                    if type(el) is HarmonicExcitation:  # not a subclass, which may change evaluate()
                        g = np.zeros((self.N, self.n))
                        g[:, el.dof] = el._shape(self.tau)
                        shape = aft.project(g, self.H).reshape(-1)
                    self._fext_shapes.append((el, shape))
            fext = np.zeros(self.size)
            dfext = np.zeros(self.size)
            f = df = None
            for el, shape in self._fext_shapes:
                if shape is not None:
                    fext += el.amplitude.value(p) * shape
                    if el.amplitude.depends_on(self.k):
                        dfext += el.amplitude.derivative(p, self.k) * shape
                    continue
                if f is None:
                    f = np.zeros((self.N, self.n))
                    df = np.zeros((self.N, self.n))
                el.evaluate(self.tau, p, f)
                el.evaluate_dp(self.tau, p, self.k, df)
            if f is not None:
                fext += aft.project(f, self.H).reshape(-1)
                dfext += aft.project(df, self.H).reshape(-1)
            self._fext, self._dfext = fext, dfext
            self._fext_key = key
        return self._fext, self._dfext

    # -- time domain ------------------------------------------------------
    def _blocks(self, u: np.ndarray) -> np.ndarray:
        """``u`` as the C-ordered, writable ``(2H+1, n)`` matrix the kernels take.

        Writable too: numba compiles a separate specialisation for read-only
        arrays (such as the views of a stored branch), a second compilation
        of every kernel on a cold cache.
        """
        U = np.ascontiguousarray(coefficient_blocks(u, self.n), dtype=float)
        return U if U.flags.writeable else U.copy()

    def samples_of(self, u: np.ndarray, lam: float):
        """Time samples of the solution.

        Returns
        -------
        x, xd : ndarray, shape (N, n)
            Displacements and velocities (d/dt) at ``theta_j``.
        xp : ndarray, shape (N, n)
            ``dx/dtheta``.
        """
        U = self._blocks(u)
        x, xp = aft.synthesize(U, self.N)
        Omega = self.base_frequency(self.params_at(lam))
        return x, Omega * xp, xp

    def sample_jacobians(self, u: np.ndarray, lam: float):
        """Nonlinear force and its derivatives at the samples.

        Returns
        -------
        f : ndarray, shape (N, n)
        dfdx, dfdxd : ndarray, shape (N, n, n)
        """
        x, xd, _ = self.samples_of(u, lam)
        return tuple(a.copy() for a in self._forces_at(x, xd, self.params_at(lam), u))

    def _forces_at(self, x, xd, p, u):
        """Nonlinear force and its derivatives at the samples, in the reused work arrays.

        Switching laws integrated exactly leave their arcs' part in ``self._laws``
        (coefficient space); see :meth:`_law_coefficients`.
        """
        f, dfdx, dfdxd = self._work
        f[:] = 0.0
        dfdx[:] = 0.0
        dfdxd[:] = 0.0
        exact = self.options.crossings == "exact"
        for el in self.model.forces:
            if not (exact and el in self._switching):
                el.evaluate(x, xd, self.tau, p, f, dfdx, dfdxd)
        self._crossings = []
        self._laws = []
        if not self._switching:
            return f, dfdx, dfdxd
        U = self._blocks(u)
        Omega = self.base_frequency(p)
        if exact:
            xp, xpp = aft.synthesize(np.ascontiguousarray(derivative_coefficients(U)), self.N)
        for el in self._switching:
            sw = el.switching_functions(x, xd, self.tau, p)
            if not exact:
                cr = crossings.locate_crossings(el, U, Omega, self.theta, sw.value, p)
                if cr.t.size:
                    coef = crossings.apply_crossings(cr.intervals, cr.sign, cr.t, sw.difference, sw.difference_x,
                                                     sw.difference_xd, f, dfdx, dfdxd)
                    self._crossings.append((el, sw, cr, coef))
                continue
            for i in range(sw.value.shape[1]):
                slope = np.einsum("jq,jq->j", sw.grad_x[:, i], xp) + Omega * np.einsum("jq,jq->j", sw.grad_xd[:, i], xpp)
                law = contact_quadrature.LawIntegral(el, i, U, Omega, self.nu, self.theta, sw.value[:, i], slope, p)
                if law.quad.full:  # the trapezoidal rule of the law over the whole period, minus the flights
                    f += sw.difference[:, i]
                    dfdx += sw.difference_x[:, i]
                    dfdxd += sw.difference_xd[:, i]
                self._laws.append((el, i, law))
        return f, dfdx, dfdxd

    def _law_coefficients(self) -> np.ndarray:
        """The arcs' part of the exactly integrated laws, shape (size,)."""
        out = np.zeros((2 * self.H + 1, self.n))
        for _, _, law in self._laws:
            out += law.coefficients
        return out.reshape(-1)

    def _law_terms(self, x, xd, p, J, Jlam, dfdp, dofs=None):
        """Jacobian and lambda derivative of the exactly integrated laws (arcs into J, Jlam; samples into dfdp).

        With ``dofs``, ``J`` is the block of those dofs' coefficients (see :meth:`linearize_into`).
        """
        for el, i, law in self._laws:
            law.add_jacobian(J, dofs)
            dep = el.depends_on(self.k)
            Jlam += law.lam_derivative(self.frequency_moves, self.k if dep else None).reshape(-1)
            if dep and law.quad.full:
                _, Lp = el.switching_dp(x, xd, self.tau, p, self.k)
                dfdp += Lp[:, i]

    def _crossing_terms(self, x, xd, p, J, dfdp, dofs=None):
        """Crossing terms of ``J`` and ``dfdp`` (see :mod:`contin.hb.crossings`).

        With ``dofs``, ``J`` is the block of those dofs' coefficients (see :meth:`linearize_into`).
        """
        Omega = self.base_frequency(p)
        for el, sw, cr, coef in self._crossings:
            dtdU = crossings.crossing_gradients(cr.phi, cr.gx, cr.gxd, cr.slope, Omega, self.H)
            if dofs is None:
                crossings.add_crossing_jacobian(cr.intervals, coef, sw.difference, self.theta, dtdU, J)
            else:
                crossings.add_crossing_jacobian(cr.intervals, coef, sw.difference[:, :, dofs], self.theta,
                                                dtdU[:, :, dofs], J)
            dt = np.zeros(cr.t.size)
            if self.frequency_moves:  # x' = (w/nu) dx/dtheta at the crossing
                dt -= np.einsum("kq,kq->k", cr.gxd, cr.dx1) / self.nu / cr.slope
            Lp = np.zeros((0, 1, 1))
            if el.depends_on(self.k):
                hp, Lp = el.switching_dp(x, xd, self.tau, p, self.k)
                hpc, _ = el.switching_dp(cr.state[0], cr.state[1], cr.phi, p, self.k)
                dt -= hpc[np.arange(cr.t.size), cr.intervals[:, 2]] / cr.slope
            crossings.add_crossing_dp(cr.intervals, coef, sw.difference, Lp, dt, dfdp)

    # -- residual and Jacobian -------------------------------------------
    def residual(self, u: np.ndarray, lam: float) -> np.ndarray:
        """``R(u, lambda)``, shape (size,)."""
        p = self.params_at(lam)
        fext, _ = self.excitation(p)
        M, C, K = self._linear_mck(p)
        U = self._blocks(u)
        R = linear_apply(M, C, K, self.base_frequency(p), U).reshape(-1) - fext
        if self.model.forces:
            x, xd, _ = self.samples_of(u, lam)
            f, _, _ = self._forces_at(x, xd, p, u)
            R += aft.project(f, self.H).reshape(-1)
            if self._laws:
                R += self._law_coefficients()
        self.evaluations += 1
        return R

    def linearize(self, u: np.ndarray, lam: float):
        """Residual and analytic Jacobians.

        Returns
        -------
        R : ndarray, shape (size,)
        Ju : ndarray, shape (size, size)
            ``dR/du``.
        Jlam : ndarray, shape (size,)
            ``dR/dlambda``.
        """
        p = self.params_at(lam)
        M, C, K = self._linear_mck(p)
        # the linear part block by block, O(n^2 H): no dense A0 + Omega A1 + Omega^2 A2 nor dense products
        J = np.zeros((self.size, self.size))
        linear_operator(M, C, K, self.base_frequency(p), self.H, J, False)
        R, Jlam = self.linearize_into(u, lam, J)
        return R, J, Jlam

    def linearize_into(self, u: np.ndarray, lam: float, J: np.ndarray, dofs=None):
        """Residual and ``dR/dlambda``, with the nonlinear part of ``dR/du`` added to ``J``.

        The linear part of ``dR/du`` (the block-diagonal ``A``) is left to the
        caller, who may hold it in another form (:mod:`contin.hb.condensation`
        holds its Schur complement on ``dofs``).

        Parameters
        ----------
        u : ndarray, shape (size,)
        lam : float
        J : ndarray, shape (size, size), or (len(dofs)(2H+1), len(dofs)(2H+1)) with ``dofs``
            Accumulated in place.
        dofs : ndarray of int, optional
            Sorted dofs that include every dof a force element acts on or
            depends on: ``J`` is then the block of their coefficients (rows and
            columns, harmonic-major as in :mod:`contin.hb.harmonics`) and the
            nonlinear kernels work on those dofs alone.

        Returns
        -------
        R, Jlam : ndarray, shape (size,)
            The full residual and its lambda derivative.
        """
        m = self.size if dofs is None else len(dofs) * (2 * self.H + 1)
        if J.shape != (m, m):  # the kernels write without bounds checks
            raise ValueError(f"linearize_into: J must have shape {(m, m)}, got {J.shape}")
        p = self.params_at(lam)
        fext, dfext = self.excitation(p)
        MCK = self._linear_mck(p)
        M, C, K = MCK
        Omega = self.base_frequency(p)
        U = self._blocks(u)
        R = linear_apply(M, C, K, Omega, U).reshape(-1) - fext
        dAu = self._linear_dp_times(p, U, MCK)
        Jlam = -dfext if dAu is None else dAu - dfext
        if self.model.forces:
            x, xp = aft.synthesize(U, self.N)
            xd = Omega * xp
            f, dfdx, dfdxd = self._forces_at(x, xd, p, u)
            dfdp = np.zeros((self.N, self.n))
            for el in self._dp_forces:
                el.evaluate_dp(x, xd, self.tau, p, self.k, dfdp)
            if self._crossings:
                self._crossing_terms(x, xd, p, J, dfdp, dofs)
            if self._laws:
                R += self._law_coefficients()
                self._law_terms(x, xd, p, J, Jlam, dfdp, dofs)
            # when lambda is w, the velocity xdot = (w/nu) x'(theta) depends on it too
            with_w = self.frequency_moves
            if dofs is None:
                Rn, Jn = aft.nonlinear_terms(f, dfdx, dfdxd, dfdp, xp, Omega, self.nu, self.H, with_w, J)
                R += Rn
                Jlam += Jn
            else:
                # the other dofs carry no force and no force depends on them: their samples are zero
                Rn, Jn = aft.nonlinear_terms(f[:, dofs], dfdx[:, dofs][:, :, dofs], dfdxd[:, dofs][:, :, dofs],
                                             dfdp[:, dofs], xp[:, dofs], Omega, self.nu, self.H, with_w, J)
                rows = (np.arange(2 * self.H + 1)[:, None] * self.n + np.asarray(dofs)[None, :]).reshape(-1)
                R[rows] += Rn
                Jlam[rows] += Jn
        self.evaluations += 1
        return R, Jlam

    def hill_matrices(self, u: np.ndarray, lam: float):
        """Coefficient-space matrices of Hill's quadratic eigenproblem.

        A perturbation ``e^{s t} y(theta)`` of the periodic solution, with
        ``y`` expanded as in :mod:`contin.hb.harmonics` (coefficients ``q``),
        satisfies ``(Delta0 + s Delta1 + s^2 Delta2) q = 0`` with

        - ``Delta0 = dR/du`` (the harmonic-balance Jacobian),
        - ``Delta1 = I (x) C + T(df/dx') + 2 Omega (I (x) M) D``,
        - ``Delta2 = I (x) M``,

        where ``T(G)`` is the matrix of multiplication by the sampled field
        ``G`` and ``D`` the ``d/dtheta`` operator (Hill's method in the form
        of von Groll & Ewins, J. Sound Vib. 241 (2001) 223-233, and Detroux
        et al., CMAME 296 (2015) 18-38).

        Returns
        -------
        Delta0, Delta1, Delta2 : ndarray, shape (size, size)
        """
        p = self.params_at(lam)
        M, C, _ = self.model.linear(p)
        _, D0, _ = self.linearize(u, lam)
        H = self.H
        Omega = self.base_frequency(p)
        I = np.eye(2 * H + 1)
        D2 = np.kron(I, M)
        D1 = np.kron(I, C) + 2.0 * Omega * D2 @ self.derivative_operator()
        if self.model.forces:
            _, _, dfdxd = self.sample_jacobians(u, lam)
            aft.multiplication_matrix(dfdxd, H, D1, 1.0)
            for _, _, law in self._laws:  # contact laws integrated over their arcs
                law.add_velocity_jacobian(D1)
        return D0, D1, D2

    def derivative_operator(self) -> np.ndarray:
        """The ``d/dtheta`` operator on coefficient vectors, shape (size, size)."""
        Dop = np.zeros((2 * self.H + 1, 2 * self.H + 1))
        k = np.arange(1, self.H + 1)
        Dop[2 * k - 1, 2 * k] = k
        Dop[2 * k, 2 * k - 1] = -k
        return np.kron(Dop, np.eye(self.n))

    def unknown_scale(self):
        """No per-component scale: the engine scales ``u`` as a whole."""
        return None

    def unknown_groups(self) -> np.ndarray:
        """The degree of freedom of each unknown (harmonic-major layout): the
        engine scales dofs separately when their magnitudes are far apart."""
        return np.arange(self.size) % self.model.n_dof

    # -- starting points --------------------------------------------------
    def linear_solution(self, lam: float) -> np.ndarray:
        """Solution of the linear part alone (nonlinear forces dropped).

        Used as the start guess. Falls back to a least-squares solution when
        ``A`` is singular (for example a free rigid-body mode).
        """
        p = self.params_at(lam)
        A = self.linear_matrix(p)
        fext, _ = self.excitation(p)
        try:
            u = np.linalg.solve(A, fext)
            if np.all(np.isfinite(u)):
                return u
        except np.linalg.LinAlgError:
            pass
        return np.linalg.lstsq(A, fext, rcond=None)[0]
