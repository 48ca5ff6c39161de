"""The banded elimination of the condensation equals the dense one.

A chain of 40 masses (tridiagonal M, C, K) with a cubic spring on one mass:
the eliminated blocks are tridiagonal, so they are factored in band storage.
Truth: the same problem condensed with dense factors, and central finite
differences.
"""

import numpy as np
import pytest
from conftest import fd_jacobian

from contin.hb.condensation import CondensedHarmonicBalance, condense
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.model.base import Monomial, ParametricMatrix
from contin.model.catalog import build_model
from contin.model.elements.polynomial import PolynomialForce

N_MASSES = 40


def chain_problem(at: int, parameter: str, spring=None) -> HarmonicBalance:
    """The damped chain with ``2 x_at^3`` on mass ``at + 1``, its first mass forced.

    ``spring``: a pair of masses ``(i, j)`` joined by one more spring.
    """
    n = N_MASSES
    p = {f"c{i}": 0.02 for i in range(1, n + 2)}
    p.update({f"k{i}": 1.0 + 0.01 * i for i in range(1, n + 2)})
    p["w"] = 0.8
    model = build_model("linear_chain", p, n=n)
    ex = np.zeros(n, dtype=int)
    ex[at] = 3
    if spring is not None:
        A = np.zeros((n, n))
        A[np.ix_(spring, spring)] = [[1.0, -1.0], [-1.0, 1.0]]
        model.stiffness = ParametricMatrix(n, model.stiffness.terms + ((Monomial(0.1), A),))
    model.forces.append(PolynomialForce(n, [(at, Monomial(2.0), ex, np.zeros(n, dtype=int))], label="cubic"))
    return HarmonicBalance(model, parameter, HBOptions(harmonics=4))


def close(got, ref):
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-12 * np.abs(ref).max())


@pytest.mark.parametrize("at, parameter", [(N_MASSES - 1, "w"), (17, "k3")])
def test_banded_elimination_equals_the_dense_one(at, parameter, rng):
    hb = chain_problem(at, parameter)
    ch = condense(hb)
    dense = CondensedHarmonicBalance(hb, ch.dofs, banded=False)
    assert list(ch.dofs) == [at] and ch.band == (1, 1) and dense.band is None
    assert ch._at(0.9).LU.shape == (5, 4, N_MASSES - 1)
    assert ch.with_options(harmonics=3).band == (1, 1)
    lam = 0.9
    u, du = 0.3 * rng.normal(size=ch.size), rng.normal(size=ch.size)
    close(ch.expand(u, lam), dense.expand(u, lam))
    close(ch.residual(u, lam), dense.residual(u, lam))
    for a, b in zip(ch.linearize(u, lam), dense.linearize(u, lam)):
        close(a, b)
    for dlam in (0.0, 0.7):
        close(ch.expand_direction(u, lam, du, dlam), dense.expand_direction(u, lam, du, dlam))
    # the banded Jacobians against central differences
    R, Ju, Jlam = ch.linearize(u, lam)
    np.testing.assert_allclose(Ju, fd_jacobian(lambda v: ch.residual(v, lam), u), rtol=0,
                               atol=1e-7 * np.abs(Ju).max())
    h = 1e-6
    fd = (ch.residual(u, lam + h) - ch.residual(u, lam - h)) / (2 * h)
    np.testing.assert_allclose(Jlam, fd, rtol=0, atol=1e-7 * np.abs(Jlam).max())


def test_wide_eliminated_blocks_are_factored_densely():
    # a spring between the first and the last but one mass makes the eliminated block full-width
    hb = chain_problem(N_MASSES - 1, "w", spring=(0, N_MASSES - 2))
    ch = condense(hb)
    assert list(ch.dofs) == [N_MASSES - 1] and ch.band is None
    assert ch._at(0.9).LU.shape == (5, N_MASSES - 1, N_MASSES - 1)
