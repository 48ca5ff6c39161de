"""Modal analysis and impedance FRF against the closed forms of seed 002 (and seed 000's absorber)."""

import numpy as np
import pytest
import scipy.linalg

from contin.modal.modes import (LinearSystem, SingularImpedance, chain_matrices, damped_modes, frf, impedance,
                          natural_modes, principal_coordinates, receptance)


def seed002_example(m=1.0, k=1.0, c=(0.0, 0.0, 0.0)):
    """Seed 002, sec. 4.3: m1 = m, m2 = 2m, k1 = k2 = k, k3 = 2k."""
    return chain_matrices([m, 2 * m], [k, k, 2 * k], c)


@pytest.mark.parametrize("m, k", [(1.0, 1.0), (2.5, 40.0), (1e-3, 7e5)])
def test_seed002_example_natural_frequencies_and_ratios(m, k):
    M, C, K = seed002_example(m, k)
    nm = natural_modes(M, K)
    w1, w2 = np.sqrt(k / m), np.sqrt(5.0 / 2.0) * np.sqrt(k / m)  # seed 002: w2 = 1.5814 sqrt(k/m)
    np.testing.assert_allclose(nm.omega, [w1, w2], rtol=1e-13)
    assert abs(w2 / w1 - 1.5814) < 5e-4
    # r_i = -(k11 - w_i^2 m1)/k12 = -k12/(k22 - w_i^2 m2) (seed 002, sec. 2.2)
    k11, k12, k22, m1, m2 = 2 * k, -k, 3 * k, m, 2 * m
    for i, w in enumerate((w1, w2)):
        r = -(k11 - w**2 * m1) / k12
        assert abs(r + k12 / (k22 - w**2 * m2)) < 1e-12 * abs(r)
        assert abs(nm.ratios()[1, i] - r) < 1e-12
    np.testing.assert_allclose(nm.ratios()[1], [1.0, -0.5], atol=1e-13)
    # mass-normalised and orthogonal
    np.testing.assert_allclose(nm.modes.T @ M @ nm.modes, np.eye(2), atol=1e-13)
    np.testing.assert_allclose(nm.modes.T @ K @ nm.modes, np.diag(nm.omega2), atol=1e-12 * k / m)


def test_frequency_equation_of_seed002_for_random_systems(rng):
    """w_{1,2}^2 from m1 m2 w^4 - (m1 k22 + m2 k11) w^2 + k11 k22 - k12^2 = 0 (seed 002, sec. 2.2)."""
    for _ in range(20):
        m1, m2 = rng.uniform(0.1, 10, 2)
        k1, k2, k3 = rng.uniform(0.0, 10, 3)
        k2 += 0.1
        M, _, K = chain_matrices([m1, m2], [k1, k2, k3])
        k11, k12, k22 = K[0, 0], K[0, 1], K[1, 1]
        b = (m1 * k22 + m2 * k11) / (m1 * m2)
        disc = np.sqrt(b**2 - 4 * (k11 * k22 - k12**2) / (m1 * m2))
        ref = np.sqrt([b / 2 - disc / 2, b / 2 + disc / 2])
        np.testing.assert_allclose(natural_modes(M, K).omega, ref, rtol=1e-10, atol=1e-12)


def test_chain_matrices_are_the_seed_matrices():
    M, C, K = chain_matrices([1.0, 2.0], [3.0, 5.0, 7.0], [0.1, 0.2, 0.3])
    np.testing.assert_array_equal(M, np.diag([1.0, 2.0]))
    np.testing.assert_array_equal(K, [[3 + 5, -5], [-5, 5 + 7]])
    np.testing.assert_array_equal(C, [[0.1 + 0.2, -0.2], [-0.2, 0.2 + 0.3]])
    M, C, K = chain_matrices([1, 1, 1], [1, 2, 3, 4])
    np.testing.assert_array_equal(K, [[3, -2, 0], [-2, 5, -3], [0, -3, 7]])
    with pytest.raises(ValueError, match="3 masses need 4 stiffnesses"):
        chain_matrices([1, 1, 1], [1, 2, 3])


def state_matrix(M, C, K):
    Mi = np.linalg.inv(M)
    n = M.shape[0]
    return np.block([[np.zeros((n, n)), np.eye(n)], [-Mi @ K, -Mi @ C]])


