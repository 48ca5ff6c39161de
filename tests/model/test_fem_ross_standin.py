"""The ROSS bridge on a tiny rotor made without ROSS (default tier).

ROSS is not installed in CI (its own tests are the ``ross`` tier, ``test_fem_ross.py``). Here a stand-in
with what :func:`contin.model.fem.ross_bridge.from_ross` reads of a ``ross.Rotor``, built with numpy and
scipy alone: ``number_dof`` (6: ``x, y, z, alpha, beta, theta`` per node, as ROSS numbers them), ``nodes``,
``nodes_pos`` [m], the matrices without bearings ``M0``, ``C0``, ``K0``, ``G0`` (SI), the discs
(``n, m, Ip, Id``) and the bearings, whose ``<coef>_interpolated`` are made by ROSS's rule
(``BearingElement._process_coefficient``): a constant is an ``interp1d`` through ``[0, 1]``, two or three
table points an ``interp1d`` of degree 1 or 2 (extrapolated), four or more a ``UnivariateSpline``.

Truth from outside the bridge: the lateral matrices assembled by hand in the four-dof ordering
(``x, y, alpha, beta``) from the textbook beam, bar and shaft elements, the polynomials the bearing tables
are sampled from, and scipy's ``make_interp_spline`` and ``UnivariateSpline`` of the same tables.
"""

from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from scipy.interpolate import UnivariateSpline, interp1d, make_interp_spline

from conftest import fuzz_examples
from contin.model.fem.matrices import COEFFICIENTS
from contin.model.fem.ross_bridge import DECOUPLED, from_ross, lateral_dofs

# steel shaft, diameter 30 mm, two elements of 0.2 m (nodes 0, 1, 2)
E, G_S, RHO, D = 2.1e11, 8.1e10, 7810.0, 0.03
AREA, I_AREA = np.pi * D**2 / 4, np.pi * D**4 / 64
J_POLAR = 2 * I_AREA
LENGTHS = (0.2, 0.2)
#: shaft damping proportional to its stiffness (ROSS's ``beta``), so that ``C0`` is not zero
BETA = 1e-5
#: a disc at the middle node: (node, m [kg], Ip, Id [kg m^2])
DISC = (1, 12.0, 0.09, 0.05)
#: ROSS's dof order within a node
ROSS6 = {"x": 0, "y": 1, "z": 2, "alpha": 3, "beta": 4, "theta": 5}
SPEEDS = np.array([0.0, 100.0, 200.0, 300.0, 400.0, 500.0])


def beam_plane(L):
    """Euler-Bernoulli bending in one plane, dofs (w_1, phi_1, w_2, phi_2): (mass, stiffness), consistent."""
    k = E * I_AREA / L**3 * np.array([[12, 6 * L, -12, 6 * L], [6 * L, 4 * L**2, -6 * L, 2 * L**2],
                                      [-12, -6 * L, 12, -6 * L], [6 * L, 2 * L**2, -6 * L, 4 * L**2]])
    m = RHO * AREA * L / 420 * np.array([[156, 22 * L, 54, -13 * L], [22 * L, 4 * L**2, 13 * L, -3 * L**2],
                                         [54, 13 * L, 156, -22 * L], [-13 * L, -3 * L**2, -22 * L, 4 * L**2]])
    return m, k


#: the y-plane's rotation is alpha = -dy/dz: its rotation rows and columns change sign
FLIP = np.diag([1.0, -1.0, 1.0, -1.0])


