import numpy as np
from scipy.special import mathieu_a, mathieu_b
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


def mathieu_boundaries(eps, rmax):
    """Transition curves delta = a_r(q)/4, b_r(q)/4, q = 2 eps (Abramowitz & Stegun 20.1).

    x'' + (delta + eps cos t) x = 0 with t = 2z is y'' + (4 delta + 4 eps cos 2z) y = 0,
    Mathieu's equation with a = 4 delta, q = -2 eps; the set of curves {a_r, b_r} is
    the same for q and -q. Even r: 2 pi-periodic solutions (multiplier +1), odd r:
    4 pi-periodic (multiplier -1).
    """
    q = 2 * eps
    out = [(mathieu_a(0, q) / 4, 0)]
    for r in range(1, rmax + 1):
        out += [(mathieu_b(r, q) / 4, r), (mathieu_a(r, q) / 4, r)]
    return sorted(out)
