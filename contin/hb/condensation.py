"""Exact condensation of the harmonic balance onto the dofs that carry nonlinear forces.

The linear part ``A(Omega, p) u - f_ext`` of the residual of
:mod:`contin.hb.problem` is block diagonal in the harmonics. Split the
dofs into ``c`` (every dof a force element acts on or depends on, through
``x`` or ``x'``: :meth:`contin.model.base.ForceElement.active_dofs`) and ``l``
(the others, which carry linear terms only). In the ordering of
:mod:`contin.hb.harmonics` (``U = u.reshape(2H+1, n)``, rows ``a_0, a_1, b_1,
..., a_H, b_H``) the blocks of harmonic ``k >= 1`` act on ``(a_k, b_k)`` as

    A^(k)_rs = [ K_rs - (k Omega)^2 M_rs     k Omega C_rs            ]    (r, s in {c, l})
               [ -k Omega C_rs               K_rs - (k Omega)^2 M_rs ]

(``2 n_r x 2 n_s``), and the mean block is ``A^(0)_rs = K_rs``. No force
acts on ``l`` and none depends on it, so the ``l`` rows of ``R = 0`` are
linear and give, harmonic by harmonic,

    u_l = A_ll^-1 (f_l - A_lc u_c)                                   (expand)

and the condensed problem in the ``c`` coefficients alone

    R_c(u_c, lambda) = [A u - f_ext]_c + F_nl,c(u),      u = expand(u_c, lambda)
    dR_c/du_c        = S + dF_nl,c/du_c,                 S = A_cc - A_cl A_ll^-1 A_lc
    dR_c/dlambda     = J_lam,c - A_cl A_ll^-1 J_lam,l,
    J_lam            = (dA/dlambda) u - df_ext/dlambda + dF_nl/dlambda

(the ``l`` rows of ``J_lam`` have no nonlinear part). The tangent of the
expansion is

    du_l = A_ll^-1 (-A_lc du_c - dlambda J_lam,l).

It is exact: the solutions of ``R_c = 0``, expanded, are those of the full
``R = 0``. The nonlinear Jacobian is assembled on the ``c`` dofs only
(:meth:`contin.hb.problem.HarmonicBalance.linearize_into`), so the full
dense Jacobian is never formed.

The real block of harmonic ``k`` acting on ``(a_k, b_k)`` is the complex
matrix ``Z_k = K - (k Omega)^2 M + i k Omega C`` acting on ``z_k = a_k - i
b_k`` (residual rows map alike), so the elimination is done on ``n_l x
n_l`` complex blocks, one per harmonic ``k = 0..H``, by a compiled kernel.
Narrow blocks (finite-element models ordered node by node) are factored in
band storage (:mod:`contin.hb.block_lu`), at a cost linear in ``n_l``.
The blocks depend on ``lambda`` through ``Omega = w/nu`` when ``lambda`` is
the frequency and through any matrix term that depends on it (the rotor's
gyroscopic ``ip*w``) or the excitation; they are rebuilt for each ``lambda``
that enters them (once only otherwise, e.g. in a homotopy in a contact
stiffness) and kept for the last few values.

The elimination needs every ``A_ll^(k)`` regular. :func:`condense` with
``require=False`` (a scene's ``analysis.condense: auto``) condenses only when
that holds at every frequency for the problem's parameters: ``K_ll`` regular
and the symmetric part of ``C_ll`` positive definite (then
``Im(z^H A_ll z) = k Omega z^H C_ll,sym z > 0`` for complex ``z != 0``).
"""

from __future__ import annotations

import collections

import numpy as np

from contin.hb.block_lu import bandwidths, factor, solve
from contin.hb.force_submodel import force_submodel_problem
from contin.hb.problem import HarmonicBalance
from contin.util.jit import njit

__all__ = ["CondensedHarmonicBalance", "condense", "condensation_dofs", "nonlinear_dofs", "restrict_coefficients"]

#: values of lambda whose blocks are kept (corrector, recorder and monitor at the same point)
_CACHE = 4
#: the eliminated blocks are factored in band storage when its ``2 kl + ku + 1`` rows times this are at most ``n_l``
_BAND_RATIO = 4