def hand_lateral(with_disc=True):
    """The lateral (M, C, K, G) assembled directly in the four-dof ordering ``4 node + (x, y, alpha, beta)``."""
    n = 4 * (len(LENGTHS) + 1)
    M, K, G = np.zeros((n, n)), np.zeros((n, n)), np.zeros((n, n))
    for e, L in enumerate(LENGTHS):
        m, k = beam_plane(L)
        ix = [4 * e, 4 * e + 3, 4 * e + 4, 4 * e + 7]  # x_e, beta_e, x_e+1, beta_e+1
        iy = [4 * e + 1, 4 * e + 2, 4 * e + 5, 4 * e + 6]  # y_e, alpha_e, y_e+1, alpha_e+1
        M[np.ix_(ix, ix)] += m
        K[np.ix_(ix, ix)] += k
        M[np.ix_(iy, iy)] += FLIP @ m @ FLIP
        K[np.ix_(iy, iy)] += FLIP @ k @ FLIP
    C = BETA * K
    if with_disc:
        node, m, Ip, Id = DISC
        b = 4 * node
        M[b:b + 4, b:b + 4] += np.diag([m, m, Id, Id])
        G[b + 2, b + 3], G[b + 3, b + 2] = Ip, -Ip
    return M, C, K, G


def ross_matrices():
    """(M0, C0, K0, G0) as ROSS numbers them: six dofs a node, the bar and torsion on ``z`` and ``theta``."""
    n = 6 * (len(LENGTHS) + 1)
    M, K, G = np.zeros((n, n)), np.zeros((n, n)), np.zeros((n, n))

    def at(node, name):
        return 6 * node + ROSS6[name]

    for e, L in enumerate(LENGTHS):
        m, k = beam_plane(L)
        ix = [at(e, "x"), at(e, "beta"), at(e + 1, "x"), at(e + 1, "beta")]
        iy = [at(e, "y"), at(e, "alpha"), at(e + 1, "y"), at(e + 1, "alpha")]
        M[np.ix_(ix, ix)] += m
        K[np.ix_(ix, ix)] += k
        M[np.ix_(iy, iy)] += FLIP @ m @ FLIP
        K[np.ix_(iy, iy)] += FLIP @ k @ FLIP
        pair = np.array([[1.0, -1.0], [-1.0, 1.0]])
        consistent = np.array([[2.0, 1.0], [1.0, 2.0]]) / 6
        iz, it = [at(e, "z"), at(e + 1, "z")], [at(e, "theta"), at(e + 1, "theta")]
        K[np.ix_(iz, iz)] += E * AREA / L * pair  # axial bar
        M[np.ix_(iz, iz)] += RHO * AREA * L * consistent
        K[np.ix_(it, it)] += G_S * J_POLAR / L * pair  # torsion
        M[np.ix_(it, it)] += RHO * J_POLAR * L * consistent
    node, m, Ip, Id = DISC
    dofs = [at(node, d) for d in ("x", "y", "z", "alpha", "beta", "theta")]
    M[np.ix_(dofs, dofs)] += np.diag([m, m, m, Id, Id, Ip])  # ROSS's DiskElement.M
    G[at(node, "alpha"), at(node, "beta")], G[at(node, "beta"), at(node, "alpha")] = Ip, -Ip  # DiskElement.G
    return M, BETA * K, K, G


def ross_interpolant(frequency, value):
    """A coefficient's interpolant by ROSS's rule (``BearingElement._process_coefficient``)."""
    if np.ndim(value) == 0 and frequency is not None:
        value = np.full(len(frequency), float(value))  # a constant with a table of speeds: repeated over it
    if np.ndim(value) == 0:
        return interp1d([0, 1], [value, value], kind="linear", fill_value="extrapolate")
    if len(value) >= 4:
        return UnivariateSpline(frequency, value)
    return interp1d(frequency, value, kind=len(value) - 1, fill_value="extrapolate")


class Bearing:
    """A bearing to ground as ROSS's ``BearingElement`` shows it: ``n``, ``n_link``, ``tag``, ``<coef>_interpolated``."""

    def __init__(self, n, tag, frequency=None, **coefficients):
        self.n, self.tag, self.n_link = n, tag, None
        values = {"kyy": coefficients.get("kxx", 0.0), "cyy": coefficients.get("cxx", 0.0),
                  "myy": coefficients.get("mxx", 0.0)}  # ROSS's defaults: yy as xx
        values.update(coefficients)
        for name in (*COEFFICIENTS, "kzz", "czz", "mzz"):
            setattr(self, f"{name}_interpolated", ross_interpolant(frequency, values.get(name, 0.0)))


