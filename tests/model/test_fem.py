"""Finite-element rotors: coefficients, the rotor file, the model built from it, its reduction.

Truth from outside: ROSS's own unbalance responses of the stored rotors (``tests/model/data/ross_reference.npz``,
written by ROSS through ``scripts/figures/rotor/rotor_fe_data.py``), scipy's splines, the full model's
eigenvalues (for the reduction). ROSS itself is exercised in ``test_fem_ross.py`` (tier ``ross``).
"""

from pathlib import Path

import numpy as np
import pytest
from scipy.interpolate import UnivariateSpline, interp1d

from contin.hb.problem import HarmonicBalance, HBOptions
from contin.model.fem.builder import Contact, Reduction, SideLoad, Unbalance, Units, fe_rotor_model
from contin.model.fem.coefficients import SplineCoefficient, spline_of
from contin.model.fem.matrices import BearingTable, RotorMatrices, load_matrices
from contin.model.fem.reduction import craig_bampton
from contin.model.fem.rig import RIG_NODES, rig_items, rig_scales
from contin.model.fem.ross_bridge import load_rotor

ROOT = Path(__file__).resolve().parents[2]
DATA = Path(__file__).resolve().parent / "data"
RIG = ROOT / "scenes" / "data" / "rig_001.npz"


@pytest.fixture(scope="module")
def reference():
    with np.load(DATA / "ross_reference.npz") as z:
        return {k: z[k] for k in z.files}


def test_spline_coefficient_is_scipys_spline_with_its_derivative():
    x = np.linspace(0.0, 500.0, 6)
    spl = UnivariateSpline(x, 1e6 * (1 + (x / 500) ** 2))
    t, c, k = spline_of(spl)
    coef = SplineCoefficient(1, t, c, k, scale=2.0, arg_scale=10.0)
    p = np.array([0.3, 17.3])
    assert coef.value(p) == pytest.approx(2.0 * float(spl(173.0)), rel=1e-14)
    h = 1e-5
    fd = (coef.value(p + [0, h]) - coef.value(p - [0, h])) / (2 * h)
    assert coef.derivative(p, 1) == pytest.approx(fd, rel=1e-7)
    assert coef.derivative(p, 0) == 0.0 and coef.depends_on(1) and not coef.depends_on(0)
    for kind, pts in (("linear", 2), (2, 3)):  # ROSS's interp1d through two or three points
        xs = np.linspace(0, 400, pts)
        f = interp1d(xs, 1 + xs + 1e-3 * xs**2 * (pts == 3), kind=kind, fill_value="extrapolate")
        t, c, k = spline_of(f)
        s = SplineCoefficient(0, t, c, k)
        for v in (-50.0, 123.0, 700.0):  # extrapolated too, as ROSS does
            assert s.value(np.array([v])) == pytest.approx(float(f(v)), rel=1e-12)
    t, c, k = spline_of(interp1d([0, 1], [5.0, 5.0], kind="linear", fill_value="extrapolate"))
    assert k == 0 and c.tolist() == [5.0]
    with pytest.raises(ValueError, match="unsupported interpolant"):
        spline_of(np.poly1d([1.0, 2.0]))


def test_rotor_file_round_trip_and_bad_files(tmp_path):
    r = load_matrices(DATA / "spline_rotor.npz")
    r.save(tmp_path / "copy.npz")
    s = load_matrices(tmp_path / "copy.npz")
    for name in ("mass", "damping", "stiffness", "gyroscopic", "positions", "discs"):
        assert np.array_equal(getattr(r, name), getattr(s, name))
    for W in (0.0, 123.0, 600.0):
        assert all(np.array_equal(a, b) for a, b in zip(r.linear(W), s.linear(W)))
    np.savez(tmp_path / "other.npz", x=np.zeros(3))
    with pytest.raises(ValueError, match="not a rotor matrix file"):
        load_matrices(tmp_path / "other.npz")
    (tmp_path / "junk.npz").write_bytes(b"not a zip")
    with pytest.raises(ValueError, match="not a rotor matrix file"):
        load_matrices(tmp_path / "junk.npz")
    with pytest.raises(OSError, match="no such rotor file"):
        load_rotor(tmp_path / "missing.npz")
    with pytest.raises(ValueError, match=r"expected a rotor file \.npz"):
        (tmp_path / "rotor.txt").write_text("x")
        load_rotor(tmp_path / "rotor.txt")
    with pytest.raises(ValueError, match=r"rotor stiffness: expected a 8x8 matrix"):
        RotorMatrices([0.0, 1.0], np.eye(8), np.zeros((8, 8)), np.eye(7), np.zeros((8, 8)))
    with pytest.raises(ValueError, match="unknown coefficient 'kzz'"):
        RotorMatrices([0.0, 1.0], np.eye(8), np.zeros((8, 8)), np.eye(8), np.zeros((8, 8)),
                      (BearingTable(0, {"kzz": (np.array([0.0, 1.0]), np.array([1.0]), 0)}),))


@pytest.mark.parametrize("which", ["rig", "spline"])
def test_unbalance_response_matches_ross(which, reference):
    """The harmonic balance of the rotor without its contact reproduces ROSS's unbalance response
    (amplitude and phase, every lateral dof, several speeds) to 1e-6 relative."""
    rotor = load_matrices(RIG if which == "rig" else DATA / "spline_rotor.npz")
    node, magnitude, phase = reference[f"{which}_unbalance"]
    units = Units(1e-3, 5.0, 60.0)  # any units: the comparison is in SI
    model = fe_rotor_model(rotor, unbalance=[Unbalance(int(node), float(magnitude), float(phase))], units=units)
    hb = HarmonicBalance(model, "w", HBOptions(harmonics=1))
    for j, W in enumerate(reference["speeds"]):
        u = hb.linear_solution(W / units.frequency).reshape(3, model.n_dof)
        X = model.fe.physical(u[1] - 1j * u[2])  # x = Re(X e^{i W t}) = a1 cos + b1 sin
        ross = reference[which][:, j]
        err = np.abs(X - ross).max() / np.abs(ross).max()
        assert err < 1e-6, (W, err)
        big = np.abs(ross) > 1e-3 * np.abs(ross).max()
        assert np.allclose(np.angle(X[big] / ross[big]), 0.0, atol=1e-6)


