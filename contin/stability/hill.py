"""Floquet exponents of a harmonic-balance solution by Hill's method.

A perturbation ``e^{s t} y(theta)`` of a periodic solution, with ``y``
expanded on the harmonics of the base phase ``theta = Omega t``
(``Omega = w/nu``), satisfies Hill's quadratic eigenproblem

    (Delta0 + s Delta1 + s^2 Delta2) q = 0,          q of shape (m,), m = n(2H+1),

(:meth:`contin.hb.problem.HarmonicBalance.hill_matrices`). It is
linearised to a first-order problem of size ``2m`` (companion form)

    [ 0       I      ] [ q ]       [ I   0      ] [ q ]
    [ -Delta0 -Delta1 ] [ sq ] = s [ 0   Delta2 ] [ sq ],

reduced to a standard eigenproblem when ``Delta2 = I (x) M`` is invertible.

Selection of the physical exponents
-----------------------------------
The infinite Hill problem has ``2n`` classes of exponents ``s + i k Omega``
(``k`` integer), all describing the same perturbation and the same
multiplier ``exp(s T)``, ``T = 2 pi / Omega``: the eigenvector of
``s + i k Omega`` is that of ``s`` shifted by ``-k`` harmonics. The
truncation keeps ``2H+1`` members of each class, accurate near the centre
and wrong near the truncation edge. Following the symmetry criterion of
Lazarus & Thomas (C. R. Mecanique 338 (2010) 510-517) and Guillot, Lazarus,
Thomas, Vergez & Cochelin (J. Comput. Phys. 416 (2020) 109477), the member
whose eigenvector is centred on harmonic 0 is selected. The centring is
measured by the harmonic *centroid*

    c = sum_l l E_l / sum_l E_l,      E_l = sum_dof |c_l|^2,  l = -H..H,

of the eigenvector written on complex exponentials ``e^{i l theta}``
(``c_{+-k} = (a_k -+ i b_k)/2``). A shift by ``k`` harmonics moves ``c`` by
exactly ``-k`` in the infinite problem, so each class has exactly one member
with ``c`` in ``(-1/2, 1/2]``. Selecting by ``|c|`` rather than by the
smallest ``|Im s|`` is what makes multipliers near -1 (period doubling)
reliable: there ``Im s = +-Omega/2`` and the two members of a class are
equally small in ``|Im s|``; they have ``c = -+1/2`` and are recognised as
shifts of each other (exponents differing by ``i k Omega`` *and* centroids
by ``-k``), so exactly one of them is kept.

The quality of the selection is the gap, in centroid units, between the
least-centred selected eigenvector and the best-centred remaining
eigenvector that is not a recognised shift of a selected one (clipped to 1):
close to 0 means two candidates competed for the last place.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import scipy.linalg

__all__ = [
    "HillSpectrum",
    "companion_eigen",
    "harmonic_centroids",
    "select_exponents",
    "hill_spectrum",
]


@dataclasses.dataclass(frozen=True, eq=False)
class HillSpectrum:
    """Eigen-decomposition of Hill's problem and the selected exponents.

    Attributes
    ----------
    eigenvalues : ndarray, shape (K,) complex
        All finite eigenvalues ``s`` (``K = 2m`` when ``M`` is invertible).
    centroids : ndarray, shape (K,)
        Harmonic centroid of each eigenvector.
    selected : ndarray of int, shape (2n,)
        Indices of the selected (physical) exponents (``2 rank(M)`` of them
        when the mass matrix is singular).
    exponents : ndarray, shape (2n,) complex
        ``eigenvalues[selected]``.
    multipliers : ndarray, shape (2n,) complex
        ``exp(exponents * period)``.
    vectors : ndarray, shape (m, 2n) complex, or None
        Coefficient-space eigenvectors ``q`` of the selected exponents (unit
        2-norm), if requested.
    quality : float
        Selection gap in ``[0, 1]`` (see the module docstring).
    period : float
        ``T = 2 pi / Omega``.
    Omega : float
        Base frequency ``w/nu``.
    """

    eigenvalues: np.ndarray
    centroids: np.ndarray
    selected: np.ndarray
    exponents: np.ndarray
    multipliers: np.ndarray
    vectors: np.ndarray | None
    quality: float
    period: float
    Omega: float


def companion_eigen(D0: np.ndarray, D1: np.ndarray, D2: np.ndarray, vectors: bool = True, mass: np.ndarray | None = None):
    """Eigenpairs of ``(D0 + s D1 + s^2 D2) q = 0`` by linearisation.

    Parameters
    ----------
    D0, D1, D2 : ndarray, shape (m, m)
    vectors : bool
        Also return the ``q`` parts of the eigenvectors.
    mass : ndarray, shape (n, n), optional
        If given, ``D2 = I (x) mass`` is assumed, and ``D2^-1`` is applied
        block by block.

    Returns
    -------
    s : ndarray, shape (K,) complex
        Finite eigenvalues (``K = 2m`` if ``D2`` is invertible; infinite
        eigenvalues of a singular ``D2`` are dropped).
    Q : ndarray, shape (m, K) complex, or None
        ``q`` of each eigenpair, unit 2-norm.
    """
    m = D0.shape[0]
    I = np.eye(m)
    Z = np.zeros((m, m))
    G0 = G1 = None
    if mass is not None:
        sv = np.linalg.svd(mass, compute_uv=False)
        # a tiny singular value means a massless dof: keep the generalized form
        if sv.size and sv[-1] > 1e-12 * sv[0]:
            Minv = np.linalg.inv(mass)
            n = mass.shape[0]
            G0 = np.einsum("ab,kbj->kaj", Minv, D0.reshape(-1, n, m)).reshape(m, m)
            G1 = np.einsum("ab,kbj->kaj", Minv, D1.reshape(-1, n, m)).reshape(m, m)
    else:
        sv = np.linalg.svd(D2, compute_uv=False)
        if sv.size and sv[-1] > 1e-12 * sv[0]:
            G = np.linalg.solve(D2, np.hstack([D0, D1]))
            G0, G1 = G[:, :m], G[:, m:]
    if G0 is not None:
        A = np.block([[Z, I], [-G0, -G1]])
        if vectors:
            s, V = np.linalg.eig(A)
        else:
            s, V = np.linalg.eigvals(A), None
    else:
        A = np.block([[Z, I], [-D0, -D1]])
        B = np.block([[I, Z], [Z, D2]])
        if vectors:
            s, V = scipy.linalg.eig(A, B, check_finite=False)
        else:
            s, V = scipy.linalg.eig(A, B, right=False, check_finite=False), None
        keep = np.isfinite(s)
        s = s[keep]
        V = V[:, keep] if V is not None else None
    if V is None:
        return s, None
    Q = V[:m]
    norms = np.linalg.norm(Q, axis=0)
    norms[norms == 0] = 1.0
    return s, Q / norms


def harmonic_centroids(Q: np.ndarray, n: int) -> np.ndarray:
    """Harmonic centroid of each column of ``Q`` (coefficient space).

    Parameters
    ----------
    Q : ndarray, shape (n(2H+1), K) complex
    n : int
        Degrees of freedom.

    Returns
    -------
    ndarray, shape (K,)
        ``sum_l l E_l / sum_l E_l`` over complex harmonics ``l = -H..H``.
    """
    K = Q.shape[1]
    B = Q.reshape(-1, n, K)  # (2H+1, n, K)
    H = (B.shape[0] - 1) // 2
    a = B[1::2]
    b = B[2::2]
    Ep = 0.25 * np.sum(np.abs(a - 1j * b) ** 2, axis=1)  # (H, K), harmonic +k
    Em = 0.25 * np.sum(np.abs(a + 1j * b) ** 2, axis=1)  # harmonic -k
    E0 = np.sum(np.abs(B[0]) ** 2, axis=0)
    k = np.arange(1, H + 1)[:, None]
    total = E0 + Ep.sum(axis=0) + Em.sum(axis=0)
    total[total == 0] = 1.0
    return (k * (Ep - Em)).sum(axis=0) / total


def select_exponents(
    s: np.ndarray,
    centroids: np.ndarray,
    Omega: float,
    count: int,
    shift_tol: float = 1e-4,
    centroid_tol: float = 0.25,
):
    """Pick one exponent per class, the best-centred one.

    Candidates are taken by increasing ``|centroid|``; a candidate is skipped
    when it is a shift of an already selected exponent: ``s_j - s_i`` within
    ``shift_tol * Omega`` of ``i k Omega`` for some integer ``k != 0`` *and*
    ``c_j - (c_i - k)`` within ``centroid_tol``. (The second condition keeps
    genuinely different classes that happen to differ by ``i k Omega``, e.g.
    internal resonances.)

    Parameters
    ----------
    s : ndarray, shape (K,) complex
    centroids : ndarray, shape (K,)
    Omega : float
    count : int
        Number of exponents to select (``2n``).
    shift_tol, centroid_tol : float

    Returns
    -------
    selected : ndarray of int, shape (count,) (fewer if not enough candidates)
    quality : float
        Selection gap in ``[0, 1]``.
    """
    d = np.abs(centroids)
    order = np.lexsort((np.abs(s.imag), d))
    selected: list[int] = []
    d_next = np.inf
    for j in order:
        shift = False
        for i in selected:
            k = np.rint((s[j].imag - s[i].imag) / Omega)
            if k == 0:
                continue
            if abs(s[j] - s[i] - 1j * k * Omega) <= shift_tol * Omega and abs(centroids[j] - (centroids[i] - k)) <= centroid_tol:
                shift = True
                break
        if shift:
            continue
        if len(selected) < count:
            selected.append(int(j))
        else:
            d_next = d[j]
            break
    d_sel = float(d[selected].max()) if selected else np.inf
    quality = float(np.clip(d_next - d_sel, 0.0, 1.0)) if np.isfinite(d_sel) else 0.0
    return np.array(selected, dtype=int), quality


def hill_spectrum(
    hb,
    u: np.ndarray,
    lam: float,
    *,
    vectors: bool = False,
    shift_tol: float = 1e-4,
    centroid_tol: float = 0.25,
    matrices=None,
) -> HillSpectrum:
    """Floquet exponents and multipliers of a solution by Hill's method.

    Parameters
    ----------
    hb : HarmonicBalance
    u : ndarray, shape (hb.size,)
        A solution ``R(u, lam) = 0``.
    lam : float
    vectors : bool
        Keep the selected eigenvectors (coefficient space).
    shift_tol, centroid_tol : float
        See :func:`select_exponents`.
    matrices : tuple of ndarray, optional
        ``(Delta0, Delta1, Delta2)`` if already computed.

    Returns
    -------
    HillSpectrum
    """
    if hb.condensed:  # Hill's method needs every dof
        u, hb = hb.expand(u, lam), hb.full
    D0, D1, D2 = hb.hill_matrices(u, lam) if matrices is None else matrices
    p = hb.params_at(lam)
    Omega = hb.base_frequency(p)
    if not Omega > 0:
        raise ValueError(f"Hill's method needs a positive excitation frequency, got w/nu = {Omega}")
    period = hb.period(p)
    mass = hb.model.linear(p)[0]
    s, Q = companion_eigen(D0, D1, D2, vectors=True, mass=mass)
    c = harmonic_centroids(Q, hb.n)
    # a massless dof has no dynamics of its own: 2 rank(M) exponents per class set
    count = 2 * int(np.linalg.matrix_rank(mass))
    sel, quality = select_exponents(s, c, Omega, count, shift_tol, centroid_tol)
    ex = s[sel]
    mult = np.exp(ex * period)
    return HillSpectrum(
        eigenvalues=s,
        centroids=c,
        selected=sel,
        exponents=ex,
        multipliers=mult,
        vectors=Q[:, sel].copy() if vectors else None,
        quality=quality,
        period=period,
        Omega=Omega,
    )
