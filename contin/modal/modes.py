"""Linear modal analysis and frequency response of ``M x'' + C x' + K x = f``.

The mathematics of seed 002 (two-degree-of-freedom systems) for ``n``
degrees of freedom:

- **undamped modes** (seed 002, sec. 2.2): ``(K - w^2 M) u = 0``, solved as
  the symmetric-definite pencil ``K u = w^2 M u`` (``scipy.linalg.eigh``),
  modes scaled to unit modal mass ``u^T M u = 1``; the mode-shape ratios of
  the seed, ``r_i = u_2^(i) / u_1^(i)``, are :meth:`NaturalModes.ratios`;
- **principal coordinates** (sec. 2.3): ``x = Phi q`` turns the equations
  into ``q'' + diag(w_i^2) q = Phi^T f`` (:class:`PrincipalCoordinates`);
- **damped eigenvalues** (sec. 3.2): ``det(lambda^2 M + lambda C + K) = 0``,
  ``2n`` roots ``lambda_i`` with modes ``B_i``, from the first-order pencil
  ``[[0, I], [-K, -C]] y = lambda [[I, 0], [0, M]] y`` with ``y = [B; lambda B]``
  (:func:`damped_modes`);
- **frequency response** (sec. 4.2): the impedance (dynamic stiffness) matrix
  ``Z(w) = K - w^2 M + i w C`` and ``X = Z(w)^-1 F`` for a force ``F e^{iwt}``
  (:func:`impedance`, :func:`frf`, :func:`receptance`), solved for all
  frequencies at once.

Convention: a force ``Re(F e^{i w t})`` (``F cos(w t)`` for real ``F``) gives
the steady response ``x(t) = Re(X e^{i w t})``: amplitude ``|X|`` and phase
``arg X`` (negative: the response lags the force). In the harmonic-balance
coefficients of :mod:`contin.hb.harmonics`, ``x = a cos(w t) + b sin(w t)``
means ``X = a - i b``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.linalg

__all__ = [
    "LinearSystem",
    "NaturalModes",
    "DampedModes",
    "PrincipalCoordinates",
    "natural_modes",
    "damped_modes",
    "principal_coordinates",
    "impedance",
    "receptance",
    "frf",
    "chain_matrices",
    "SingularImpedance",
    "check_mass",
]


class SingularImpedance(np.linalg.LinAlgError):
    """``Z(w)`` is exactly singular at some frequencies (an undamped resonance on the grid).

    Attributes
    ----------
    indices : ndarray of int
        Positions in the frequency array where ``Z`` could not be solved.
    """

    def __init__(self, indices, w):
        self.indices = np.asarray(indices, dtype=int)
        vals = ", ".join(f"{float(w[i]):.12g}" for i in self.indices[:5])
        super().__init__(f"Z(w) = K - w^2 M + i w C is singular at w = {vals}"
                         + (" ..." if self.indices.size > 5 else "")
                         + " (an undamped resonance exactly on the frequency grid)")


def _matrix(name: str, a, n: int | None = None) -> np.ndarray:
    a = np.asarray(a, dtype=float)
    if a.ndim != 2 or a.shape[0] != a.shape[1]:
        raise ValueError(f"{name} must be a square matrix, got shape {a.shape}")
    if n is not None and a.shape[0] != n:
        raise ValueError(f"{name} must be {n}x{n} like M, got {a.shape[0]}x{a.shape[1]}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} has non-finite entries")
    return a


def _is_symmetric(a: np.ndarray, rtol: float = 1e-12) -> bool:
    return bool(np.max(np.abs(a - a.T), initial=0.0) <= rtol * max(np.max(np.abs(a), initial=0.0), 1e-300))


def check_mass(M: np.ndarray) -> None:
    """Raise a ValueError unless ``M`` is a symmetric positive definite mass matrix (the message says which)."""
    if not _is_symmetric(M):
        raise ValueError("M must be symmetric")
    # positive definiteness, on the diagonally scaled matrix so that widely different masses pass
    d = np.diag(M)
    if np.any(d <= 0):
        raise ValueError(f"M must be positive definite; its diagonal is {d.tolist()}")
    s = 1.0 / np.sqrt(d)
    try:
        np.linalg.cholesky(M * s[:, None] * s[None, :])
    except np.linalg.LinAlgError:
        raise ValueError("M must be positive definite") from None


def _sign_fix(v: np.ndarray, reference: int) -> np.ndarray:
    """Scale each column so its ``reference`` component is real positive (else its largest one)."""
    v = v.copy()
    for i in range(v.shape[1]):
        col = v[:, i]
        big = np.max(np.abs(col))
        j = reference if abs(col[reference]) > 1e-9 * big else int(np.argmax(np.abs(col)))
        ph = col[j] / abs(col[j])
        v[:, i] = col / ph
    return v


@dataclass(frozen=True)
class NaturalModes:
    """Undamped natural frequencies and mass-normalised mode shapes.

    Attributes
    ----------
    omega2 : ndarray, shape (n,)
        Eigenvalues ``w_i^2`` of ``K u = w^2 M u``, ascending. A negative value
        means the equilibrium is statically unstable (divergent) in that mode.
    modes : ndarray, shape (n, n)
        Column ``i`` is mode ``i``, scaled to ``u^T M u = 1`` and signed so that
        its ``reference`` component is positive (its largest one where the
        reference dof is a node).
    reference : int
        The dof the ratios refer to (seed 002: ``x1``).
    symmetric : bool
        Whether ``K`` was symmetric (then the modes are M-orthonormal:
        ``Phi^T M Phi = I``, ``Phi^T K Phi = diag(omega2)``).
    """

    omega2: np.ndarray
    modes: np.ndarray
    reference: int = 0
    symmetric: bool = True

    @property
    def n(self) -> int:
        return self.omega2.size

    @property
    def omega(self) -> np.ndarray:
        """Natural angular frequencies ``sqrt(omega2)``, shape (n,); 0 where ``omega2 < 0`` (see ``divergent``)."""
        return np.sqrt(np.maximum(self.omega2, 0.0))

    @property
    def divergent(self) -> np.ndarray:
        """Modes with ``omega2 < 0`` (static instability), shape (n,) bool."""
        return self.omega2 < 0

    def ratios(self, reference: int | None = None) -> np.ndarray:
        """Mode-shape ratios ``u_j^(i) / u_ref^(i)``, shape (n, n) (seed 002: ``r_i = u_2/u_1``).

        ``NaN`` where the reference dof is a node of the mode (|u_ref| below
        1e-12 of the mode's largest component).
        """
        ref = self.reference if reference is None else int(reference)
        den = self.modes[ref]
        big = np.max(np.abs(self.modes), axis=0)
        ok = np.abs(den) > 1e-12 * big
        out = np.full(self.modes.shape, np.nan)
        out[:, ok] = self.modes[:, ok] / den[ok]
        return out


@dataclass(frozen=True)
class DampedModes:
    """Eigenvalues ``lambda_i`` of ``(lambda^2 M + lambda C + K) B = 0`` (seed 002, sec. 3.2).

    Attributes
    ----------
    eigenvalues : ndarray of complex, shape (2n,)
        Sorted by ``|lambda|``, then by imaginary part (descending), so an
        underdamped mode appears as ``(s, conj(s))`` with ``Im s > 0`` first.
    vectors : ndarray of complex, shape (n, 2n)
        Mode ``B_i`` per column, scaled so that its ``reference`` component is
        1 (the seed's ``[1, r_i]``), or its largest component 1 where the
        reference dof is a node.
    reference : int
    """

    eigenvalues: np.ndarray
    vectors: np.ndarray
    reference: int = 0

    @property
    def natural_frequency(self) -> np.ndarray:
        """``|lambda_i|`` (the undamped-equivalent natural frequency), shape (2n,)."""
        return np.abs(self.eigenvalues)

    @property
    def damped_frequency(self) -> np.ndarray:
        """``|Im lambda_i|``, the frequency of the free damped oscillation, shape (2n,)."""
        return np.abs(self.eigenvalues.imag)

    @property
    def damping_ratio(self) -> np.ndarray:
        """``-Re lambda_i / |lambda_i|``, shape (2n,) (0 for a zero eigenvalue)."""
        a = np.abs(self.eigenvalues)
        return np.divide(-self.eigenvalues.real, a, out=np.zeros(a.shape), where=a > 0)

    @property
    def stable(self) -> bool:
        """All ``Re lambda_i < 0`` (asymptotically stable)."""
        return bool(np.all(self.eigenvalues.real < 0))


@dataclass(frozen=True)
class PrincipalCoordinates:
    """Principal (modal) coordinates ``x = Phi q`` (seed 002, sec. 2.3).

    With mass-normalised modes ``Phi``, ``M x'' + C x' + K x = f`` becomes
    ``q'' + Phi^T C Phi q' + diag(omega2) q = Phi^T f``.

    Attributes
    ----------
    transform : ndarray, shape (n, n)
        ``Phi`` (mass-normalised modes as columns).
    modal_mass : ndarray, shape (n, n)
        ``Phi^T M Phi`` (the identity up to rounding).
    modal_stiffness : ndarray, shape (n, n)
        ``Phi^T K Phi`` (``diag(omega2)`` for symmetric ``K``).
    modal_damping : ndarray, shape (n, n)
        ``Phi^T C Phi``; diagonal only for proportional (classical) damping.
    mass : ndarray, shape (n, n)
        ``M``, kept for :meth:`to_modal`.
    """

    transform: np.ndarray
    modal_mass: np.ndarray
    modal_stiffness: np.ndarray
    modal_damping: np.ndarray
    mass: np.ndarray = field(repr=False)

    @property
    def proportional(self) -> bool:
        """Whether ``Phi^T C Phi`` is diagonal (to 1e-10 of its largest entry): modes stay uncoupled."""
        D = self.modal_damping
        off = D - np.diag(np.diag(D))
        return bool(np.max(np.abs(off), initial=0.0) <= 1e-10 * max(np.max(np.abs(D), initial=0.0), 1e-300))

    @property
    def modal_damping_ratio(self) -> np.ndarray:
        """``(Phi^T C Phi)_ii / (2 omega_i)``, shape (n,); 0 where ``omega_i = 0``."""
        om = np.sqrt(np.maximum(np.diag(self.modal_stiffness), 0.0))
        d = np.diag(self.modal_damping)
        return np.divide(d, 2 * om, out=np.zeros(om.shape), where=om > 0)

    def to_modal(self, x: np.ndarray) -> np.ndarray:
        """``q = Phi^T M x`` for ``x`` of shape (n,) or (n, k)."""
        return self.transform.T @ (self.mass @ x)

    def to_physical(self, q: np.ndarray) -> np.ndarray:
        """``x = Phi q``."""
        return self.transform @ q

    def modal_force(self, f: np.ndarray) -> np.ndarray:
        """``Phi^T f``."""
        return self.transform.T @ f


@dataclass(frozen=True)
class LinearSystem:
    """``M x'' + C x' + K x = f``: validated matrices with the analyses of this module.

    Parameters
    ----------
    M : array_like, shape (n, n)
        Symmetric positive definite.
    K : array_like, shape (n, n)
    C : array_like, shape (n, n), optional
        Zero if omitted.
    dof_names : sequence of str, optional
        Default ``x1 .. xn``.
    reference : int
        The dof that mode-shape ratios refer to (default the first).

    Raises
    ------
    ValueError
        Naming the field (``LinearSystem.M``, ...) and the problem.
    """

    M: np.ndarray
    K: np.ndarray
    C: np.ndarray | None = None
    dof_names: tuple = ()
    reference: int = 0

    def __post_init__(self):
        try:
            M = _matrix("M", self.M)
        except ValueError as exc:
            raise ValueError(f"LinearSystem.{exc}") from None
        n = M.shape[0]
        try:
            check_mass(M)
        except ValueError as exc:
            raise ValueError(f"LinearSystem.{exc}") from None
        try:
            K = _matrix("K", self.K, n)
            C = np.zeros((n, n)) if self.C is None else _matrix("C", self.C, n)
        except ValueError as exc:
            raise ValueError(f"LinearSystem.{exc}") from None
        names = tuple(self.dof_names) or tuple(f"x{i + 1}" for i in range(n))
        if len(names) != n or len(set(names)) != n:
            raise ValueError(f"LinearSystem.dof_names must be {n} distinct names, got {list(names)}")
        if isinstance(self.reference, bool) or not isinstance(self.reference, (int, np.integer)) \
                or not 0 <= self.reference < n:
            raise ValueError(f"LinearSystem.reference must be a dof index from 0 to {n - 1}, got {self.reference!r}")
        for k, v in (("M", M), ("K", K), ("C", C), ("dof_names", names)):
            object.__setattr__(self, k, v)

    @property
    def n(self) -> int:
        return self.M.shape[0]

    def natural_modes(self) -> NaturalModes:
        return natural_modes(self.M, self.K, self.reference)

    def damped_modes(self) -> DampedModes:
        return damped_modes(self.M, self.C, self.K, self.reference)

    def principal_coordinates(self) -> PrincipalCoordinates:
        return principal_coordinates(self.M, self.C, self.K, self.natural_modes())

    def force(self, dof) -> np.ndarray:
        """Unit force vector on ``dof`` (index or name), shape (n,)."""
        if isinstance(dof, str):
            if dof not in self.dof_names:
                raise ValueError(f"LinearSystem.force: unknown dof {dof!r}; expected one of {list(self.dof_names)}")
            j = self.dof_names.index(dof)
        else:
            j = int(dof)
            if not 0 <= j < self.n:
                raise ValueError(f"LinearSystem.force: dof index must be from 0 to {self.n - 1}, got {dof!r}")
        F = np.zeros(self.n)
        F[j] = 1.0
        return F

    def frf(self, w, force) -> np.ndarray:
        """``X(w)``, shape (len(w), n), for the force vector ``force`` (shape (n,)) or a dof name/index."""
        F = self.force(force) if isinstance(force, (str, int, np.integer)) else force
        return frf(self.M, self.C, self.K, w, F)


def natural_modes(M, K, reference: int = 0) -> NaturalModes:
    """Undamped natural frequencies and mass-normalised modes (seed 002, sec. 2.2).

    Parameters
    ----------
    M : array_like, shape (n, n)
        Symmetric positive definite.
    K : array_like, shape (n, n)
        Symmetric: ``scipy.linalg.eigh(K, M)``; otherwise (a tangent stiffness
        of a non-conservative force) the general pencil, keeping the real part
        of the eigenvalues and modes (``Phi^T M Phi = I`` then holds on the
        diagonal only).
    reference : int
        Dof that fixes each mode's sign and that ratios refer to.

    Returns
    -------
    NaturalModes
    """
    M = _matrix("M", M)
    K = _matrix("K", K, M.shape[0])
    check_mass(M)
    if _is_symmetric(K, 1e-10):
        Ks = 0.5 * (K + K.T)
        w2, V = scipy.linalg.eigh(Ks, 0.5 * (M + M.T))  # eigh already returns V^T M V = I
        sym = True
    else:
        lam, V = scipy.linalg.eig(K, M)
        order = np.argsort(lam.real)
        # real eigenvalues have real modes up to a complex factor: remove it, keep the real part
        w2, V = lam.real[order], _sign_fix(V[:, order], reference).real
        V = V / np.sqrt(np.abs(np.einsum("ji,jk,ki->i", V, M, V)))
        sym = False
    V = _sign_fix(V, reference).real
    return NaturalModes(np.asarray(w2, dtype=float), V, int(reference), sym)


def damped_modes(M, C, K, reference: int = 0) -> DampedModes:
    """Eigenvalues and modes of ``(lambda^2 M + lambda C + K) B = 0`` (seed 002, sec. 3.2).

    Solved as the generalised eigenproblem of the first-order form (no
    inverse of ``M`` is formed)::

        [[0, I], [-K, -C]] [B; lambda B] = lambda [[I, 0], [0, M]] [B; lambda B]

    Parameters
    ----------
    M, C, K : array_like, shape (n, n)
    reference : int

    Returns
    -------
    DampedModes
    """
    M = _matrix("M", M)
    n = M.shape[0]
    C = _matrix("C", C, n)
    K = _matrix("K", K, n)
    I, Z = np.eye(n), np.zeros((n, n))
    A = np.block([[Z, I], [-K, -C]])
    B = np.block([[I, Z], [Z, M]])
    lam, Y = scipy.linalg.eig(A, B)
    if not np.all(np.isfinite(lam)):
        raise ValueError("damped_modes: infinite eigenvalues (M is singular)")
    # |lambda| ascending, then the positive-imaginary member of a pair first
    scale = max(np.max(np.abs(lam)), 1e-300)
    key = np.round(np.abs(lam) / scale, 10)
    order = np.lexsort((-lam.imag, key))
    lam, V = lam[order], Y[:n, order]
    V = _sign_fix(V, reference)
    # the reference component becomes exactly 1 (the seed's [1, r_i]), else the largest one
    for i in range(V.shape[1]):
        col = V[:, i]
        j = reference if abs(col[reference]) > 1e-9 * np.max(np.abs(col)) else int(np.argmax(np.abs(col)))
        V[:, i] = col / col[j]
        V[j, i] = 1.0  # exactly, not 1 - 1e-16 from the complex division
    return DampedModes(lam, V, int(reference))


def principal_coordinates(M, C, K, modes: NaturalModes | None = None) -> PrincipalCoordinates:
    """The principal-coordinate form of ``M x'' + C x' + K x = f`` (seed 002, sec. 2.3).

    Parameters
    ----------
    M, C, K : array_like, shape (n, n)
    modes : NaturalModes, optional
        From :func:`natural_modes` (computed if omitted).

    Returns
    -------
    PrincipalCoordinates
    """
    M = _matrix("M", M)
    n = M.shape[0]
    C = np.zeros((n, n)) if C is None else _matrix("C", C, n)
    K = _matrix("K", K, n)
    if modes is None:
        modes = natural_modes(M, K)
    P = modes.modes
    return PrincipalCoordinates(P, P.T @ M @ P, P.T @ K @ P, P.T @ C @ P, M)


def impedance(M, C, K, w) -> np.ndarray:
    """The impedance matrices ``Z(w) = K - w^2 M + i w C`` (seed 002, sec. 4.2).

    Parameters
    ----------
    M, C, K : ndarray, shape (n, n), or (nw, n, n) for matrices that vary with ``w``
    w : array_like, shape (nw,)

    Returns
    -------
    ndarray of complex, shape (nw, n, n)
    """
    w = np.atleast_1d(np.asarray(w, dtype=float))
    ws = w[:, None, None]
    return np.asarray(K) - ws**2 * np.asarray(M) + 1j * ws * np.asarray(C)


def _solve(Z: np.ndarray, rhs: np.ndarray, w: np.ndarray) -> np.ndarray:
    try:
        X = np.linalg.solve(Z, rhs)
    except np.linalg.LinAlgError:
        X = None
    if X is not None and np.all(np.isfinite(X)):
        return X
    # locate the singular frequencies (one at a time only on this rare path)
    bad = []
    for i in range(Z.shape[0]):
        try:
            xi = np.linalg.solve(Z[i], rhs[i])
            if not np.all(np.isfinite(xi)):
                bad.append(i)
        except np.linalg.LinAlgError:
            bad.append(i)
    raise SingularImpedance(bad, w)


def receptance(M, C, K, w) -> np.ndarray:
    """The receptance (dynamic flexibility) matrices ``H(w) = Z(w)^-1``, shape (nw, n, n).

    ``H[k, i, j]`` is the response of dof ``i`` to a unit force on dof ``j``.

    Raises
    ------
    SingularImpedance
        If ``Z`` is exactly singular at some frequencies.
    """
    w = np.atleast_1d(np.asarray(w, dtype=float))
    Z = impedance(M, C, K, w)
    n = Z.shape[-1]
    return _solve(Z, np.broadcast_to(np.eye(n, dtype=complex), Z.shape).copy(), w)


def frf(M, C, K, w, F) -> np.ndarray:
    """Complex amplitudes ``X(w) = Z(w)^-1 F`` for a harmonic force ``Re(F e^{iwt})``.

    Parameters
    ----------
    M, C, K : ndarray, shape (n, n) or (nw, n, n)
    w : array_like, shape (nw,)
    F : array_like, shape (n,) or (nw, n)
        Complex force amplitudes (real for ``F cos(w t)``).

    Returns
    -------
    ndarray of complex, shape (nw, n)
        ``|X|`` is the amplitude, ``angle(X)`` the phase relative to the force.

    Raises
    ------
    SingularImpedance
        If ``Z`` is exactly singular at some frequencies.
    """
    w = np.atleast_1d(np.asarray(w, dtype=float))
    Z = impedance(M, C, K, w)
    n = Z.shape[-1]
    F = np.broadcast_to(np.asarray(F, dtype=complex), (w.size, n))
    return _solve(Z, F[..., None].copy(), w)[..., 0]


def chain_matrices(masses, stiffnesses, dampings=None):
    """``M, C, K`` of a chain of masses between two walls (seed 002's model, for ``n`` masses).

    Spring ``k_1`` ties mass 1 to the left wall, ``k_i`` (``2 <= i <= n``)
    ties mass ``i-1`` to mass ``i``, and ``k_{n+1}`` ties mass ``n`` to the
    right wall (0 for a free end); dampers likewise.

    Parameters
    ----------
    masses : array_like, shape (n,)
    stiffnesses : array_like, shape (n+1,)
    dampings : array_like, shape (n+1,), optional

    Returns
    -------
    M, C, K : ndarray, shape (n, n)
    """
    m = np.asarray(masses, dtype=float)
    n = m.size
    k = np.asarray(stiffnesses, dtype=float)
    c = np.zeros(n + 1) if dampings is None else np.asarray(dampings, dtype=float)
    if k.shape != (n + 1,) or c.shape != (n + 1,):
        raise ValueError(f"chain_matrices: {n} masses need {n + 1} stiffnesses and dampings, "
                         f"got {k.size} and {c.size}")

    def assemble(e):
        A = np.zeros((n, n))
        for i in range(n + 1):
            left, right = i - 1, i  # element i joins mass i-1 (or the left wall) and mass i (or the right wall)
            if left >= 0:
                A[left, left] += e[i]
            if right < n:
                A[right, right] += e[i]
            if left >= 0 and right < n:
                A[left, right] -= e[i]
                A[right, left] -= e[i]
        return A

    return np.diag(m), assemble(c), assemble(k)
