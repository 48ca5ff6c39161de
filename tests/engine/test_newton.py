"""Tests of contin.engine.newton on small analytic problems."""

import numpy as np
import pytest

from contin.engine.newton import (
    LUFactor,
    NewtonResult,
    SingularMatrixError,
    factorize,
    newton,
    solve_at_parameter,
)


def sqrt2(x):
    return np.array([x[0] ** 2 - 2.0]), np.array([[2.0 * x[0]]])


def test_quadratic_convergence():
    res = newton(sqrt2, [1.0], tol=1e-14, max_iter=20)
    assert isinstance(res, NewtonResult)
    assert res.converged
    assert res.x[0] == pytest.approx(np.sqrt(2.0), abs=1e-15)
    hist = np.array(res.residual_history)
    assert hist[0] == pytest.approx(1.0)
    assert len(hist) == res.iterations + 1
    assert res.residual_norm == hist[-1] <= 1e-14
    # quadratic: r_{k+1} <= C r_k^2 with a modest C once in the basin
    ratios = hist[2:] / hist[1:-1] ** 2
    assert np.all(ratios[:-1] < 1.0)
    assert res.iterations <= 6
    assert "converged" in res.message


def test_already_converged_needs_no_iteration():
    res = newton(sqrt2, [np.sqrt(2.0)], tol=1e-12)
    assert res.converged and res.iterations == 0


def test_system_and_factor_final(rng):
    A = rng.standard_normal((5, 5)) + 5 * np.eye(5)
    b = rng.standard_normal(5)

    def f(x):
        return A @ x + 0.1 * x**3 - b, A + np.diag(0.3 * x**2)

    res = newton(f, np.zeros(5), tol=1e-12, factor_final=True)
    assert res.converged
    np.testing.assert_allclose(A @ res.x + 0.1 * res.x**3, b, atol=1e-12)
    assert res.lu is not None and 0 < res.rcond <= 1
    # the final factorisation is that of the Jacobian at the solution
    J = A + np.diag(0.3 * res.x**2)
    rhs = rng.standard_normal(5)
    np.testing.assert_allclose(J @ res.lu.solve(rhs), rhs, atol=1e-12)


def test_singular_jacobian_is_reported():
    def f(x):
        return np.array([x[0] + x[1] - 1.0, x[0] + x[1] - 2.0]), np.array([[1.0, 1.0], [1.0, 1.0]])

    res = newton(f, [0.0, 0.0])
    assert not res.converged
    assert res.singular
    assert "singular Jacobian" in res.message


def test_zero_jacobian_row_is_singular():
    res = newton(lambda x: (np.array([x[0] ** 2 + 1.0]), np.array([[2 * x[0]]])), [0.0])
    assert not res.converged and "singular Jacobian" in res.message


def test_no_convergence_message_and_best_iterate():
    # x^2 + 1 has no real root: Newton wanders
    res = newton(lambda x: (np.array([x[0] ** 2 + 1.0]), np.array([[2 * x[0]]])), [0.7], max_iter=8)
    assert not res.converged
    assert np.isfinite(res.x).all()
    assert res.residual_norm == pytest.approx(min(res.residual_history))
    assert "after" in res.message or "singular" in res.message or "diverg" in res.message


def test_non_finite_residual():
    def f(x):
        r = np.log(x)  # x becomes negative after the first step
        return r, np.diag(1.0 / x)

    with np.errstate(invalid="ignore"):
        res = newton(f, [50.0])
    assert not res.converged
    assert "non-finite residual" in res.message
    assert np.isfinite(res.x).all()


def test_numerical_exception_is_a_failure_not_a_crash():
    def f(x):
        if x[0] < 0.5:
            raise ZeroDivisionError("boom")
        return np.array([x[0] - 0.2]), np.array([[1.0]])

    res = newton(f, [1.0])
    assert not res.converged
    assert "ZeroDivisionError" in res.message


def test_divergence_detection():
    # cube root: every Newton step doubles |x| and flips its sign
    def f(x):
        return np.cbrt(x), np.diag(1.0 / (3.0 * np.cbrt(x) ** 2))

    res = newton(f, [1.0], max_iter=50, divergence_factor=10.0)
    assert not res.converged
    assert "diverging" in res.message


def test_xtol_is_an_additional_requirement():
    # with a huge tolerance the residual test passes at once; xtol forces updates
    res = newton(sqrt2, [1.0], tol=10.0, xtol=1e-12)
    assert res.converged and res.iterations == 0  # no update made yet
    res = newton(sqrt2, [1.0], tol=1e-3, xtol=1e-12)
    assert res.converged
    assert res.x[0] == pytest.approx(np.sqrt(2), abs=1e-12)