def restrict_coefficients(u_full, n_dof: int, dofs) -> np.ndarray:
    """The coefficients of ``dofs`` out of a full coefficient vector.

    Parameters
    ----------
    u_full : array_like, shape (n_dof (2H+1),)
    n_dof : int
    dofs : sequence of int, sorted

    Returns
    -------
    ndarray, shape (len(dofs) (2H+1),)
    """
    u = np.asarray(u_full, dtype=float).reshape(-1)
    if u.size % n_dof:
        raise ValueError(f"restrict: {u.size} coefficients are not a multiple of the {n_dof} dofs")
    return u.reshape(-1, n_dof)[:, np.asarray(dofs, dtype=int)].reshape(-1)


def nonlinear_dofs(model):
    """The dofs that force elements act on or depend on.

    Returns
    -------
    dofs : tuple of int or None
        Sorted; None when an element cannot tell (then no dof may be eliminated).
    reason : str
        Why None (empty otherwise).
    """
    used: set = set()
    for el in model.forces:
        get = getattr(el, "active_dofs", None)
        d = get() if callable(get) else None
        if d is None:
            return None, f"force element '{el.kind or type(el).__name__}' does not tell which dofs it acts on"
        d = [int(i) for i in d]
        if any(not 0 <= i < model.n_dof for i in d):
            raise ValueError(f"force element '{el.kind}' names dofs {d} outside 0..{model.n_dof - 1}")
        used.update(d)
    return tuple(sorted(used)), ""


def _regular_everywhere(hb: HarmonicBalance, free) -> str:
    """Empty if every eliminated block is regular at every frequency (see the module docstring), else why not."""
    M, C, K = hb.model.linear(hb.p0)
    names = [hb.model.dof_names[i] for i in free]
    Kll = K[np.ix_(free, free)]
    s = np.linalg.svd(Kll, compute_uv=False)
    if not s[-1] > 1e-12 * max(s[0], 1e-300):
        return f"the stiffness of the linear dofs {names} alone is singular (their mean is not fixed by the others)"
    if hb.H == 0:
        return ""
    Cs = C[np.ix_(free, free)]
    e = np.linalg.eigvalsh(0.5 * (Cs + Cs.T))
    if not e[0] > 1e-12 * max(abs(e[-1]), 1e-300):
        return (f"the damping of the linear dofs {names} alone is not positive definite: their blocks are singular "
                "at their own resonances")
    return ""


def condensation_dofs(hb: HarmonicBalance, require: bool = False):
    """The dofs to keep when condensing ``hb``, or None with the reason.

    Parameters
    ----------
    hb : HarmonicBalance
    require : bool
        False: keep all dofs (None) also when the eliminated blocks could be
        singular at some frequency (see the module docstring).

    Returns
    -------
    dofs : tuple of int or None
    reason : str
    """
    kept, why = nonlinear_dofs(hb.model)
    if kept is None:
        return None, why
    if not hb.model.forces:
        return None, "the model has no nonlinear force: nothing to condense onto"
    if len(kept) == hb.n:
        return None, "every dof carries a nonlinear force"
    if not require:
        why = _regular_everywhere(hb, [i for i in range(hb.n) if i not in kept])
        if why:
            return None, why
    return kept, ""


def condense(hb, require: bool = False):
    """The condensed problem of ``hb`` when it removes at least one dof, else ``hb`` itself.

    Parameters
    ----------
    hb : HarmonicBalance or CondensedHarmonicBalance
    require : bool
        Condense whenever a dof can be removed (also when the eliminated
        blocks are not surely regular), and raise when none can.

    Raises
    ------
    ValueError
        With ``require``, when no dof can be removed (the message says why).
    """
    if isinstance(hb, CondensedHarmonicBalance):
        return hb
    kept, why = condensation_dofs(hb, require)
    if kept is None:
        if require:
            raise ValueError(f"no dof can be condensed out: {why}")
        return hb
    return CondensedHarmonicBalance(hb, kept)


