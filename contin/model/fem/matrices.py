"""The lateral matrices of a finite-element rotor, in SI units, and their ``.npz`` file.

Dofs are ordered node by node, four per node, as in ROSS: ``x``, ``y``
(translations, m) and ``alpha``, ``beta`` (rotations about ``x`` and ``y``,
rad). ROSS's axial and torsional dofs (``z``, ``theta``) are left out: its
shaft, disc and bearing elements do not couple them to the lateral ones
(:func:`contin.model.fem.ross_bridge.from_ross` checks it).

The equations of motion at the speed ``Omega`` [rad/s] are

    M x'' + (C + sum_b C_b(Omega) + Omega G) x' + (K + sum_b K_b(Omega)) x = f(t),

with ``M``, ``C``, ``K`` of the shaft and discs, ``G`` the gyroscopic matrix
and, for each bearing ``b`` at a node, 2 x 2 blocks of stiffness, damping and
mass coefficients on its ``(x, y)`` that are B-splines of the speed (ROSS's
own interpolants, :mod:`contin.model.fem.coefficients`). This is the matrix
ROSS factors in ``Rotor.transfer_matrix``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

__all__ = ["BearingTable", "RotorMatrices", "COEFFICIENTS", "DOFS_PER_NODE", "dof_names", "load_matrices"]

#: the lateral dofs of a node, in order
DOFS_PER_NODE = ("x", "y", "alpha", "beta")
#: the bearing coefficients: stiffness, damping and mass, on the node's (x, y)
COEFFICIENTS = tuple(f"{kind}{a}{b}" for kind in "kcm" for a in "xy" for b in "xy")


def dof_names(n_nodes: int) -> tuple:
    """``x_0, y_0, alpha_0, beta_0, x_1, ...``."""
    return tuple(f"{d}_{i}" for i in range(n_nodes) for d in DOFS_PER_NODE)


@dataclass(frozen=True, eq=False)
class BearingTable:
    """A bearing at a node: each coefficient a B-spline of the speed [rad/s].

    Parameters
    ----------
    node : int
    splines : dict
        Coefficient name (:data:`COEFFICIENTS`) -> ``(knots, coeffs, degree)``;
        a coefficient left out is zero.
    tag : str
    """

    node: int
    splines: dict
    tag: str = ""

    def value(self, name: str, speed) -> np.ndarray:
        """The coefficient ``name`` at ``speed`` (scalar or array)."""
        from scipy.interpolate import BSpline

        if name not in self.splines:
            return np.zeros_like(np.asarray(speed, float))
        t, c, k = self.splines[name]
        return BSpline(t, c, k, extrapolate=True)(speed)


@dataclass(frozen=True, eq=False)
class RotorMatrices:
    """A finite-element rotor's lateral matrices (SI) and bearing tables.

    Parameters
    ----------
    positions : ndarray, shape (n_nodes,)
        Axial node positions [m].
    mass, damping, stiffness, gyroscopic : ndarray, shape (4 n_nodes, 4 n_nodes)
        Shaft and discs (no bearings); ``gyroscopic`` is multiplied by the speed.
    bearings : tuple of BearingTable
    discs : ndarray, shape (n_discs, 4)
        Rows ``(node, mass [kg], Ip, Id [kg m^2])``, for reports.
    source : str
        Where the matrices came from.
    """

    positions: np.ndarray
    mass: np.ndarray
    damping: np.ndarray
    stiffness: np.ndarray
    gyroscopic: np.ndarray
    bearings: tuple = ()
    discs: np.ndarray = field(default_factory=lambda: np.zeros((0, 4)))
    source: str = ""

    def __post_init__(self):
        pos = np.asarray(self.positions, float).reshape(-1)
        object.__setattr__(self, "positions", pos)
        n = 4 * pos.size
        if pos.size < 2 or not np.all(np.isfinite(pos)) or np.any(np.diff(pos) <= 0):
            raise ValueError(f"rotor positions: expected at least two increasing finite node positions, found {pos}")
        for name in ("mass", "damping", "stiffness", "gyroscopic"):
            A = np.asarray(getattr(self, name), float)
            if A.shape != (n, n):
                raise ValueError(f"rotor {name}: expected a {n}x{n} matrix (4 dofs at each of {pos.size} nodes), "
                                 f"found shape {A.shape}")
            if not np.all(np.isfinite(A)):
                raise ValueError(f"rotor {name}: expected finite entries")
            object.__setattr__(self, name, A)
        for b in self.bearings:
            if not 0 <= b.node < pos.size:
                raise ValueError(f"rotor bearing {b.tag or ''} at node {b.node}: expected a node in 0..{pos.size - 1}")
            for k in b.splines:
                if k not in COEFFICIENTS:
                    raise ValueError(f"rotor bearing at node {b.node}: unknown coefficient '{k}'; expected some of "
                                     f"{list(COEFFICIENTS)}")
        object.__setattr__(self, "discs", np.asarray(self.discs, float).reshape(-1, 4))

    @property
    def n_nodes(self) -> int:
        return int(self.positions.size)

    @property
    def n_dof(self) -> int:
        return 4 * self.n_nodes

    @property
    def dof_names(self) -> tuple:
        return dof_names(self.n_nodes)

    def node_dofs(self, node: int) -> tuple:
        """The ``(x, y)`` dof indices of ``node``."""
        if not 0 <= int(node) < self.n_nodes:
            raise ValueError(f"node {node}: expected a node in 0..{self.n_nodes - 1}")
        return 4 * int(node), 4 * int(node) + 1

    def bearing_matrices(self, speed: float):
        """``(M_b, C_b, K_b)``: every bearing's coefficients at ``speed`` [rad/s], each (n, n)."""
        out = [np.zeros((self.n_dof, self.n_dof)) for _ in range(3)]
        for b in self.bearings:
            ix, iy = self.node_dofs(b.node)
            idx = (ix, iy)
            for name in b.splines:
                kind, r, c = name[0], "xy".index(name[1]), "xy".index(name[2])
                out["mck".index(kind)][idx[r], idx[c]] += float(b.value(name, speed))
        return tuple(out)

    def linear(self, speed: float):
        """``(M, C + Omega G, K)`` with the bearings at ``speed`` [rad/s], each (n, n): ROSS's ``M(speed)``,
        ``C(speed) + speed G()``, ``K(speed)`` restricted to the lateral dofs."""
        Mb, Cb, Kb = self.bearing_matrices(speed)
        return self.mass + Mb, self.damping + Cb + speed * self.gyroscopic, self.stiffness + Kb

    def unbalance_response(self, speed: float, node: int, magnitude: float, phase: float = 0.0) -> np.ndarray:
        """Complex amplitudes ``X`` (``x(t) = Re(X e^{i Omega t})``) of the linear rotor under an unbalance.

        The force at ``node`` is ``magnitude Omega^2 (cos, sin)(Omega t + phase)``
        (ROSS's ``Rotor._unbalance_force``).

        Returns
        -------
        ndarray, shape (n,), complex
        """
        M, C, K = self.linear(speed)
        f = np.zeros(self.n_dof, complex)
        ix, iy = self.node_dofs(node)
        f[ix] = magnitude * speed**2 * np.exp(1j * phase)
        f[iy] = -1j * magnitude * speed**2 * np.exp(1j * phase)
        return np.linalg.solve(K - speed**2 * M + 1j * speed * C, f)

    # -- file ---------------------------------------------------------------------
    def save(self, path) -> None:
        """Write an ``.npz`` file (arrays only: read back without pickles)."""
        data = {"format": np.array("contin-rotor-1"), "positions": self.positions, "mass": self.mass,
                "damping": self.damping, "stiffness": self.stiffness, "gyroscopic": self.gyroscopic,
                "discs": self.discs, "source": np.array(self.source),
                "bearing_nodes": np.array([b.node for b in self.bearings], int),
                "bearing_tags": np.array([b.tag for b in self.bearings], dtype=str)}
        for i, b in enumerate(self.bearings):
            for name, (t, c, k) in b.splines.items():
                data[f"bearing{i}_{name}_t"] = np.asarray(t, float)
                data[f"bearing{i}_{name}_c"] = np.asarray(c, float)
                data[f"bearing{i}_{name}_k"] = np.array(int(k))
        with open(path, "wb") as fh:
            np.savez_compressed(fh, **data)