def test_factorize_det_sign_and_rcond(rng):
    for n in (1, 3, 10):
        A = rng.standard_normal((n, n))
        lu = factorize(A)
        assert lu.det_sign == np.sign(np.linalg.det(A))
        exact = 1.0 / np.linalg.cond(np.diag(1 / np.abs(A).max(1)) @ A, 1)
        # gecon underestimates ||A^-1||: the estimate is an upper bound of rcond
        assert exact * (1 - 1e-10) <= lu.rcond <= 10 * exact
        x = lu.solve(np.ones(n))
        np.testing.assert_allclose(A @ x, np.ones(n), atol=1e-10)


def test_factorize_sign_without_overflow(rng):
    A = 1e3 * rng.standard_normal((300, 300))
    with np.errstate(over="ignore"):
        assert not np.isfinite(np.linalg.det(A))
    sign, _ = np.linalg.slogdet(A)
    assert factorize(A).det_sign == sign


def test_factorize_rejects_singular_and_non_finite():
    with pytest.raises(SingularMatrixError, match="zero pivot"):
        factorize(np.array([[1.0, 2.0], [2.0, 4.0]]))
    with pytest.raises(SingularMatrixError, match="zero row"):
        factorize(np.array([[1.0, 2.0], [0.0, 0.0]]))
    with pytest.raises(SingularMatrixError, match="non-finite"):
        factorize(np.array([[np.nan, 2.0], [0.0, 1.0]]))


class Cubic:
    """R = u^3 - u - lam."""

    def residual(self, u, lam):
        return np.array([u[0] ** 3 - u[0] - lam])

    def linearize(self, u, lam):
        return self.residual(u, lam), np.array([[3 * u[0] ** 2 - 1]]), np.array([-1.0])


def test_solve_at_parameter():
    res = solve_at_parameter(Cubic(), np.array([2.0]), 1.0)
    assert res.converged
    assert res.x[0] ** 3 - res.x[0] - 1.0 == pytest.approx(0.0, abs=1e-10)

    class Opts:
        newton_tol = 1e-14
        newton_max_iter = 1

    res = solve_at_parameter(Cubic(), np.array([2.0]), 1.0, Opts())
    assert not res.converged and res.iterations == 1
    assert "after 1 iterations" in res.message


def test_chord_step_reuses_the_factorisation_only_where_it_converges(rng):
    A = rng.standard_normal((6, 6)) + 6 * np.eye(6)
    b = rng.standard_normal(6)

    def f(x):
        return A @ x + 0.05 * x**3 - b, A + np.diag(0.15 * x**2)

    full = newton(f, np.zeros(6), tol=1e-12, factor_final=True, reuse_lu=False)
    reuse = newton(f, np.zeros(6), tol=1e-12, factor_final=True)
    assert full.converged and reuse.converged
    # same number of updates, one factorisation fewer, the same solution to the tolerance
    assert reuse.iterations == full.iterations
    assert reuse.factorizations == full.factorizations - 1
    np.testing.assert_allclose(reuse.x, full.x, atol=1e-12)
    # the final factorisation is still that of the Jacobian at the solution
    J = A + np.diag(0.15 * reuse.x**2)
    rhs = rng.standard_normal(6)
    np.testing.assert_allclose(J @ reuse.lu.solve(rhs), rhs, atol=1e-12)


def test_slow_contraction_keeps_full_newton():
    # a double root: linear convergence, the chord step is never predicted to finish
    def f(x):
        return np.array([(x[0] - 1.0) ** 2]), np.array([[2.0 * (x[0] - 1.0)]])

    a = newton(f, [2.0], tol=1e-10, max_iter=60, reuse_lu=False)
    b = newton(f, [2.0], tol=1e-10, max_iter=60)
    assert a.converged and b.converged
    assert a.iterations == b.iterations and a.factorizations == b.factorizations


def test_a_given_factorisation_saves_the_first_one_and_a_poor_one_costs_no_convergence(rng):
    A = rng.standard_normal((6, 6)) + 6 * np.eye(6)
    b = rng.standard_normal(6)

    def f(x):
        return A @ x + 0.05 * x**3 - b, A + np.diag(0.15 * x**2)

    full = newton(f, np.zeros(6), tol=1e-12, factor_final=True, reuse_lu=False)
    x_near = full.x + 1e-4 * rng.standard_normal(6)
    near = factorize(f(full.x)[1])  # the Jacobian at a nearby point, as a previous continuation point gives
    ref = newton(f, x_near, tol=1e-12, factor_final=True, reuse_lu=False)
    res = newton(f, x_near, tol=1e-12, factor_final=True, lu0=near)
    assert res.converged and ref.converged
    assert res.factorizations < ref.factorizations
    np.testing.assert_allclose(res.x, ref.x, atol=1e-12)
    # a factorisation of an unrelated matrix: the step is undone and Newton converges as without it
    bad = factorize(-np.eye(6))
    res = newton(f, np.zeros(6), tol=1e-12, factor_final=True, lu0=bad)
    assert res.converged and res.iterations == full.iterations
    np.testing.assert_allclose(res.x, full.x, atol=1e-12)


