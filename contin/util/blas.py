"""Threads of the BLAS/LAPACK library behind numpy and scipy.

contin's matrices (Jacobians of ``n(2H+1)`` rows, Hill matrices of twice that)
are small to moderate. For such sizes a multithreaded OpenBLAS spends more
time synchronising than computing: on a 2-core machine an eigenvalue
decomposition of a 98x98 matrix measured 42 ms with two threads against
3.6 ms with one. The command line therefore runs with one BLAS thread unless
``CONTIN_BLAS_THREADS`` says otherwise; library users call
:func:`limit_blas_threads` themselves if they want the same.
"""

from __future__ import annotations

__all__ = ["limit_blas_threads"]

_limiter = None


def limit_blas_threads(threads: int | None = None):
    """Limit BLAS threads for the rest of the process (``threadpoolctl``).

    Parameters
    ----------
    threads : int, optional
        Default: ``$CONTIN_BLAS_THREADS`` or 1.
    """
    global _limiter
    import numpy.linalg  # noqa: F401  (load both BLAS libraries first: limits apply to loaded ones)
    import scipy.linalg  # noqa: F401
    from threadpoolctl import threadpool_limits

    if threads is None:
        from contin.util.options import environment_count  # deferred: numpy (its names), not for --help

        threads = environment_count("CONTIN_BLAS_THREADS", 1)
    _limiter = threadpool_limits(limits=threads, user_api="blas")
    return _limiter