@pytest.mark.parametrize("case", ["absorber", "chain", "overdamped", "gyroscopic"])
def test_damped_eigenvalues_match_the_state_matrix_and_the_seed_ratios(case):
    if case == "absorber":  # seed 000: damper c between the masses, k3 = 0
        M, C, K = chain_matrices([100.0, 10.0], [5e5, 41322.3, 0.0], [0.0, 237.4, 0.0])
    elif case == "chain":
        M, C, K = chain_matrices([1.0, 2.0, 0.5], [1.0, 3.0, 2.0, 1.0], [0.05, 0.0, 0.2, 0.01])
    elif case == "overdamped":
        M, C, K = chain_matrices([1.0, 1.0], [1.0, 1.0, 1.0], [5.0, 0.0, 0.1])
    else:  # a skew-symmetric (gyroscopic) part in C
        M, C, K = np.diag([1.0, 1.0]), np.array([[0.02, 0.8], [-0.8, 0.02]]), np.diag([1.0, 1.5])
    dm = damped_modes(M, C, K)
    ref = scipy.linalg.eigvals(state_matrix(M, C, K))
    assert dm.eigenvalues.size == ref.size
    for r in ref:  # each eigenvalue of the state matrix is found (pairs matched by distance)
        assert np.min(np.abs(dm.eigenvalues - r)) <= 1e-9 * np.max(np.abs(ref))
    for g in dm.eigenvalues:
        assert np.min(np.abs(ref - g)) <= 1e-9 * np.max(np.abs(ref))
    for lam, B in zip(dm.eigenvalues, dm.vectors.T):
        D = lam**2 * M + lam * C + K
        assert np.linalg.norm(D @ B) <= 1e-9 * np.linalg.norm(D) * np.linalg.norm(B)
        assert abs(B[0] - 1.0) < 1e-12  # scaled to [1, r_i] as in the seed
        if M.shape[0] == 2 and case != "gyroscopic":
            # r_i = -(m11 l^2 + c11 l + k11)/(m12 l^2 + c12 l + k12) (seed 002, sec. 3.2)
            r = -(M[0, 0] * lam**2 + C[0, 0] * lam + K[0, 0]) / (M[0, 1] * lam**2 + C[0, 1] * lam + K[0, 1])
            assert abs(B[1] - r) < 1e-8 * max(1.0, abs(r))
    assert dm.stable
    np.testing.assert_allclose(dm.damping_ratio, -dm.eigenvalues.real / np.abs(dm.eigenvalues))


def test_damped_eigenvalues_of_one_dof_are_the_textbook_roots():
    m, c, k = 2.0, 0.6, 50.0
    dm = damped_modes([[m]], [[c]], [[k]])
    wn, z = np.sqrt(k / m), c / (2 * np.sqrt(k * m))
    np.testing.assert_allclose(dm.eigenvalues, [-z * wn + 1j * wn * np.sqrt(1 - z**2),
                                                -z * wn - 1j * wn * np.sqrt(1 - z**2)], rtol=1e-13)
    np.testing.assert_allclose(dm.damping_ratio, z, rtol=1e-12)
    np.testing.assert_allclose(dm.natural_frequency, wn, rtol=1e-13)


def test_frf_is_seed002s_closed_form():
    """X1 = (3k - 2 w^2 m) F0/(2 m^2 w^4 - 7 m k w^2 + 5 k^2), X2 = k F0/(...) (seed 002, sec. 4.3)."""
    m, k, F0 = 1.7, 30.0, 2.0
    M, C, K = seed002_example(m, k)
    w = np.linspace(0.01, 3.0, 301) * np.sqrt(k / m) + 1e-3
    X = frf(M, C, K, w, [F0, 0.0])
    den = 2 * m**2 * w**4 - 7 * m * k * w**2 + 5 * k**2
    np.testing.assert_allclose(X[:, 0].real, (3 * k - 2 * w**2 * m) * F0 / den, rtol=1e-10)
    np.testing.assert_allclose(X[:, 1].real, k * F0 / den, rtol=1e-10)
    np.testing.assert_allclose(X.imag, 0.0, atol=1e-14)
    # the seed's normalised form with w1 = sqrt(k/m), w2 = sqrt(5k/(2m))
    w1, w2 = np.sqrt(k / m), np.sqrt(5 * k / (2 * m))
    d = (1 - (w / w1) ** 2) * (1 - (w / w2) ** 2)
    np.testing.assert_allclose(X[:, 0].real, 2 * F0 / (5 * k) * (1.5 - (w / w1) ** 2) / d, rtol=1e-10)
    np.testing.assert_allclose(X[:, 1].real, F0 / (5 * k) / d, rtol=1e-10)