def line(a, b):
    return lambda w: a + b * w


def parabola(w):
    return 3.5e6 + 2e3 * w + 4.0 * w**2


def cubic(w):
    return 2e6 * (1 + w / 500 - 0.3 * (w / 500) ** 2 + 0.2 * (w / 500) ** 3)


def bearings():
    """Left (node 0): six-point tables (ROSS's smoothing spline) of a cubic and a line, cross-coupled; right
    (node 2): two- and three-point tables (a line, a parabola) and a constant mass."""
    two, three = SPEEDS[[0, -1]], SPEEDS[[0, 2, 5]]
    left = Bearing(0, "left", SPEEDS, kxx=cubic(SPEEDS), kxy=2e5 * SPEEDS / 500, kyx=-2e5 * SPEEDS / 500,
                   cxx=line(400.0, 1.0)(SPEEDS), cyy=line(500.0, 0.5)(SPEEDS))
    right = Bearing(2, "right", two, kxx=line(3e6, 2e3)(two), cxx=line(300.0, 0.6)(two))
    right_3 = Bearing(2, "right_3", three, kyy=parabola(three), kxx=np.zeros(3), cxx=np.zeros(3), mxx=0.7)
    return [left, right, right_3]


def stand_in(**replace):
    """The tiny rotor: three nodes, one disc, bearings; ``replace`` overrides attributes (None deletes one)."""
    M0, C0, K0, G0 = ross_matrices()
    attrs = {"number_dof": 6, "nodes": [0, 1, 2], "nodes_pos": [0.0, 0.2, 0.4], "M0": M0, "C0": C0, "K0": K0,
             "G0": G0, "bearing_elements": bearings(), "point_mass_elements": [],
             "disk_elements": [SimpleNamespace(n=DISC[0], m=DISC[1], Ip=DISC[2], Id=DISC[3], tag="disc")]}
    attrs.update(replace)
    return SimpleNamespace(**{k: v for k, v in attrs.items() if v is not None})


def test_lateral_dofs_are_x_y_alpha_beta_of_every_node():
    # ROSS: x, y, z, alpha, beta, theta at 6 n + 0..5; its older four-dof rotors: x, y, alpha, beta
    assert lateral_dofs(6, 3).tolist() == [0, 1, 3, 4, 6, 7, 9, 10, 12, 13, 15, 16]
    assert lateral_dofs(4, 3).tolist() == list(range(12))


def test_lateral_matrices_equal_the_hand_assembled_ones():
    mats = from_ross(stand_in())
    assert mats.n_nodes == 3 and mats.positions.tolist() == [0.0, 0.2, 0.4]
    for name, want in zip(("mass", "damping", "stiffness", "gyroscopic"), hand_lateral()):
        got = getattr(mats, name)
        assert got.shape == (12, 12)
        assert np.allclose(got, want, rtol=0, atol=1e-13 * np.abs(want).max()), name


def test_four_dof_rotor_is_taken_whole():
    M, C, K, G = hand_lateral()
    mats = from_ross(stand_in(number_dof=4, M0=M, C0=C, K0=K, G0=G))
    assert np.array_equal(mats.stiffness, K) and np.array_equal(mats.gyroscopic, G)


def test_disc_mass_and_inertia_land_on_its_node():
    mats = from_ross(stand_in())
    shaft_M = hand_lateral(with_disc=False)[0]
    node, m, Ip, Id = DISC
    added = mats.mass - shaft_M
    b = 4 * node
    want = np.zeros_like(added)
    want[b:b + 4, b:b + 4] = np.diag([m, m, Id, Id])  # Id on alpha, beta: not ROSS's m on z nor Ip on theta
    assert np.allclose(added, want, rtol=0, atol=1e-12 * m)
    g = mats.gyroscopic
    assert g[b + 2, b + 3] == Ip and g[b + 3, b + 2] == -Ip and np.count_nonzero(g) == 2
    assert mats.discs.tolist() == [[node, m, Ip, Id]]


