"""Rotors from ROSS (``ross-rotordynamics``, the optional extra ``contin[ross]``).

:func:`from_ross` reads a ``ross.Rotor`` into :class:`~contin.model.fem.matrices.RotorMatrices`:
the shaft-and-disc matrices without bearings (ROSS's ``M0``, ``C0``, ``K0``,
``G0``), each bearing's coefficient interpolants (as B-splines, so they equal
ROSS's at every speed) and the discs. :func:`load_rotor` reads a rotor file:
a ``.npz`` written by :meth:`RotorMatrices.save` needs no ROSS; a rotor file
ROSS writes (``Rotor.save``, ``.toml`` or ``.json``) is read by ROSS.
"""

from __future__ import annotations

import contextlib
import io
import warnings
from pathlib import Path

import numpy as np

from contin.model.fem.coefficients import spline_of
from contin.model.fem.matrices import COEFFICIENTS, BearingTable, RotorMatrices, load_matrices

__all__ = ["from_ross", "load_rotor", "import_ross", "lateral_dofs", "ROSS_MISSING"]

ROSS_MISSING = ("this needs ROSS (ross-rotordynamics), which is not installed: pip install 'contin[ross]' "
                "(or read a rotor .npz file written by contin, which needs no ROSS)")
#: coupling between lateral and axial/torsional dofs counted as none, relative to the largest entry
DECOUPLED = 1e-12


def import_ross():
    """The ``ross`` module, imported quietly (it prints a message about REFPROP on import).

    Raises
    ------
    ImportError
        With :data:`ROSS_MISSING`.
    """
    try:
        with warnings.catch_warnings(), contextlib.redirect_stdout(io.StringIO()):
            warnings.simplefilter("ignore")
            import ross
    except ImportError as exc:
        raise ImportError(f"{ROSS_MISSING} ({exc})") from None
    return ross


def lateral_dofs(n_dof_node: int, n_nodes: int) -> np.ndarray:
    """ROSS's indices of the lateral dofs ``x, y, alpha, beta`` of every node (``n_dof_node`` 6 or 4)."""
    per = {6: (0, 1, 3, 4), 4: (0, 1, 2, 3)}[n_dof_node]
    return np.array([n_dof_node * i + d for i in range(n_nodes) for d in per], dtype=int)


def from_ross(rotor, source: str = "ross.Rotor") -> RotorMatrices:
    """The lateral matrices and bearing tables of a ``ross.Rotor``.

    Parameters
    ----------
    rotor : ross.Rotor
    source : str
        Recorded in the result.

    Raises
    ------
    ValueError
        For what the bridge does not take: point masses or bearings linked to
        another node (extra nodes beyond the shaft's), lateral dofs coupled to
        axial or torsional ones, bearings with an axial/torsional coefficient
        only are fine (dropped with those dofs).
    """
    for b in rotor.bearing_elements:
        if getattr(b, "n_link", None) is not None:
            raise ValueError(f"ross.Rotor: bearing '{b.tag}' at node {b.n} is linked to node {b.n_link}; "
                             "expected bearings to ground")
    if getattr(rotor, "point_mass_elements", None):
        raise ValueError("ross.Rotor: point masses are not taken by the bridge (they add nodes off the shaft); "
                         "put the mass on a shaft node (a disc or a bearing's mxx, myy)")
    nd = int(rotor.number_dof)
    if nd not in (4, 6):
        raise ValueError(f"ross.Rotor: expected 4 or 6 dofs per node, found {nd}")
    n_nodes = len(rotor.nodes)
    if rotor.M0.shape[0] != nd * n_nodes:
        raise ValueError(f"ross.Rotor: {rotor.M0.shape[0]} dofs for {n_nodes} nodes of {nd} dofs: extra nodes "
                         "are not taken by the bridge")
    lat = lateral_dofs(nd, n_nodes)
    other = np.setdiff1d(np.arange(nd * n_nodes), lat)
    mats = {}
    for name, A in (("mass", rotor.M0), ("damping", rotor.C0), ("stiffness", rotor.K0), ("gyroscopic", rotor.G0)):
        A = np.asarray(A, float)
        # relative to this matrix's largest entry, whatever its size (a small rotor's G0 is far below 1)
        if other.size and np.abs(A[np.ix_(lat, other)]).max(initial=0.0) > DECOUPLED * np.abs(A).max(initial=0.0):
            raise ValueError(f"ross.Rotor: its {name} matrix couples lateral and axial/torsional dofs; "
                             "the bridge takes lateral dynamics only")
        mats[name] = A[np.ix_(lat, lat)]
    bearings = []
    for b in rotor.bearing_elements:
        splines = {}
        for name in COEFFICIENTS:
            interp = getattr(b, f"{name}_interpolated", None)
            if interp is None:
                continue
            t, c, k = spline_of(interp, f"bearing '{b.tag}' {name}")
            if k == 0 and c[0] == 0.0:
                continue
            splines[name] = (t, c, k)
        bearings.append(BearingTable(int(b.n), splines, str(b.tag)))
    discs = [(d.n, d.m, d.Ip, d.Id) for d in rotor.disk_elements]
    return RotorMatrices(np.asarray(rotor.nodes_pos, float), mats["mass"], mats["damping"], mats["stiffness"],
                         mats["gyroscopic"], tuple(bearings), np.array(discs, float).reshape(-1, 4), source)


def load_rotor(path) -> RotorMatrices:
    """A rotor from a file: ``.npz`` (:meth:`RotorMatrices.save`, no ROSS needed) or a ROSS rotor file.

    Raises
    ------
    OSError
        The file cannot be read.
    ImportError
        A ROSS file without ROSS installed (:data:`ROSS_MISSING`).
    ValueError
        A malformed file, naming it.
    """
    path = Path(path)
    if not path.is_file():
        raise OSError(f"{path}: no such rotor file")
    if path.suffix == ".npz":
        return load_matrices(path)
    if path.suffix not in (".toml", ".json"):
        raise ValueError(f"{path}: expected a rotor file .npz (contin) or .toml/.json (ROSS's Rotor.save)")
    ross = import_ross()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            rotor = ross.Rotor.load(str(path))
    except Exception as exc:  # noqa: BLE001 - ROSS raises many kinds on a bad file
        raise ValueError(f"{path}: ROSS could not read it as a rotor: {type(exc).__name__}: {exc}") from None
    return from_ross(rotor, source=path.name)