def _to_complex(V: np.ndarray) -> np.ndarray:
    """Coefficient rows ``(2H+1, m)`` as ``z_k = a_k - i b_k`` (``z_0 = a_0``), shape (H+1, m).

    The real block ``[[D, G], [-G, D]]`` of harmonic ``k`` acting on
    ``(a_k, b_k)`` is the complex matrix ``D + i G`` acting on ``z_k``, for
    coefficient vectors and residual rows alike.
    """
    z = np.empty((V.shape[0] // 2 + 1, V.shape[1]), dtype=complex)
    z[0] = V[0]
    z[1:].real = V[1::2]
    z[1:].imag = -V[2::2]
    return z


def _to_real(z: np.ndarray) -> np.ndarray:
    """Inverse of :func:`_to_complex`: shape (2H+1, m)."""
    V = np.empty((2 * z.shape[0] - 1, z.shape[1]))
    V[0] = z[0].real
    V[1::2] = z[1:].real
    V[2::2] = -z[1:].imag
    return V


@njit(cache=True)
def _eliminate(M, C, K, Omega, c, l, f, kl, ku, LU, perm, P, Q, g, S) -> bool:
    """The blocks of :class:`_Blocks` for harmonics ``k = 0..H`` (``H + 1 = f.shape[0]``).

    ``Z_k = K - (k Omega)^2 M + i k Omega C`` split on the kept dofs ``c`` and
    the eliminated ``l``; ``f`` (H+1, n) the complex excitation. Writes the
    factors of ``Z_ll`` (``LU``, ``perm``: dense when ``kl < 0``, else in the
    band storage of :func:`contin.hb.block_lu.band_lu`, which ``Z_ll`` must
    fit), ``P = Z_ll^-1 Z_lc``, ``Q = Z_cl Z_ll^-1``, ``g = Z_ll^-1 f_l`` and
    ``S = Z_cc - Z_cl P``. Returns False when some ``Z_ll`` is singular.
    """
    nc, nl = c.shape[0], l.shape[0]
    col = np.empty(nl, dtype=np.complex128)
    sol = np.empty(nl, dtype=np.complex128)
    for k in range(f.shape[0]):
        w = k * Omega
        A = LU[k]
        if kl < 0:
            for i in range(nl):
                for j in range(nl):
                    a, b = l[i], l[j]
                    A[i, j] = complex(K[a, b] - w * w * M[a, b], w * C[a, b])
        else:
            A[:, :] = 0.0
            for j in range(nl):
                for i in range(max(0, j - ku), min(nl, j + kl + 1)):
                    a, b = l[i], l[j]
                    A[kl + ku + i - j, j] = complex(K[a, b] - w * w * M[a, b], w * C[a, b])
        if not factor(A, kl, ku, perm[k]):
            return False
        for j in range(nc):
            for i in range(nl):
                a, b = l[i], c[j]
                col[i] = complex(K[a, b] - w * w * M[a, b], w * C[a, b])
            solve(A, kl, ku, perm[k], col, sol)
            for i in range(nl):
                P[k, i, j] = sol[i]
        for i in range(nl):
            col[i] = f[k, l[i]]
        solve(A, kl, ku, perm[k], col, sol)
        for i in range(nl):
            g[k, i] = sol[i]
        for i in range(nc):
            for j in range(nl):
                a, b = c[i], l[j]
                col[j] = complex(K[a, b] - w * w * M[a, b], w * C[a, b])
            solve(A, kl, ku, perm[k], col, sol, True)
            for j in range(nl):
                Q[k, i, j] = sol[j]
        for i in range(nc):
            for j in range(nc):
                a, b = c[i], c[j]
                s = complex(K[a, b] - w * w * M[a, b], w * C[a, b])
                for q in range(nl):
                    d = l[q]
                    s -= complex(K[a, d] - w * w * M[a, d], w * C[a, d]) * P[k, q, j]
                S[k, i, j] = s
    return True


@njit(cache=True)
def _solve_all(LU, kl, ku, perm, r):
    """``Z_ll,k^-1 r_k`` for every harmonic from the factors of :func:`_eliminate`; ``r`` of shape (H+1, n_l)."""
    out = np.empty_like(r)
    for k in range(r.shape[0]):
        solve(LU[k], kl, ku, perm[k], r[k], out[k])
    return out


class _Blocks:
    """The linear blocks at one value of lambda, complex per harmonic ``k = 0..H`` (see :func:`_to_complex`).

    With ``Z_k = K - (k Omega)^2 M + i k Omega C`` restricted to kept (c) and
    eliminated (l) dofs:

    Attributes
    ----------
    p : ndarray
        Parameter vector.
    band : tuple of int
        ``(kl, ku)`` when ``LU`` is in band storage, ``(-1, -1)`` when it is dense.
    LU : (H+1, n_l, n_l) or (H+1, 2 kl + ku + 1, n_l);  perm : (H+1, n_l) int
        The factors of ``Z_ll`` (:func:`contin.hb.block_lu.factor`).
    P : (H+1, n_l, n_c)
        ``Z_ll^-1 Z_lc``.
    Q : (H+1, n_c, n_l)
        ``Z_cl Z_ll^-1``.
    g : (H+1, n_l)
        ``Z_ll^-1 f_l``, the eliminated dofs at ``u_c = 0``.
    S : (H+1, n_c, n_c)
        The Schur complement ``Z_cc - Z_cl Z_ll^-1 Z_lc``.
    fc : (H+1, n_c)
        The condensed excitation ``f_c - Z_cl Z_ll^-1 f_l``.
    """

    __slots__ = ("p", "band", "LU", "perm", "P", "Q", "g", "S", "fc")


class CondensedHarmonicBalance:
    """The harmonic-balance problem in the coefficients of the dofs that carry nonlinear forces.

    The formulas are in the module docstring. Consumers of a harmonic-balance
    problem (the continuation engine, branch switching, stability) use it as
    they use :class:`~contin.hb.problem.HarmonicBalance`; what they show
    users is full: :meth:`expand` gives the full coefficients.

    Parameters
    ----------
    hb : HarmonicBalance
    dofs : sequence of int
        The dofs to keep; they must include every dof a force element acts on
        or depends on.
    banded : bool
        False: factor the eliminated blocks densely even when they are narrow
        (to compare the two eliminations).

    Attributes
    ----------
    full : HarmonicBalance
    dofs : ndarray of int
        Kept dofs, sorted.
    eliminated : ndarray of int
    n : int
        ``len(dofs)``.
    band : tuple of int or None
        ``(kl, ku)``, the bandwidths of the eliminated blocks when they are
        factored in band storage (fixed at construction from the nonzeros of
        every term of ``M``, ``C``, ``K``), None when they are factored densely.
    H, nu, N : int
    size : int
        ``n (2H+1)``, the length of the condensed ``u``.
    parameter, k, kw, model, p0, options, frequency, frequency_moves
        As in the full problem (and its frequency methods, :meth:`base_frequency`, ...).
    evaluations : int
        Condensed residual and Jacobian evaluations.
    """

    def __init__(self, hb: HarmonicBalance, dofs, banded: bool = True):
        if isinstance(hb, CondensedHarmonicBalance):
            raise ValueError("CondensedHarmonicBalance: the problem is condensed already")
        d = np.unique(np.asarray(dofs, dtype=int).reshape(-1))
        if d.size == 0 or d.size == hb.n or d[0] < 0 or d[-1] >= hb.n:
            raise ValueError(f"CondensedHarmonicBalance: dofs must be a non-empty proper subset of 0..{hb.n - 1}, "
                             f"got {list(np.asarray(dofs).reshape(-1))}")
        needed, why = nonlinear_dofs(hb.model)
        if needed is None:
            raise ValueError(f"CondensedHarmonicBalance: cannot eliminate dofs: {why}")
        missing = sorted(set(needed or ()) - set(d.tolist()))
        if missing:
            names = [hb.model.dof_names[i] for i in missing]
            raise ValueError(f"CondensedHarmonicBalance: dofs {names} carry nonlinear forces and must be kept")
        self.full = hb
        self.dofs = d
        self.eliminated = np.array([i for i in range(hb.n) if i not in set(d.tolist())], dtype=int)
        self.n = int(d.size)
        self.band = self._bandwidths() if banded else None
        self.H, self.nu, self.N = hb.H, hb.nu, hb.N
        self.size = self.n * (2 * self.H + 1)
        self.parameter, self.k, self.kw = hb.parameter, hb.k, hb.kw
        self.frequency, self.frequency_moves = hb.frequency, hb.frequency_moves
        self.model, self.p0, self.options = hb.model, hb.p0, hb.options
        self.evaluations = 0
        self._cache: collections.OrderedDict = collections.OrderedDict()
        # the blocks change with lambda only through Omega, the matrices or the excitation (not in a homotopy in
        # a contact stiffness)
        self._varies = bool(hb.frequency_moves or hb._lin.depends
                            or any(el.depends_on(hb.k) for el in hb.model.excitations))
        #: the forces on the kept dofs alone (None: evaluated on the full model, sliced)
        self._forces = force_submodel_problem(hb, d)

    def __repr__(self) -> str:
        return (f"CondensedHarmonicBalance({self.model.name!r}, dofs={self.dof_names}, "
                f"{self.size} of {self.full.size} unknowns)")

    def _bandwidths(self):
        """``(kl, ku)`` of the eliminated blocks if band storage pays off for them, else None."""
        l, nl = self.eliminated, self.eliminated.size
        pattern = np.zeros((nl, nl), dtype=bool)
        for mat in (self.full.model.mass, self.full.model.damping, self.full.model.stiffness):
            for _, A in mat.terms:
                pattern |= np.asarray(A)[np.ix_(l, l)] != 0
        kl, ku = bandwidths(pattern)
        return (kl, ku) if (2 * kl + ku + 1) * _BAND_RATIO <= nl else None

    @property
    def dof_names(self) -> list:
        return [self.model.dof_names[i] for i in self.dofs]

    def describe(self) -> str:
        return (f"condensed onto the dofs {self.dof_names} that carry nonlinear forces: {self.size} of "
                f"{self.full.size} unknowns")

    # -- parameters -----------------------------------------------------------
    def params_at(self, lam: float) -> np.ndarray:
        return self.full.params_at(lam)

    def excitation_frequency(self, p: np.ndarray) -> float:
        """``w`` at ``p``, as the full problem has it."""
        return self.full.excitation_frequency(p)

    def base_frequency(self, p: np.ndarray) -> float:
        """``Omega = w/nu`` at ``p``, as the full problem has it."""
        return self.full.base_frequency(p)

    def period(self, p: np.ndarray) -> float:
        """The solution period at ``p``, as the full problem has it."""
        return self.full.period(p)

    # the periodic-problem protocol (contin.model.periodic): the frequency and period as the full problem has them
    condensed = True

    def frequency_at(self, lam: float) -> float:
        return self.full.frequency_at(lam)

    def period_at(self, lam: float) -> float:
        return self.full.period_at(lam)

    def orbit(self, u: np.ndarray, lam: float, t):
        """Every dof's displacements and velocities at times ``t``, shape (full.n, len(t)) each."""
        return self.full.orbit(self.expand(u, lam), lam, t)

    def with_options(self, **changes) -> "CondensedHarmonicBalance":
        """The condensed problem of ``full.with_options(**changes)`` (the same dofs)."""
        return CondensedHarmonicBalance(self.full.with_options(**changes), self.dofs, self.band is not None)

    # -- linear blocks ------------------------------------------------------------
    def _at(self, lam: float) -> _Blocks:
        key = float(lam) if self._varies else 0.0
        b = self._cache.get(key)
        if b is not None:
            self._cache.move_to_end(key)
            return b
        hb = self.full
        c, l = self.dofs, self.eliminated
        nc, nl, K1 = c.size, l.size, self.H + 1
        p = hb.params_at(float(lam))
        M, C, K = hb._linear_mck(p)
        fext, _ = hb.excitation(p)
        b = _Blocks()
        b.p = p
        b.band = kl, ku = self.band or (-1, -1)
        b.LU = np.empty((K1, nl, nl) if kl < 0 else (K1, 2 * kl + ku + 1, nl), dtype=complex)
        b.perm = np.empty((K1, nl), dtype=np.int64)
        b.P = np.empty((K1, nl, nc), dtype=complex)
        b.Q = np.empty((K1, nc, nl), dtype=complex)
        b.g = np.empty((K1, nl), dtype=complex)
        b.S = np.empty((K1, nc, nc), dtype=complex)
        F = _to_complex(fext.reshape(2 * self.H + 1, hb.n))
        ok = _eliminate(M, C, K, hb.base_frequency(p), c, l, F, kl, ku, b.LU, b.perm, b.P, b.Q, b.g, b.S)
        b.fc = F[:, c] - (b.Q @ F[:, l][:, :, None])[:, :, 0]  # f_c - A_cl A_ll^-1 f_l
        if not (ok and np.all(np.isfinite(b.S)) and np.all(np.isfinite(b.g))):
            raise np.linalg.LinAlgError(
                f"the blocks of the eliminated dofs are singular at {self.parameter}={float(lam):.10g}")
        self._cache[key] = b
        if len(self._cache) > _CACHE:
            self._cache.popitem(last=False)
        return b

    def _schur_matrix(self, b: _Blocks) -> np.ndarray:
        """The Schur complement in the real coefficient layout, dense (block diagonal), shape (size, size)."""
        H, nc = self.H, self.n
        J = np.zeros((self.size, self.size))
        Jv = J.reshape(2 * H + 1, nc, 2 * H + 1, nc)
        Jv[0, :, 0, :] = b.S[0].real
        if H:
            a = np.arange(1, 2 * H, 2)
            Sr, Si = b.S[1:].real, b.S[1:].imag
            Jv[a, :, a, :] = Sr
            Jv[a, :, a + 1, :] = Si
            Jv[a + 1, :, a, :] = -Si
            Jv[a + 1, :, a + 1, :] = Sr
        return J

    def _assemble(self, Uc, Ul) -> np.ndarray:
        U = np.empty((2 * self.H + 1, self.full.n))
        U[:, self.dofs] = Uc
        U[:, self.eliminated] = Ul
        return U.reshape(-1)

    def _split(self, u, what="u") -> np.ndarray:
        u = np.asarray(u, dtype=float).reshape(-1)
        if u.size != self.size:
            raise ValueError(f"{what}: expected {self.size} condensed coefficients (dofs {self.dof_names}, "
                             f"H={self.H}), got {u.size}")
        return u.reshape(2 * self.H + 1, self.n)

    def expand(self, u: np.ndarray, lam: float) -> np.ndarray:
        """The full coefficients, shape (full.size,), of the condensed ``u`` (shape (size,))."""
        Uc = self._split(u)
        b = self._at(lam)
        zl = b.g - (b.P @ _to_complex(Uc)[:, :, None])[:, :, 0]
        return self._assemble(Uc, _to_real(zl))

    def restrict(self, u_full: np.ndarray) -> np.ndarray:
        """The kept dofs' coefficients, shape (size,), of a full vector (shape (full.size,))."""
        u_full = np.asarray(u_full, dtype=float).reshape(-1)
        if u_full.size != self.full.size:
            raise ValueError(f"restrict: expected {self.full.size} full coefficients ({self.full.n} dofs, "
                             f"H={self.H}), got {u_full.size}")
        return restrict_coefficients(u_full, self.full.n, self.dofs)

    def _lam_linear(self, b: _Blocks, u_full) -> np.ndarray:
        """``(dA/dlambda) u - df_ext/dlambda``, shape (2H+1, n)."""
        hb = self.full
        U = u_full.reshape(2 * self.H + 1, hb.n)
        _, dfext = hb.excitation(b.p)
        out = -dfext.reshape(2 * self.H + 1, hb.n)
        dAu = hb._linear_dp_times(b.p, np.ascontiguousarray(U))
        return out if dAu is None else out + dAu.reshape(2 * self.H + 1, hb.n)

    def expand_direction(self, u: np.ndarray, lam: float, du: np.ndarray, dlam: float) -> np.ndarray:
        """Derivative of :meth:`expand` along ``(du, dlam)``, shape (full.size,).

        ``du_l = A_ll^-1 (-A_lc du_c - dlam J_lam,l)`` with ``J_lam,l`` the
        eliminated rows of ``(dA/dlambda) u - df_ext/dlambda``.
        """
        b = self._at(lam)
        dUc = self._split(du, "du")
        r = _to_complex(self._lam_linear(b, self.expand(u, lam))[:, self.eliminated])
        zl = -float(dlam) * _solve_all(b.LU, *b.band, b.perm, r)
        zl -= (b.P @ _to_complex(dUc)[:, :, None])[:, :, 0]
        return self._assemble(dUc, _to_real(zl))

    def _condense_rows(self, b: _Blocks, v) -> np.ndarray:
        """``v_c - A_cl A_ll^-1 v_l`` of a full vector ``v`` (shape (full.size,)), shape (size,)."""
        V = v.reshape(2 * self.H + 1, self.full.n)
        z = _to_complex(V[:, self.dofs]) - (b.Q @ _to_complex(V[:, self.eliminated])[:, :, None])[:, :, 0]
        return _to_real(z).reshape(-1)

    # -- residual and Jacobian ----------------------------------------------------
    def residual(self, u: np.ndarray, lam: float) -> np.ndarray:
        """``R_c(u, lambda)``, shape (size,): ``S u_c - (f_c - A_cl A_ll^-1 f_l) + F_nl,c(u_c)``."""
        self.evaluations += 1
        if self._forces is not None:
            return self._linear_rows(self._at(lam), u) + self._forces.residual(u, lam)
        R = self.full.residual(self.expand(u, lam), lam)
        return R.reshape(2 * self.H + 1, self.full.n)[:, self.dofs].reshape(-1)

    def _linear_rows(self, b: _Blocks, u) -> np.ndarray:
        """The linear part of ``R_c``, ``S u_c - (f_c - A_cl A_ll^-1 f_l)``, shape (size,)."""
        z = (b.S @ _to_complex(self._split(u))[:, :, None])[:, :, 0] - b.fc
        return _to_real(z).reshape(-1)

    def linearize(self, u: np.ndarray, lam: float):
        """Condensed residual and analytic Jacobians.

        Returns
        -------
        R : ndarray, shape (size,)
        Ju : ndarray, shape (size, size)
            The Schur complement plus the nonlinear Jacobian on the kept dofs.
        Jlam : ndarray, shape (size,)
        """
        b = self._at(lam)
        J = self._schur_matrix(b)
        self.evaluations += 1
        if self._forces is not None:
            Rn, Jlam = self._forces.linearize_into(u, lam, J)
            if self._varies:  # else (dA/dlambda) u - df_ext/dlambda is zero
                Jlam = Jlam + self._condense_rows(b, self._lam_linear(b, self.expand(u, lam)).reshape(-1))
            return self._linear_rows(b, u) + Rn, J, Jlam
        R, Jlam = self.full.linearize_into(self.expand(u, lam), lam, J, self.dofs)
        Rc = R.reshape(2 * self.H + 1, self.full.n)[:, self.dofs].reshape(-1)
        return Rc, J, self._condense_rows(b, Jlam)

    # -- engine and starting points ---------------------------------------------------
    def unknown_scale(self):
        """No per-component scale: the engine scales ``u`` as a whole."""
        return None

    def unknown_groups(self) -> np.ndarray:
        """The (full-model) dof of each unknown, harmonic-major."""
        return np.tile(self.dofs, 2 * self.H + 1)

    def linear_solution(self, lam: float) -> np.ndarray:
        """The full problem's linear solution (nonlinear forces dropped), restricted."""
        return self.restrict(self.full.linear_solution(lam))