def test_bearing_coefficients_are_the_tables_and_interpolate_between_them():
    mats = from_ross(stand_in())
    left, right, right_3 = mats.bearings
    assert [(b.node, b.tag) for b in mats.bearings] == [(0, "left"), (2, "right"), (2, "right_3")]
    w = np.linspace(-50.0, 650.0, 29)  # the table points, between them and beyond
    # at the table's speeds: the values given (the smoothing spline of a cubic passes through its points)
    assert np.allclose(left.value("kxx", SPEEDS), cubic(SPEEDS), rtol=1e-12)
    assert np.allclose(right.value("kxx", SPEEDS[[0, -1]]), [3e6, 3e6 + 2e3 * 500], rtol=1e-14)
    assert np.allclose(right_3.value("kyy", SPEEDS[[0, 2, 5]]), parabola(SPEEDS[[0, 2, 5]]), rtol=1e-14)
    # between and beyond: the polynomial sampled, and scipy's interpolating B-spline of the same degree
    for table, name, f, x in ((left, "kxx", cubic, SPEEDS), (left, "cxx", line(400.0, 1.0), SPEEDS),
                              (right, "kxx", line(3e6, 2e3), SPEEDS[[0, -1]]),
                              (right, "cxx", line(300.0, 0.6), SPEEDS[[0, -1]]),
                              (right_3, "kyy", parabola, SPEEDS[[0, 2, 5]])):
        k = table.splines[name][2]
        assert k == min(len(x) - 1, 3), name
        ref = make_interp_spline(x, f(x), k=k)
        assert np.allclose(table.value(name, w), ref(w, extrapolate=True), rtol=1e-10), name
        assert np.allclose(table.value(name, w), f(w), rtol=1e-10), name
    # cross-coupled stiffness with opposite signs; a constant; coefficients that are zero are left out
    assert np.allclose(left.value("kyx", w), -2e5 * w / 500, rtol=1e-10, atol=1e-6)
    assert right_3.splines["mxx"][2] == 0 and np.all(right_3.value("mxx", w) == 0.7)
    assert right_3.value("myy", 250.0) == 0.7
    assert "kxy" not in right.splines and "kxx" not in right_3.splines and "mxx" not in right.splines


def test_a_table_that_is_no_polynomial_follows_ross_smoothing_spline():
    vals = np.array([4.1e6, 3.2e6, 5.0e6, 2.7e6, 6.3e6, 4.4e6])
    plain = Bearing(2, "plain", None, kxx=1e6, cxx=50.0)  # constants without a table of speeds
    mats = from_ross(stand_in(bearing_elements=[Bearing(1, "wavy", SPEEDS, kxx=vals, cxx=0.0), plain]))
    w = np.linspace(-20.0, 700.0, 37)
    assert np.allclose(mats.bearings[0].value("kxx", w), UnivariateSpline(SPEEDS, vals)(w), rtol=1e-12)
    assert not np.any(mats.bearings[0].value("cxx", w))
    assert sorted(mats.bearings[1].splines) == ["cxx", "cyy", "kxx", "kyy"]
    assert np.all(mats.bearings[1].value("kyy", w) == 1e6) and np.all(mats.bearings[1].value("cxx", w) == 50.0)


def test_bearings_enter_the_linear_matrices_on_their_node():
    mats = from_ross(stand_in())
    M, C, K, G = hand_lateral()
    W = 275.0
    Kb, Cb, Mb = np.zeros_like(K), np.zeros_like(K), np.zeros_like(K)
    x0, y0, x2, y2 = 0, 1, 8, 9
    Kb[x0, x0], Kb[y0, y0] = cubic(W), cubic(W)  # kyy defaults to kxx (ROSS)
    Kb[x0, y0], Kb[y0, x0] = 2e5 * W / 500, -2e5 * W / 500
    Cb[x0, x0], Cb[y0, y0] = 400.0 + W, 500.0 + 0.5 * W
    Kb[x2, x2], Kb[y2, y2] = 3e6 + 2e3 * W, 3e6 + 2e3 * W + parabola(W)
    Cb[x2, x2], Cb[y2, y2] = 300.0 + 0.6 * W, 300.0 + 0.6 * W
    Mb[x2, x2], Mb[y2, y2] = 0.7, 0.7
    got = mats.linear(W)
    for g, want in zip(got, (M + Mb, C + Cb + W * G, K + Kb)):
        assert np.allclose(g, want, rtol=1e-10, atol=1e-10 * np.abs(want).max())


