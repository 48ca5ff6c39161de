"""The periodic-problem protocol: every periodic problem offers its members, with the values closed forms give.

Truth from outside the classes: ``T = 2 pi nu / w`` and ``w`` read from the
parameters the problem was made with, the Fourier series of
:mod:`contin.hb.harmonics` written out by hand at chosen times, and the
package's sources (no problem is asked which kind it is by ``getattr``).
"""

import math
import re
from pathlib import Path

import numpy as np
import pytest

from contin.hb.condensation import CondensedHarmonicBalance
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.hb.torus import QuasiPeriodicBalance, TorusOptions
from contin.model.periodic import PeriodicProblem
from contin.models.polynomial import polynomial_model
from contin.output.expansion import StoredExpansion

PACKAGE = Path(__file__).resolve().parents[2] / "contin"
W = 1.2  # the model's excitation frequency


def chain():
    """Two masses in a chain, a cubic spring on the second (the dof a condensed problem keeps)."""
    params = {"k": 1.0, "c": 0.05, "g": 2.0, "F": 1.0, "w": W}
    return polynomial_model(
        ["x1", "x2"], params, mass=[[1, 0], [0, 2]], damping=[["2*c", "-c"], ["-c", "c"]],
        stiffness=[["2*k", "-k"], ["-k", "k"]], nonlinear=[{"dof": "x2", "coef": "g", "x": {"x2": 3}}],
        forcing=[{"dof": "x1", "amplitude": "F"}])


def problems(parameter, nu):
    hb = HarmonicBalance(chain(), parameter, HBOptions(harmonics=3, subharmonic=nu))
    return {"full": hb, "condensed": CondensedHarmonicBalance(hb, [1]),
            "torus": QuasiPeriodicBalance(chain(), parameter, TorusOptions(2, 2, subharmonic=nu))}


@pytest.mark.parametrize("kind", ["full", "condensed", "torus"])
@pytest.mark.parametrize("nu", [1, 2])
def test_every_periodic_problem_is_one_with_the_closed_form_period(kind, nu):
    p = problems("w", nu)[kind]
    assert isinstance(p, PeriodicProblem)
    assert p.parameter == "w" and p.frequency == "w" and p.nu == nu
    for lam in (0.7, 2.3):
        assert p.frequency_at(lam) == lam
        assert math.isclose(p.period_at(lam), nu * 2 * math.pi / lam, rel_tol=1e-15)
        assert p.params_at(lam)[p.model.parameter_index("w")] == lam


@pytest.mark.parametrize("kind", ["full", "condensed", "torus"])
def test_a_parameter_other_than_the_frequency_leaves_the_period_fixed(kind):
    p = problems("F", 2)[kind]
    assert p.parameter == "F" and p.frequency == "w"
    assert p.frequency_at(0.3) == W and p.frequency_at(5.0) == W
    assert math.isclose(p.period_at(0.3), 2 * 2 * math.pi / W, rel_tol=1e-15)
    assert p.params_at(0.3)[p.model.parameter_index("F")] == 0.3


def test_full_condensed_and_the_dofs_of_each_problem():
    pr = problems("w", 1)
    hb, ch, qp = pr["full"], pr["condensed"], pr["torus"]
    assert hb.full is hb and not hb.condensed and hb.n == 2 and hb.dof_names == ["x1", "x2"] and hb.size == 2 * 7
    assert ch.full is hb and ch.condensed and ch.n == 1 and ch.dof_names == ["x2"] and ch.size == 7
    assert qp.full is qp and not qp.condensed and qp.n == 2 and qp.dof_names == ["x1", "x2"]
    # the stored expansion keeps the problem in every dof, whichever it is handed
    assert StoredExpansion(ch).full is hb and StoredExpansion(hb).full is hb and StoredExpansion(None).full is None


@pytest.mark.parametrize("parameter, nu", [("w", 1), ("w", 2), ("F", 2)])
def test_the_shooting_problem_is_one_too(parameter, nu):
    from contin.timedomain.shooting import ShootingOptions, ShootingProblem

    sp = ShootingProblem(chain(), parameter, options=ShootingOptions(subharmonic=nu))
    assert isinstance(sp, PeriodicProblem)
    assert sp.full is sp and not sp.condensed and sp.n == 2 and list(sp.dof_names) == ["x1", "x2"]
    assert sp.parameter == parameter and sp.frequency == "w" and sp.nu == nu
    w = 2.3 if parameter == "w" else W
    assert sp.frequency_at(2.3) == w
    assert math.isclose(sp.period_at(2.3), nu * 2 * math.pi / w, rel_tol=1e-15)