def test_a_given_factorisation_whose_update_is_not_finite_is_dropped():
    """A caller's factorisation giving a non-finite update costs nothing: the first update factorises here."""
    zero = LUFactor(lu=np.zeros((1, 1), order="F"), piv=np.array([1], dtype=np.int32), row_scale=np.ones(1),
                    anorm=1.0)
    plain = newton(sqrt2, [1.0], tol=1e-14, max_iter=20)
    given = newton(sqrt2, [1.0], tol=1e-14, max_iter=20, lu0=zero)
    assert given.converged and given.iterations == plain.iterations
    assert given.factorizations == plain.factorizations
    np.testing.assert_array_equal(given.x, plain.x)


class Counted:
    """``A x + 0.05 x^3 = b`` with the evaluations of the residual alone and of residual and Jacobian counted."""

    def __init__(self, rng, n=6):
        self.A = rng.standard_normal((n, n)) + n * np.eye(n)
        self.b = rng.standard_normal(n)
        self.residuals = self.jacobians = 0

    def residual(self, x):
        self.residuals += 1
        return self.A @ x + 0.05 * x**3 - self.b

    def fun_and_jac(self, x):
        self.jacobians += 1
        return self.A @ x + 0.05 * x**3 - self.b, self.A + np.diag(0.15 * x**2)


def test_a_lazy_jacobian_is_evaluated_at_the_solution_only_when_a_nearby_one_suffices(rng):
    f = Counted(rng)
    full = newton(f.fun_and_jac, np.zeros(6), tol=1e-12, factor_final=True, reuse_lu=False)
    x_near = full.x + 1e-4 * rng.standard_normal(6)
    near = factorize(f.fun_and_jac(full.x + 1e-3)[1])  # a neighbour's Jacobian, as the previous point gives
    f.residuals = f.jacobians = 0
    res = newton(f.fun_and_jac, x_near, tol=1e-12, factor_final=True, lu0=near, residual=f.residual)
    assert res.converged and res.iterations >= 2
    np.testing.assert_allclose(res.x, full.x, atol=1e-12)
    # the chord steps used the residual alone; one Jacobian, at the solution, which the result carries
    assert f.jacobians == res.jacobians == 1 and f.residuals == res.iterations + 1
    assert res.chord_steps == res.iterations
    np.testing.assert_allclose(res.jacobian, f.fun_and_jac(res.x)[1], rtol=1e-14)
    rhs = rng.standard_normal(6)
    np.testing.assert_allclose(res.jacobian @ res.lu.solve(rhs), rhs, atol=1e-12)


def test_a_lazy_jacobian_without_a_factorisation_starts_with_one_and_refactorises_on_slow_contraction(rng):
    f = Counted(rng)
    res = newton(f.fun_and_jac, np.zeros(6), tol=1e-12, residual=f.residual)
    assert res.converged and f.jacobians == res.jacobians >= 2  # at the guess and at the solution
    eager = Counted(rng)
    eager.A, eager.b = f.A, f.b
    ref = newton(eager.fun_and_jac, np.zeros(6), tol=1e-12)
    assert res.jacobians < ref.jacobians
    np.testing.assert_allclose(res.x, ref.x, atol=1e-12)

    # a double root: Newton's linear convergence (residual / 4 per update); the lazy iteration
    # alternates chord steps and factorisations: more updates, fewer Jacobians, the same root
    def g(x):
        return np.array([(x[0] - 1.0) ** 2]), np.array([[2.0 * (x[0] - 1.0)]])

    a = newton(g, [2.0], tol=1e-10, max_iter=60)
    b = newton(g, [2.0], tol=1e-10, max_iter=60, residual=lambda x: g(x)[0])
    assert a.converged and b.converged and b.jacobians < a.jacobians
    assert b.x[0] == pytest.approx(1.0, abs=1e-5)


def test_a_lazy_jacobian_that_fails_at_the_solution_is_a_failure_not_a_crash(rng):
    f = Counted(rng)
    full = newton(f.fun_and_jac, np.zeros(6), tol=1e-12)

    def broken(x):
        if np.abs(x - full.x).max() < 1e-9:
            raise FloatingPointError("overflow in the variational equations")
        return f.fun_and_jac(x)

    res = newton(broken, full.x + 1e-5, tol=1e-12, lu0=factorize(f.fun_and_jac(full.x)[1]), residual=f.residual)
    assert not res.converged and "Jacobian failed at the solution" in res.message