def test_model_units_items_and_errors():
    rotor = load_matrices(RIG)
    it = rig_items()
    s = rig_scales()
    model = fe_rotor_model(rotor, **it, units=Units(1e-3, s["m1"], s["wn"]))
    # with the paper's scales the parameters are the paper's (eq. 10): the Fig. 3 values
    p = model.parameters
    assert p["delta"] == pytest.approx(0.1) and p["e"] == pytest.approx(0.5) and p["f0"] == pytest.approx(0.5)
    assert p["kbn"] == pytest.approx(12881.0) and p["cbn"] == pytest.approx(0.515)
    assert [el.kind for el in model.forces] == ["radial_gap"]
    assert model.observable_names[0].startswith("whirl_") and "whirl_fwd_half_bearing" in model.observable_names
    auto = fe_rotor_model(rotor, **it)
    assert auto.fe.units.mass == pytest.approx(rotor.discs[0, 1])
    assert 70 < auto.fe.units.frequency < 78  # the first natural frequency with the bearing held (11.9 Hz)
    with pytest.raises(ValueError, match=r"contact.node: expected a node in 0..18, found 19"):
        fe_rotor_model(rotor, contact=Contact(19, 1e-4, 1e8))
    with pytest.raises(ValueError, match="contact.node: node 0 has a bearing stiffness"):
        fe_rotor_model(rotor, contact=Contact(0, 1e-4, 1e8))
    with pytest.raises(ValueError, match=r"contact.stiffness: expected a finite number > 0"):
        Contact(18, 1e-4, -1.0)
    with pytest.raises(ValueError, match=r"side_load.force: expected \[fx, fy\]"):
        SideLoad(11, (0.0, 0.0))
    with pytest.raises(ValueError, match=r"units.length: expected a finite number > 0"):
        Units(0.0)
    with pytest.raises(ValueError, match=r"reduction.modes: expected an integer"):
        Reduction(-1)


def test_craig_bampton_converges_to_the_full_natural_frequencies():
    """Natural frequencies with the contact node pressed (a spring) of the reduction against the full model's:
    the error falls as modes are added, and is exact at statics."""
    rotor = load_matrices(RIG)
    it = rig_items()
    full = fe_rotor_model(rotor, **it)
    ix = full.dof_index(f"x_{RIG_NODES['lower']}")

    def lowest(model, i):
        M, _, K = model.linear(model.parameter_vector())
        K = K.copy()
        K[i, i] += 100.0
        K[i + 1, i + 1] += 100.0
        w2 = np.sort(np.linalg.eigvals(np.linalg.solve(M, K)).real)
        return np.sqrt(w2[:4])

    ref = lowest(full, ix)
    errs = []
    for modes in (2, 4, 8):
        red = fe_rotor_model(rotor, **it, reduction=Reduction(modes))
        errs.append(np.abs(lowest(red, 0) / ref - 1).max())
    assert errs[0] >= errs[1] >= errs[2] and errs[2] < 1e-4, errs
    T, f = craig_bampton(np.eye(3), np.diag([2.0, 3.0, 4.0]), [0], 2)
    assert np.allclose(T[0], [1, 0, 0]) and np.allclose(f, np.sqrt([3.0, 4.0]))
    with pytest.raises(ValueError, match="not held"):
        craig_bampton(np.eye(2), np.zeros((2, 2)), [0], 1)


def _gap_model():
    """A stop on one side of the disc (a gap along y) of the rotor with speed-dependent bearings."""
    rotor = load_matrices(DATA / "spline_rotor.npz")
    return fe_rotor_model(rotor, contact=Contact(3, 2e-5, 1e7, 50.0, type="gap", direction="y", sides="+"),
                          unbalance=[Unbalance(3, 2e-4)], side_load=SideLoad(3, (0.0, 20.0)), units=Units(1e-5))


def test_a_one_directional_gap_is_a_gap_element_on_its_dof():
    model = _gap_model()
    assert [el.kind for el in model.forces] == ["gap"] and model.forces[0].active_dofs() == (13,)
    assert model.forces[0].remapped((13,)).dof == 0
    with pytest.raises(ValueError, match="contact.type: expected 'radial_gap' or 'gap'"):
        Contact(18, 1e-4, 1e8, type="ring")
    with pytest.raises(ValueError, match="contact.sides: expected 'both', '\\+' or '-'"):
        Contact(18, 1e-4, 1e8, type="gap", sides="up")


# the solve costs a compilation of the gap's kernels (10 s on a cold cache); the element and its dof are checked
# by test_a_one_directional_gap_is_a_gap_element_on_its_dof in the default run
@pytest.mark.slow
def test_a_one_directional_gap_at_the_disc_starts_and_solves_the_full_problem():
    from contin.bifurcation.start import contact_start

    model = _gap_model()
    hb = HarmonicBalance(model, "w", HBOptions(harmonics=12, crossings="interval", samples=256), {"w": 1.0})
    u = contact_start(hb, 1.0, direction=(1.0,))
    assert np.abs(hb.residual(u, 1.0)).max() < 1e-8
    U = u.reshape(-1, model.n_dof)
    y = U[0, 13] + np.hypot(U[1, 13], U[2, 13])
    assert y > model.parameters["delta"]  # it reaches the stop