@pytest.mark.parametrize("name, attr", [("mass", "M0"), ("damping", "C0"), ("stiffness", "K0"),
                                        ("gyroscopic", "G0")])
def test_coupling_to_axial_or_torsional_dofs_is_refused(name, attr):
    A = getattr(stand_in(), attr).copy()
    scale = np.abs(A).max()
    # x_1 to z_1, ten times the threshold: refused though the gyroscopic entries are all below 1
    A[6 * 1 + ROSS6["x"], 6 * 1 + ROSS6["z"]] = 10 * DECOUPLED * scale
    with pytest.raises(ValueError, match=f"its {name} matrix couples lateral and axial/torsional dofs"):
        from_ross(stand_in(**{attr: A}))
    A[6 * 1 + ROSS6["x"], 6 * 1 + ROSS6["z"]] = 1e-3 * DECOUPLED * scale  # round-off: none
    want = hand_lateral()[("mass", "damping", "stiffness", "gyroscopic").index(name)]
    assert np.allclose(getattr(from_ross(stand_in(**{attr: A})), name), want, rtol=0, atol=1e-13 * np.abs(want).max())


@settings(max_examples=fuzz_examples(40), deadline=None)
@given(attr=st.sampled_from(["M0", "C0", "K0", "G0"]), lat=st.integers(0, 11), other=st.integers(0, 5),
       rel=st.floats(10 * DECOUPLED, 1.0), pair=st.booleans())
@example(attr="G0", lat=2, other=0, rel=10 * DECOUPLED, pair=True)  # once accepted: G0's entries are below 1
def test_any_coupling_above_decoupled_relative_to_the_matrix_is_refused(attr, lat, other, rel, pair):
    # the threshold is relative to each matrix's largest entry, whatever its units (G0's are below 1);
    # a coupling in a lateral row, alone or with its mirror entry (symmetric M, C, K; skew G)
    A = getattr(stand_in(), attr).copy()
    i, j = lateral_dofs(6, 3)[lat], 6 * (other // 2) + (ROSS6["z"], ROSS6["theta"])[other % 2]
    A[i, j] = rel * np.abs(A).max()
    if pair:
        A[j, i] = -A[i, j] if attr == "G0" else A[i, j]
    with pytest.raises(ValueError, match="couples lateral and axial/torsional dofs"):
        from_ross(stand_in(**{attr: A}))


def test_what_the_bridge_refuses_of_the_stand_in():
    linked = bearings()
    linked[1].n_link = 3
    with pytest.raises(ValueError, match="bearing 'right' at node 2 is linked to node 3; expected bearings to ground"):
        from_ross(stand_in(bearing_elements=linked))
    with pytest.raises(ValueError, match="point masses are not taken by the bridge"):
        from_ross(stand_in(point_mass_elements=[SimpleNamespace(n=3, m=1.0)]))
    with pytest.raises(ValueError, match="expected 4 or 6 dofs per node, found 5"):
        from_ross(stand_in(number_dof=5))
    with pytest.raises(ValueError, match="18 dofs for 2 nodes of 6 dofs: extra nodes are not taken"):
        from_ross(stand_in(nodes=[0, 1]))
    odd = bearings()
    odd[0].kxx_interpolated = lambda w: 1e6  # neither ROSS's spline nor its interp1d
    with pytest.raises(ValueError, match="bearing 'left' kxx: unsupported interpolant function"):
        from_ross(stand_in(bearing_elements=odd))


@pytest.mark.parametrize("missing", ["M0", "K0", "number_dof", "nodes_pos", "disk_elements"])
def test_a_missing_attribute_is_named(missing):
    with pytest.raises(AttributeError, match=missing):
        from_ross(stand_in(**{missing: None}))