def load_matrices(path) -> RotorMatrices:
    """Read a file written by :meth:`RotorMatrices.save`.

    Raises
    ------
    ValueError
        Naming the file and what is missing or malformed (an unreadable file
        gives an ``OSError``).
    """
    path = Path(path)
    try:
        with np.load(path, allow_pickle=False) as z:
            data = {k: z[k] for k in z.files}
    except (ValueError, EOFError) as exc:
        raise ValueError(f"{path}: not a rotor matrix file (.npz written by contin): {exc}") from None
    if str(data.get("format", "")) != "contin-rotor-1":
        raise ValueError(f"{path}: not a rotor matrix file: expected format 'contin-rotor-1', found "
                         f"{str(data.get('format', 'none'))!r}")
    missing = [k for k in ("positions", "mass", "damping", "stiffness", "gyroscopic", "bearing_nodes") if k not in data]
    if missing:
        raise ValueError(f"{path}: missing arrays {missing}")
    bearings = []
    tags = data.get("bearing_tags", np.array([""] * len(data["bearing_nodes"])))
    for i, node in enumerate(data["bearing_nodes"]):
        splines = {}
        for name in COEFFICIENTS:
            if f"bearing{i}_{name}_t" in data:
                splines[name] = (data[f"bearing{i}_{name}_t"], data[f"bearing{i}_{name}_c"],
                                 int(data[f"bearing{i}_{name}_k"]))
        bearings.append(BearingTable(int(node), splines, str(tags[i])))
    return RotorMatrices(data["positions"], data["mass"], data["damping"], data["stiffness"], data["gyroscopic"],
                         tuple(bearings), data.get("discs", np.zeros((0, 4))), str(data.get("source", path.name)))