def test_objects_missing_a_member_are_no_periodic_problem():
    class Partial:
        parameter, frequency, nu, n, size, dof_names, condensed = "w", "w", 1, 1, 3, ["x"], False

        def params_at(self, lam):
            return np.array([lam])

        def frequency_at(self, lam):
            return lam

        def period_at(self, lam):
            return 2 * math.pi / lam

        def orbit(self, u, lam, t):
            return None

    assert not isinstance(Partial(), PeriodicProblem)  # no ``full``
    Partial.full = property(lambda self: self)
    assert isinstance(Partial(), PeriodicProblem)
    assert not isinstance(object(), PeriodicProblem)


@pytest.mark.parametrize("nu", [1, 2])
def test_the_orbit_of_a_harmonic_balance_point_is_its_fourier_series(nu):
    hb = problems("w", nu)["full"]
    U = np.zeros((7, 2))
    U[0] = [0.1, -0.2]  # means
    U[1] = [0.5, 0.0]  # cos(theta) on x1
    U[4] = [0.0, 0.3]  # sin(2 theta) on x2
    lam = 1.7
    Om = lam / nu  # theta = w t / nu
    t = np.array([0.0, 0.4, 1.1, 3.0])
    x, xd = hb.orbit(U.reshape(-1), lam, t)
    assert x.shape == xd.shape == (2, t.size)
    np.testing.assert_allclose(x[0], 0.1 + 0.5 * np.cos(Om * t), rtol=0, atol=1e-14)
    np.testing.assert_allclose(x[1], -0.2 + 0.3 * np.sin(2 * Om * t), rtol=0, atol=1e-14)
    np.testing.assert_allclose(xd[0], -0.5 * Om * np.sin(Om * t), rtol=0, atol=1e-14)
    np.testing.assert_allclose(xd[1], 0.6 * Om * np.cos(2 * Om * t), rtol=0, atol=1e-14)
    x0, xd0 = hb.orbit(U.reshape(-1), lam, 0.4)  # a single time: one column
    assert x0.shape == (2, 1) and np.allclose(x0[:, 0], x[:, 1], rtol=0, atol=1e-15)


def test_a_condensed_orbit_is_the_full_orbit_of_its_expansion():
    pr = problems("w", 1)
    hb, ch = pr["full"], pr["condensed"]
    uc = np.array([0.05, 0.4, -0.1, 0.0, 0.02, 0.01, 0.0])
    lam, t = 1.3, np.linspace(0.0, 2 * math.pi / 1.3, 5)
    u = ch.expand(uc, lam)
    x, xd = ch.orbit(uc, lam, t)
    assert x.shape == (2, t.size)  # every dof of the model, the eliminated one too
    # the kept dof by hand from its own coefficients
    np.testing.assert_allclose(x[1], 0.05 + 0.4 * np.cos(1.3 * t) - 0.1 * np.sin(1.3 * t)
                               + 0.02 * np.sin(2 * 1.3 * t) + 0.01 * np.cos(3 * 1.3 * t), rtol=0, atol=1e-14)
    fx, fxd = hb.orbit(u, lam, t)
    np.testing.assert_array_equal(x, fx)
    np.testing.assert_array_equal(xd, fxd)


def test_the_orbit_of_a_torus_point_follows_both_angles():
    qp = problems("w", 1)["torus"]
    U = np.zeros((qp.basis.rows, 2))
    j, _ = qp.basis.pair(0, 1)
    U[2 * j - 1, 0] = 0.7  # cos(theta2) on x1
    i, _ = qp.basis.pair(1, 0)
    U[2 * i, 1] = 0.2  # sin(theta1) on x2
    w2, lam = 0.37, 1.5
    t = np.array([0.0, 0.9, 2.5])
    x, xd = qp.orbit(np.append(U.reshape(-1), w2), lam, t)
    np.testing.assert_allclose(x, [0.7 * np.cos(w2 * t), 0.2 * np.sin(lam * t)], rtol=0, atol=1e-14)
    np.testing.assert_allclose(xd, [-0.7 * w2 * np.sin(w2 * t), 0.2 * lam * np.cos(lam * t)], rtol=0, atol=1e-14)


def test_no_module_asks_a_problem_for_full_by_getattr():
    """The protocol is asked (``problem.full``, ``problem.condensed``), never probed by name."""
    probe = re.compile(r"""(getattr|hasattr)\([^()]*["']full["']""")
    found = [f"{path.relative_to(PACKAGE)}:{i}" for path in sorted(PACKAGE.rglob("*.py"))
             for i, line in enumerate(path.read_text().splitlines(), 1) if probe.search(line)]
    assert not found, f"a problem probed for 'full' instead of asked: {found}"
