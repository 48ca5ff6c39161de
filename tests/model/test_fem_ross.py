"""The bridge against ROSS itself (tier ``ross``: skipped where ROSS is not installed).

    pip install 'contin[ross]' && python -m pytest -q -m ross tests/model/test_fem_ross.py
"""

import warnings
from pathlib import Path

import numpy as np
import pytest

pytestmark = pytest.mark.ross

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def ross():
    from contin.model.fem.ross_bridge import import_ross

    try:
        return import_ross()
    except ImportError as exc:
        pytest.skip(str(exc))


def test_rig_from_ross_matches_its_unbalance_response_and_the_stored_file(ross):
    from contin.hb.problem import HarmonicBalance, HBOptions
    from contin.model.fem.builder import Unbalance, Units, fe_rotor_model
    from contin.model.fem.matrices import load_matrices
    from contin.model.fem.rig import RIG_NODES, rig_rotor
    from contin.model.fem.ross_bridge import from_ross, lateral_dofs

    rotor = rig_rotor()
    mats = from_ross(rotor)
    stored = load_matrices(ROOT / "scenes" / "data" / "rig_001.npz")
    for name in ("mass", "damping", "stiffness", "gyroscopic"):
        assert np.allclose(getattr(mats, name), getattr(stored, name), rtol=0, atol=1e-12 * np.abs(
            getattr(stored, name)).max())
    units = Units(1e-3, 7.8, 74.5)
    model = fe_rotor_model(mats, unbalance=[Unbalance(RIG_NODES["disc"], 3.9e-3, 0.7)], units=units)
    hb = HarmonicBalance(model, "w", HBOptions(harmonics=1))
    speeds = np.array([30.0, 74.0, 140.0, 300.0])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        resp = rotor.run_unbalance_response(RIG_NODES["disc"], 3.9e-3, 0.7, frequency=speeds).forced_resp
    lat = lateral_dofs(rotor.number_dof, len(rotor.nodes))
    for j, W in enumerate(speeds):
        u = hb.linear_solution(W / units.frequency).reshape(3, model.n_dof)
        X = model.fe.physical(u[1] - 1j * u[2])
        assert np.abs(X - resp[lat, j]).max() < 1e-6 * np.abs(resp[lat, j]).max()


def test_speed_dependent_bearings_and_rotor_files(ross, tmp_path):
    from contin.model.fem.ross_bridge import from_ross, lateral_dofs, load_rotor

    import importlib.util

    spec = importlib.util.spec_from_file_location("rotor_fe_data", ROOT / "scripts" / "figures" / "rotor" / "rotor_fe_data.py")
    rig_data = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(rig_data)
    rotor = rig_data.spline_rotor()
    mats = from_ross(rotor)
    lat = lateral_dofs(rotor.number_dof, len(rotor.nodes))
    for W in (0.0, 55.0, 250.0, 480.0, 650.0):  # inside the tables, between their points and beyond
        M, C, K = mats.linear(W)
        assert np.allclose(K, rotor.K(W)[np.ix_(lat, lat)], rtol=1e-12, atol=1e-12 * np.abs(K).max())
        assert np.allclose(C, (rotor.C(W) + W * rotor.G())[np.ix_(lat, lat)], rtol=1e-12,
                           atol=1e-12 * np.abs(C).max())
        assert np.allclose(M, rotor.M(W)[np.ix_(lat, lat)], rtol=1e-12)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        rotor.save(str(tmp_path / "rotor.toml"))
    again = load_rotor(tmp_path / "rotor.toml")
    assert np.allclose(again.linear(250.0)[2], mats.linear(250.0)[2], rtol=1e-12)


def test_what_the_bridge_refuses(ross):
    from contin.model.fem.ross_bridge import from_ross

    steel = ross.Material(name="refuse_steel", rho=7800.0, E=2e11, G_s=8e10)
    shaft = [ross.ShaftElement(0.2, idl=0.0, odl=0.03, material=steel) for _ in range(3)]
    bearings = [ross.BearingElement(n=0, kxx=1e7, cxx=0.0), ross.BearingElement(n=3, kxx=1e7, cxx=0.0)]
    point = ross.PointMass(n=4, m=1.0)
    linked = [ross.BearingElement(n=0, kxx=1e7, cxx=0.0), ross.BearingElement(n=3, kxx=1e7, cxx=0.0, n_link=4),
              ross.BearingElement(n=4, kxx=1e7, cxx=0.0)]
    with pytest.raises(ValueError, match="linked to node 4; expected bearings to ground"):
        from_ross(ross.Rotor(shaft, [], linked, [point]))  # a support on a point mass off the shaft
    assert from_ross(ross.Rotor(shaft, [], bearings)).n_nodes == 4
