import numpy as np
import pytest

from contin.blas import limit_blas_threads

limit_blas_threads(1)


@pytest.fixture
def rng():
    return np.random.default_rng(12345)


def fd_jacobian(fun, x, eps=1e-7):
    """Central finite differences of ``fun`` at ``x`` (columns = d/dx_j)."""
    x = np.asarray(x, dtype=float)
    cols = []
    for j in range(x.size):
        e = np.zeros_like(x)
        e[j] = eps * max(1.0, abs(x[j]))
        cols.append((fun(x + e) - fun(x - e)) / (2 * e[j]))
    return np.column_stack(cols)
