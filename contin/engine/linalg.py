"""Dense LU factorisations of the engine's Jacobians: row-equilibrated, with a condition estimate.

:func:`factorize` scales each row by the inverse of its largest entry (in
one compiled pass), factorises with LAPACK ``getrf`` and returns an
:class:`LUFactor`, which solves, gives the sign of the determinant (the
branch-point test) and estimates the condition (``gecon``) on demand.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy.linalg.lapack import get_lapack_funcs

from contin.util.jit import njit

__all__ = ["LUFactor", "SingularMatrixError", "factorize"]

_GETRF, _GECON, _GETRS = get_lapack_funcs(("getrf", "gecon", "getrs"), (np.empty((1, 1)),))


@njit(cache=True)
def _equilibrated_copy(a, equilibrate, work, row_scale):
    """Row-scale ``a`` into the Fortran-ordered ``work`` in one compiled pass.

    Returns ``(status, anorm)``: status 0 on success, -1 for a non-finite
    entry, ``i + 1`` for a zero row ``i`` (with ``equilibrate``); ``anorm`` is
    the 1-norm of the scaled matrix. One pass instead of the half dozen numpy
    sweeps (and their temporaries) that dominate the factorisation of small
    Jacobians.
    """
    n = a.shape[0]
    finite = True
    zero_row = -1
    colsum = np.zeros(n)
    # one sweep, row by row: the row's maximum, then its scaled copy while it is in cache. Rows are
    # read contiguously and the Fortran-ordered columns written with a stride, measured faster than
    # tiling or than numpy's multiply into the same array at orders 85 to 645.
    for i in range(n):
        m = 0.0
        for j in range(n):
            v = abs(a[i, j])
            if not v <= 1.7976931348623157e308:  # NaN or inf
                finite = False
            elif v > m:
                m = v
        s = 1.0
        if equilibrate:
            if m == 0.0:
                if zero_row < 0:
                    zero_row = i
            else:
                s = 1.0 / m
        row_scale[i] = s
        for j in range(n):
            w = a[i, j] * s
            work[i, j] = w
            colsum[j] += abs(w)
    if not finite:
        return -1, 0.0  # reported before a zero row, as the numpy version did
    if zero_row >= 0:
        return zero_row + 1, 0.0
    anorm = 0.0
    for j in range(n):
        if colsum[j] > anorm:
            anorm = colsum[j]
    return 0, anorm


class SingularMatrixError(np.linalg.LinAlgError):
    """Raised by :func:`factorize` for a matrix that cannot be factorised."""


@dataclasses.dataclass(frozen=True, eq=False)
class LUFactor:
    """LU factorisation of a row-equilibrated square matrix.

    The factorised matrix is ``diag(row_scale) @ A`` (positive row scaling
    changes neither the solution of ``A x = b`` nor the sign of ``det A``, but
    makes the condition estimate meaningful for rows of different units).

    Attributes
    ----------
    lu, piv : ndarray, shapes (n, n) and (n,)
        LAPACK ``getrf`` output (the same as :func:`scipy.linalg.lu_factor`).
    row_scale : ndarray, shape (n,)
        Positive row scaling applied before factorising.
    anorm : float
        1-norm of ``diag(row_scale) @ A`` (for the condition estimate).
    rcond : float
        LAPACK ``gecon`` estimate of the reciprocal 1-norm condition number of
        ``diag(row_scale) @ A``, computed on first access: a Newton
        iteration reads it only for the last factorisation, and each estimate
        costs several triangular solves.
    """

    lu: np.ndarray
    piv: np.ndarray
    row_scale: np.ndarray
    anorm: float = float("nan")
    _rcond: float | None = dataclasses.field(default=None, repr=False)

    @property
    def rcond(self) -> float:
        if self._rcond is None:
            if self.lu.shape[0] == 0:
                value = float("inf")
            else:
                value, _ = _GECON(self.lu, self.anorm, norm="1")
            object.__setattr__(self, "_rcond", float(value))  # a cache on a frozen record
        return self._rcond

    @property
    def n(self) -> int:
        """Order of the matrix."""
        return self.lu.shape[0]

    def solve(self, b: np.ndarray) -> np.ndarray:
        """Solve ``A x = b``; ``b`` has shape (n,) or (n, k)."""
        b = np.asarray(b, dtype=float)
        if b.shape[:1] != (self.lu.shape[0],) or b.ndim > 2:
            raise ValueError(f"LUFactor.solve: right-hand side of shape {b.shape} for a matrix of order {self.n}")
        rb = self.row_scale * b if b.ndim == 1 else self.row_scale[:, None] * b
        if rb.size == 0:
            return rb
        # LAPACK getrs directly: scipy.linalg.lu_solve adds checks and copies that cost as much as
        # the solve itself for the small systems of low harmonic counts
        x, info = _GETRS(self.lu, self.piv, rb, overwrite_b=True)
        if info != 0:  # pragma: no cover - invalid argument, cannot happen here
            raise ValueError(f"LAPACK getrs failed (info={info})")
        return x

    @property
    def det_sign(self) -> int:
        """Sign of ``det A`` (+1 or -1), without forming the determinant.

        Product of the signs of ``diag(U)`` times the parity of the row
        interchanges; immune to overflow.
        """
        d = np.diagonal(self.lu)
        negatives = int(np.count_nonzero(d < 0))
        swaps = int(np.count_nonzero(self.piv != np.arange(self.piv.size)))
        return -1 if (negatives + swaps) % 2 else 1

    @property
    def log_abs_det(self) -> float:
        """``log|det A|`` (the row scaling is undone)."""
        return float(np.sum(np.log(np.abs(np.diagonal(self.lu)))) - np.sum(np.log(self.row_scale)))


def factorize(a: np.ndarray, *, equilibrate: bool = True) -> LUFactor:
    """LU-factorise a square matrix and estimate its condition.

    Parameters
    ----------
    a : ndarray, shape (n, n)
        Real matrix; it is not modified.
    equilibrate : bool
        Scale each row by the inverse of its largest absolute entry first.

    Returns
    -------
    LUFactor

    Raises
    ------
    SingularMatrixError
        Non-finite entries, a zero row, or an exactly zero pivot.
    """
    a = np.asarray(a, dtype=float)
    if a.ndim != 2 or a.shape[0] != a.shape[1]:
        raise ValueError(f"factorize expects a square matrix, got shape {a.shape}")
    n = a.shape[0]
    if n == 0:
        return LUFactor(lu=np.zeros((0, 0), order="F"), piv=np.zeros(0, dtype=np.int32), row_scale=np.ones(0),
                        anorm=0.0)
    # getrf works in place on a Fortran-ordered array; handed a C-ordered one, f2py makes a
    # transposed copy that cost as much as the factorisation itself for orders of a few hundred
    work = np.empty((n, n), order="F")
    row_scale = np.empty(n)
    status, anorm = _equilibrated_copy(np.ascontiguousarray(a), bool(equilibrate), work, row_scale)
    if status < 0:
        raise SingularMatrixError("non-finite entries in the matrix")
    if status > 0:
        raise SingularMatrixError(f"zero row {status - 1}")
    lu, piv, info = _GETRF(work, overwrite_a=True)
    if info > 0:
        raise SingularMatrixError(f"zero pivot in column {info - 1}")
    if info < 0:  # pragma: no cover - invalid argument, cannot happen here
        raise SingularMatrixError(f"LAPACK getrf failed (info={info})")
    return LUFactor(lu=lu, piv=piv, row_scale=row_scale, anorm=anorm)