def test_frf_is_seed000s_damped_absorber_closed_form():
    """X = delta_st p^2 [p_a^2 - w^2 + 2i zeta p w, p_a^2 + 2i zeta p w] / D (seed 000, sec. 7.3)."""
    m1, k1, m2, k2, c, F = 100.0, 5e5, 10.0, 4.1e4, 150.0, 3.0
    M, C, K = chain_matrices([m1, m2], [k1, k2, 0.0], [0.0, c, 0.0])
    w = np.linspace(1.0, 150.0, 500)
    X = frf(M, C, K, w, [F, 0.0])
    p, pa, beta, dst = np.sqrt(k1 / m1), np.sqrt(k2 / m2), m2 / m1, F / k1
    zeta = c / (2 * m2 * p)
    D = (p**2 - w**2) * (pa**2 - w**2) - beta * pa**2 * w**2 + 2j * zeta * p * w * (p**2 - (1 + beta) * w**2)
    np.testing.assert_allclose(X[:, 0], dst * p**2 * (pa**2 - w**2 + 2j * zeta * p * w) / D, rtol=1e-11)
    np.testing.assert_allclose(X[:, 1], dst * p**2 * (pa**2 + 2j * zeta * p * w) / D, rtol=1e-11)
    # the zeta_a form of the same expression (zeta_a = c/(2 sqrt(m2 k2)), c/m2 = 2 zeta_a p_a)
    za = c / (2 * np.sqrt(m2 * k2))
    Da = (p**2 - w**2) * (pa**2 - w**2) - beta * pa**2 * w**2 + 2j * za * pa * w * (p**2 - (1 + beta) * w**2)
    np.testing.assert_allclose(X[:, 0], dst * p**2 * (pa**2 - w**2 + 2j * za * pa * w) / Da, rtol=1e-11)


def test_receptance_columns_are_unit_force_responses_and_symmetric():
    M, C, K = chain_matrices([1.0, 2.0, 0.5], [1.0, 3.0, 2.0, 1.0], [0.05, 0.1, 0.2, 0.01])
    w = np.linspace(0.1, 4, 50)
    H = receptance(M, C, K, w)
    for j in range(3):
        F = np.zeros(3)
        F[j] = 1.0
        np.testing.assert_allclose(H[:, :, j], frf(M, C, K, w, F), rtol=1e-13)
    np.testing.assert_allclose(H, np.swapaxes(H, 1, 2), rtol=1e-10)  # reciprocity (symmetric M, C, K)
    Z = impedance(M, C, K, w)
    np.testing.assert_allclose(Z @ H, np.broadcast_to(np.eye(3), Z.shape), atol=1e-12)


def test_principal_coordinates_decouple_and_reproduce_the_frf():
    """x = Phi q gives q'' + diag(w^2) q = Phi^T f (seed 002, sec. 2.3); with proportional damping the
    modal superposition sum_i phi_i phi_i^T F / (w_i^2 - w^2 + i w c_i) is the FRF."""
    M, _, K = chain_matrices([1.0, 2.0, 1.5], [2.0, 1.0, 3.0, 0.5])
    C = 0.02 * M + 0.03 * K
    pc = principal_coordinates(M, C, K)
    nm = natural_modes(M, K)
    np.testing.assert_allclose(pc.modal_mass, np.eye(3), atol=1e-13)
    np.testing.assert_allclose(pc.modal_stiffness, np.diag(nm.omega2), atol=1e-12)
    assert pc.proportional
    np.testing.assert_allclose(pc.modal_damping_ratio, (0.02 / nm.omega + 0.03 * nm.omega) / 2, rtol=1e-10)
    F = np.array([1.0, -0.5, 0.25])
    w = np.linspace(0.05, 3.0, 200)
    c = np.diag(pc.modal_damping)
    modal = sum(np.outer(1.0 / (nm.omega2[i] - w**2 + 1j * w * c[i]), nm.modes[:, i] * (nm.modes[:, i] @ F))
                for i in range(3))
    np.testing.assert_allclose(frf(M, C, K, w, F), modal, rtol=1e-10)
    x = np.array([0.3, -0.1, 0.7])
    np.testing.assert_allclose(pc.to_physical(pc.to_modal(x)), x, atol=1e-14)
    # seed 002's un-normalised form: the columns are [1, r_i] up to a factor
    M2, _, K2 = seed002_example()
    pc2 = principal_coordinates(M2, None, K2)
    np.testing.assert_allclose(pc2.transform / pc2.transform[0], [[1, 1], [1, -0.5]], atol=1e-13)
    # the absorber's damper between the masses is not proportional damping
    M3, C3, K3 = chain_matrices([100.0, 10.0], [5e5, 4e4, 0.0], [0.0, 200.0, 0.0])
    assert not principal_coordinates(M3, C3, K3).proportional


