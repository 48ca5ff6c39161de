"""The test rig of Inagaki, Ishida & Hayashi (2005), section 2.1, as a ROSS finite-element rotor.

A vertical steel shaft (diameter 16 mm, length 900 mm) carries a disc
(diameter 480 mm, thickness 5.5 mm) at ``a:b = 11:7`` (550 mm from the upper
bearing, 350 mm from the lower one). Both ends run in self-aligning ball
bearings: the upper one is a pinned support (a stiff spring on ``x, y``, no
moment), the lower one sits in a radial clearance of its casing: a holder
mass with the bearing damping and no spring; the casing's contact is added
by :func:`contin.model.fem.builder.fe_rotor_model`. The disc damping is a
damper at the disc node. Values not printed in the paper (the steel's
moduli, the upper bearing's stiffness, a small stiffness-proportional shaft
damping) are :data:`RIG` entries; the dimensional contact, unbalance, side
load and damping values are the paper's nondimensional ones (its eq. 10 and
Fig. 3 data) times its scales ``d0 = 1 mm``, ``m1``, ``wn = sqrt(ks1/m1)``.
"""

from __future__ import annotations

import math

from contin.model.fem.builder import Contact, SideLoad, Unbalance
from contin.model.fem.ross_bridge import import_ross

__all__ = ["RIG", "rig_scales", "rig_rotor", "rig_items", "RIG_NODES"]

#: geometry and values of the rig (SI)
RIG = {"length": 0.9, "diameter": 0.016, "disc_diameter": 0.48, "disc_width": 0.0055, "a": 0.55, "b": 0.35,
       "E": 2.06e11, "G": 7.94e10, "rho": 7850.0, "elements": 18, "upper_stiffness": 1e9, "shaft_beta": 1e-6,
       # the paper's nondimensional values (Fig. 3)
       "delta": 0.1, "kbn": 12881.0, "cbn": 0.515, "e": 0.5, "f0": 0.5, "c1": 0.005, "c2": 0.05, "beta": 0.019,
       "d0": 1e-3}

#: the disc node and the lower (clearance) bearing node: nodes 0.05 m apart from the upper bearing
RIG_NODES = {"upper": 0, "disc": 11, "lower": 18}


def rig_scales() -> dict:
    """The paper's scales (eq. 2, 10): disc mass ``m1`` [kg], ``ks1`` [N/m], ``wn`` [rad/s], ``d0`` [m]."""
    r = RIG
    m1 = r["rho"] * math.pi * (r["disc_diameter"] ** 2 - r["diameter"] ** 2) / 4 * r["disc_width"]
    I = math.pi * r["diameter"] ** 4 / 64
    ks1 = 3 * r["E"] * I * r["length"] / (r["a"] ** 2 * r["b"] ** 2)
    return {"m1": m1, "ks1": ks1, "wn": math.sqrt(ks1 / m1), "d0": r["d0"]}


def rig_rotor():
    """The rig as a ``ross.Rotor`` (needs ROSS: :func:`contin.model.fem.ross_bridge.import_ross`)."""
    rs = import_ross()
    r, s = RIG, rig_scales()
    steel = rs.Material(name="rig_steel", rho=r["rho"], E=r["E"], G_s=r["G"])
    n = r["elements"]
    shaft = [rs.ShaftElement(r["length"] / n, idl=0.0, odl=r["diameter"], material=steel, beta=r["shaft_beta"])
             for _ in range(n)]
    disc = rs.DiskElement.from_geometry(n=RIG_NODES["disc"], material=steel, width=r["disc_width"],
                                        i_d=r["diameter"], o_d=r["disc_diameter"], tag="disc")
    mwn = s["m1"] * s["wn"]
    upper = rs.BearingElement(n=RIG_NODES["upper"], kxx=r["upper_stiffness"], cxx=0.0, tag="upper")
    disc_damper = rs.BearingElement(n=RIG_NODES["disc"], kxx=0.0, cxx=r["c1"] * mwn, tag="disc_damping")
    lower = rs.BearingElement(n=RIG_NODES["lower"], kxx=0.0, cxx=r["c2"] * mwn, mxx=r["beta"] * s["m1"], tag="lower")
    return rs.Rotor(shaft, [disc], [upper, disc_damper, lower])


def rig_items() -> dict:
    """The contact, unbalance and side load of the paper's Fig. 3 case in SI, for
    :func:`contin.model.fem.builder.fe_rotor_model`."""
    r, s = RIG, rig_scales()
    kscale, cscale = s["ks1"], s["m1"] * s["wn"]
    return {"contact": Contact(RIG_NODES["lower"], r["delta"] * s["d0"], r["kbn"] * kscale, r["cbn"] * cscale),
            "unbalance": (Unbalance(RIG_NODES["disc"], s["m1"] * r["e"] * s["d0"]),),
            "side_load": SideLoad(RIG_NODES["disc"], (0.0, r["f0"] * s["ks1"] * s["d0"]))}
