"""Write the finite-element rotors the repository keeps, and ROSS's own unbalance responses of them.

With ROSS installed (``pip install 'contin[ross]'``) this builds, in ROSS,

- the test rig of seed 001 section 2.1 (:func:`contin.model.fem.rig.rig_rotor`) -> ``scenes/data/rig_001.npz``;
- a small rotor with speed-dependent bearings (smoothing-spline and two-point tables, cross-coupled
  stiffness) -> ``tests/model/data/spline_rotor.npz``;

and ROSS's ``Rotor.run_unbalance_response`` of both at several speeds -> ``tests/model/data/ross_reference.npz``
(what the tests compare contin's harmonic balance with, without ROSS). Without ROSS (or with ``--quick``)
it checks that the stored files read back and says so.

    python scripts/figures/rotor/rotor_fe_data.py            # rewrite (needs ROSS)
    python scripts/figures/rotor/rotor_fe_data.py --quick    # check the stored files
"""

from __future__ import annotations

import argparse
import warnings
from pathlib import Path

import numpy as np

from contin.model.fem.matrices import load_matrices
from contin.model.fem.rig import RIG_NODES, rig_rotor, rig_scales
from contin.model.fem.ross_bridge import from_ross, import_ross, lateral_dofs

ROOT = Path(__file__).resolve().parents[3]
RIG_FILE = ROOT / "scenes" / "data" / "rig_001.npz"
SPLINE_FILE = ROOT / "tests" / "model" / "data" / "spline_rotor.npz"
REFERENCE = ROOT / "tests" / "model" / "data" / "ross_reference.npz"
#: speeds [rad/s] of the reference responses: below, near and above the rotors' first criticals
SPEEDS = np.array([20.0, 60.0, 74.0, 118.0, 150.0, 233.0, 400.0])


def spline_rotor():
    """A 7-node steel rotor, a disc at node 3, two bearings whose coefficients vary with the speed."""
    rs = import_ross()
    steel = rs.Material(name="ref_steel", rho=7810.0, E=2.11e11, G_s=8.12e10)
    shaft = [rs.ShaftElement(0.1, idl=0.0, odl=0.03, material=steel, beta=1e-5) for _ in range(6)]
    disc = rs.DiskElement.from_geometry(n=3, material=steel, width=0.03, i_d=0.03, o_d=0.3, tag="disc")
    fr = np.array([0.0, 100.0, 200.0, 300.0, 400.0, 500.0])
    b0 = rs.BearingElement(n=0, kxx=2e6 * (1 + fr / 500), kyy=2.5e6 * (1 + (fr / 500) ** 2), kxy=2e5 * fr / 500,
                           kyx=-2e5 * fr / 500, cxx=400 + fr, cyy=500 + 0.5 * fr, frequency=fr, tag="left")
    b1 = rs.BearingElement(n=6, kxx=[3e6, 4e6], kyy=[3.5e6, 5e6], cxx=[300.0, 600.0], frequency=[0.0, 500.0],
                           tag="right")
    return rs.Rotor(shaft, [disc], [b0, b1])


def _responses(rotor, node: int, magnitude: float, phase: float) -> np.ndarray:
    """ROSS's unbalance response, shape (n_dof_ross, len(SPEEDS)), complex."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = rotor.run_unbalance_response(node, magnitude, phase, frequency=SPEEDS)
    return np.asarray(res.forced_resp)


def write():
    rig = rig_rotor()
    from_ross(rig, "ROSS 2.3: the seed-001 test rig (contin.model.fem.rig)").save(RIG_FILE)
    spl = spline_rotor()
    from_ross(spl, "ROSS 2.3: 7-node rotor with speed-dependent bearings").save(SPLINE_FILE)
    s = rig_scales()
    rig_u = (RIG_NODES["disc"], s["m1"] * 0.5 * s["d0"], 0.3)
    spl_u = (3, 2e-4, -1.0)
    rig_lat, spl_lat = (lateral_dofs(r.number_dof, len(r.nodes)) for r in (rig, spl))
    np.savez_compressed(REFERENCE, speeds=SPEEDS,
                        rig_unbalance=np.array(rig_u), rig=_responses(rig, *rig_u)[rig_lat],
                        spline_unbalance=np.array(spl_u), spline=_responses(spl, *spl_u)[spl_lat])
    print(f"wrote {RIG_FILE.relative_to(ROOT)}, {SPLINE_FILE.relative_to(ROOT)}, {REFERENCE.relative_to(ROOT)}")


def check():
    for path in (RIG_FILE, SPLINE_FILE):
        r = load_matrices(path)
        print(f"{path.relative_to(ROOT)}: {r.n_nodes} nodes, {r.n_dof} lateral dofs, {len(r.bearings)} bearings "
              f"({r.source})")
    with np.load(REFERENCE) as z:
        print(f"{REFERENCE.relative_to(ROOT)}: ROSS's unbalance responses at {z['speeds'].size} speeds")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="only check the stored files")
    args = ap.parse_args(argv)
    if not args.quick:
        try:
            import_ross()
        except ImportError as exc:
            print(f"not rewritten: {exc}")
        else:
            write()
    check()


if __name__ == "__main__":
    main()