def test_ratios_are_undefined_at_a_node_of_the_reference_dof():
    M, _, K = chain_matrices([1.0, 1.0, 1.0], [1.0, 1.0, 1.0, 1.0])
    nm = natural_modes(M, K, reference=1)  # the middle mass is a node of the second mode
    r = nm.ratios()
    assert np.all(np.isnan(r[:, 1])) and np.all(np.isfinite(r[:, [0, 2]]))
    assert nm.modes[np.argmax(np.abs(nm.modes[:, 1])), 1] > 0


def test_negative_stiffness_mode_is_divergent_not_nan():
    nm = natural_modes(np.eye(2), np.diag([-1.0, 4.0]))
    np.testing.assert_allclose(nm.omega2, [-1.0, 4.0])
    assert nm.divergent.tolist() == [True, False] and np.all(np.isfinite(nm.omega))


def test_nonsymmetric_stiffness_uses_the_general_pencil():
    M = np.diag([1.0, 2.0])
    K = np.array([[3.0, -1.0], [-0.5, 2.0]])  # a follower-force-like coupling
    nm = natural_modes(M, K)
    assert not nm.symmetric
    np.testing.assert_allclose(np.sort(nm.omega2), np.sort(scipy.linalg.eigvals(K, M).real), rtol=1e-12)
    for i in range(2):
        v = nm.modes[:, i]
        np.testing.assert_allclose(K @ v, nm.omega2[i] * M @ v, atol=1e-12)


def test_singular_impedance_names_the_frequency():
    M, C, K = seed002_example()
    with pytest.raises(SingularImpedance, match=r"singular at w = 1\b"):
        frf(M, C, K, [0.5, 1.0, 1.2], [1.0, 0.0])


def test_linear_system_validates_its_fields():
    with pytest.raises(ValueError, match="LinearSystem.M must be a square matrix"):
        LinearSystem(np.ones((2, 3)), np.eye(2))
    with pytest.raises(ValueError, match="LinearSystem.M must be positive definite"):
        LinearSystem(np.array([[1.0, 2.0], [2.0, 1.0]]), np.eye(2))
    with pytest.raises(ValueError, match="LinearSystem.M must be symmetric"):
        LinearSystem(np.array([[1.0, 0.1], [0.0, 1.0]]), np.eye(2))
    with pytest.raises(ValueError, match=r"LinearSystem.K must be 2x2 like M"):
        LinearSystem(np.eye(2), np.eye(3))
    with pytest.raises(ValueError, match="LinearSystem.C has non-finite entries"):
        LinearSystem(np.eye(2), np.eye(2), np.array([[np.nan, 0], [0, 0]]))
    with pytest.raises(ValueError, match="LinearSystem.reference must be a dof index"):
        LinearSystem(np.eye(2), np.eye(2), reference=2)
    with pytest.raises(ValueError, match="LinearSystem.dof_names must be 2 distinct names"):
        LinearSystem(np.eye(2), np.eye(2), dof_names=("a", "a"))
    s = LinearSystem(*seed002_example()[::2], dof_names=("x1", "x2"))
    np.testing.assert_allclose(s.natural_modes().omega, [1.0, np.sqrt(2.5)], rtol=1e-13)
    np.testing.assert_allclose(s.frf([0.5], "x2"), frf(s.M, s.C, s.K, [0.5], [0.0, 1.0]))
    with pytest.raises(ValueError, match=r"LinearSystem.force: unknown dof 'x3'; expected one of \['x1', 'x2'\]"):
        s.frf([0.5], "x3")
