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

import io
import os
import stat
import zipfile
import zlib
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
        if np.iscomplexobj(self.positions):
            raise ValueError("rotor positions: expected real numbers, found complex ones")
        pos = np.asarray(self.positions, float).reshape(-1)
        object.__setattr__(self, "positions", pos)
        n = 4 * pos.size
        if pos.size < 2 or not np.all(np.isfinite(pos)) or np.any(np.diff(pos) <= 0):
            raise ValueError(f"rotor positions: expected at least two increasing finite node positions, found {pos}")
        for name in ("mass", "damping", "stiffness", "gyroscopic"):
            if np.iscomplexobj(getattr(self, name)):  # float() would drop the imaginary part without a word
                raise ValueError(f"rotor {name}: expected real entries, found complex ones")
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


#: largest rotor file read (bytes)
MAX_FILE_BYTES = 256 * 2**20
#: largest array of a rotor file, uncompressed (bytes): four dense matrices of 2048 nodes (8192 dofs) are 512 MiB each
MAX_ARRAY_BYTES = 512 * 2**20
#: largest sum of the arrays read from one rotor file, uncompressed (bytes)
MAX_TOTAL_BYTES = 2 * 2**30
#: largest ratio of an array's size to its compressed size: deflate cannot compress beyond about 1032 to 1,
#: so a greater ratio is a header that claims more than its data holds
MAX_RATIO = 1100
#: largest number of entries of a bearing's spline table (knots or coefficients)
MAX_SPLINE = 100_000
#: the arrays that are text (numpy's unicode strings); every other array holds real numbers
_TEXT = ("format", "source", "bearing_tags")
_COMPRESSIONS = (zipfile.ZIP_STORED, zipfile.ZIP_DEFLATED)


def _read_regular(path: Path) -> bytes:
    """The bytes of ``path`` if it is a regular file (links followed) of at most :data:`MAX_FILE_BYTES`."""
    fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0))
    with os.fdopen(fd, "rb") as fh:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise ValueError(f"{path}: expected a regular file (a rotor matrix file), found a "
                             f"{'directory' if stat.S_ISDIR(st.st_mode) else 'device, pipe or socket'}")
        if st.st_size > MAX_FILE_BYTES:
            raise ValueError(f"{path}: expected a rotor file of at most {MAX_FILE_BYTES} bytes, found {st.st_size}")
        os.set_blocking(fd, True)
        data = fh.read(st.st_size + 1)  # (a read of the cap would reserve the cap)
    if len(data) > st.st_size:
        raise ValueError(f"{path}: a rotor file that grew while it was read")
    return data


def _expected_shape(name: str, n_nodes: int | None, n_bearings: int | None):
    """What array ``name`` must be: ``(shape or None for any 1-d, kind)``, ``kind`` in 'real', 'int', 'text'."""
    n = None if n_nodes is None else 4 * n_nodes
    fixed = {"format": ((), "text"), "source": ((), "text"), "positions": (None, "real"),
             "bearing_nodes": (None, "int"), "bearing_tags": ((n_bearings,), "text"), "discs": ("discs", "real")}
    if name in fixed:
        return fixed[name]
    if name in ("mass", "damping", "stiffness", "gyroscopic"):
        return (n, n), "real"
    if name.startswith("bearing") and name.endswith("_k"):
        return (), "int"
    return None, "real"  # a spline's knots or coefficients


class _Arrays:
    """The arrays of a rotor ``.npz`` read one by one, each checked before it is inflated."""

    def __init__(self, path: Path, data: bytes):
        self.path = path
        if data[:6] == b"\x93NUMPY":
            raise ValueError(f"{path}: not a rotor matrix file (.npz, a zip archive of arrays written by "
                             "RotorMatrices.save): a single .npy array")
        try:
            self.zip = zipfile.ZipFile(io.BytesIO(data))
            infos = self.zip.infolist()
        except (zipfile.BadZipFile, zipfile.LargeZipFile, EOFError, ValueError, OSError) as exc:
            raise ValueError(f"{path}: not a rotor matrix file (.npz written by contin): not a complete zip "
                             f"archive ({exc})") from None
        self.members = {i.filename[:-4]: i for i in infos if i.filename.endswith(".npy")}
        self.total = 0

    def __contains__(self, name: str) -> bool:
        return name in self.members

    def read(self, name: str, shape, kind: str) -> np.ndarray:
        """Array ``name``, its zip entry and ``.npy`` header checked first (sizes, dtype, shape)."""
        info, where = self.members[name], f"{self.path}: array '{name}'"
        if info.compress_type not in _COMPRESSIONS:
            raise ValueError(f"{where}: expected a stored or deflated zip member (as numpy writes), found compression "
                             f"method {info.compress_type}")
        if info.file_size > MAX_ARRAY_BYTES or self.total + info.file_size > MAX_TOTAL_BYTES:
            raise ValueError(f"{where}: expected at most {MAX_ARRAY_BYTES} bytes uncompressed (and "
                             f"{MAX_TOTAL_BYTES} for the whole file), found {info.file_size}")
        if info.file_size > MAX_RATIO * max(info.compress_size, 1) + 4096:
            raise ValueError(f"{where}: its zip header claims {info.file_size} bytes from {info.compress_size} "
                             f"compressed, more than deflate can give (a damaged or forged file)")
        try:
            with self.zip.open(info) as fh:
                version = np.lib.format.read_magic(fh)
                if version == (1, 0):
                    head, fortran, dtype = np.lib.format.read_array_header_1_0(fh)
                elif version == (2, 0):
                    head, fortran, dtype = np.lib.format.read_array_header_2_0(fh)
                else:
                    raise ValueError(f"an .npy format version 1.0 or 2.0, found {version}")
                head = tuple(int(k) for k in head)
                self._check(where, head, dtype, shape, kind)
                nbytes = int(np.prod(head, dtype=np.int64)) * dtype.itemsize
                raw = fh.read(nbytes + 1)
        except (zipfile.BadZipFile, zlib.error, EOFError, OSError) as exc:
            raise ValueError(f"{where}: cannot be read ({exc}): a damaged or truncated file") from None
        except ValueError as exc:
            raise ValueError(f"{where}: expected an .npy array ({exc})") from None
        if len(raw) != nbytes:
            raise ValueError(f"{where}: expected {nbytes} bytes of data for shape {head}, found {len(raw)} (a damaged "
                             "or truncated file)")
        self.total += nbytes
        return np.frombuffer(raw, dtype).reshape(head, order="F" if fortran else "C").copy()

    @staticmethod
    def _check(where: str, head, dtype, shape, kind: str) -> None:
        if dtype.hasobject or dtype.fields is not None:
            raise ValueError(f"plain numbers, found dtype {dtype} (objects or records)")
        if dtype.kind == "c":
            raise ValueError(f"real numbers, found complex dtype {dtype} (an imaginary part would be dropped)")
        want = {"real": "fiu", "int": "iu", "text": "U"}[kind]
        if dtype.kind not in want:
            what = {"real": "real numbers", "int": "integers", "text": "text"}[kind]
            raise ValueError(f"{what}, found dtype {dtype}")
        if shape == "discs":
            ok = (len(head) == 2 and head[1] == 4) or head in ((0,), (4,))  # rows (node, m, Ip, Id)
        elif shape is None:
            ok = len(head) == 1
        else:
            ok = head == shape
        if not ok:
            raise ValueError(f"shape {'(k, 4)' if shape == 'discs' else '1-d' if shape is None else shape}, "
                             f"found {head}")
        nbytes = int(np.prod(head, dtype=np.float64)) * dtype.itemsize
        if nbytes > MAX_ARRAY_BYTES:
            raise ValueError(f"at most {MAX_ARRAY_BYTES} bytes, found shape {head} of {dtype} ({nbytes:.4g} bytes)")


def load_matrices(path, data: bytes | None = None) -> RotorMatrices:
    """Read a file written by :meth:`RotorMatrices.save`.

    The file is read only if it is a regular file of at most
    :data:`MAX_FILE_BYTES`; each array's zip entry (its uncompressed size,
    compression ratio) and ``.npy`` header (dtype, shape: ``4 n x 4 n``
    matrices for ``n`` node positions) are checked before its data is
    inflated, so a forged header or a zip bomb is refused without being
    expanded. Complex arrays are refused (their imaginary parts would be
    dropped); no pickle is read.

    Parameters
    ----------
    path : path
        The file (named in messages).
    data : bytes, optional
        Its content, already read (then ``path`` is not opened).

    Raises
    ------
    ValueError
        Naming the file and what is missing or malformed (an unreadable file
        gives an ``OSError``).
    """
    path = Path(path)
    z = _Arrays(path, _read_regular(path) if data is None else bytes(data))
    found = str(z.read("format", (), "text")) if "format" in z else "none"
    if found != "contin-rotor-1":
        raise ValueError(f"{path}: not a rotor matrix file: expected format 'contin-rotor-1', found {found!r}")
    missing = [k for k in ("positions", "mass", "damping", "stiffness", "gyroscopic", "bearing_nodes") if k not in z]
    if missing:
        raise ValueError(f"{path}: missing arrays {missing}")
    positions = z.read("positions", None, "real")
    nodes = z.read("bearing_nodes", None, "int")
    arrays = {k: z.read(k, *_expected_shape(k, positions.size, nodes.size)) for k in
              ("mass", "damping", "stiffness", "gyroscopic", "discs", "source", "bearing_tags") if k in z}
    bearings = []
    tags = arrays.get("bearing_tags", np.array([""] * nodes.size))
    for i, node in enumerate(nodes):
        splines = {}
        for name in COEFFICIENTS:
            key = f"bearing{i}_{name}"
            if f"{key}_t" in z:
                t, c = (z.read(f"{key}_{p}", None, "real") for p in "tc")
                if max(t.size, c.size) > MAX_SPLINE:
                    raise ValueError(f"{path}: array '{key}_t': expected at most {MAX_SPLINE} entries, found {t.size}")
                splines[name] = (t, c, int(z.read(f"{key}_k", (), "int")))
        bearings.append(BearingTable(int(node), splines, str(tags[i])))
    return RotorMatrices(positions, arrays["mass"], arrays["damping"], arrays["stiffness"], arrays["gyroscopic"],
                         tuple(bearings), arrays.get("discs", np.zeros((0, 4))),
                         str(arrays.get("source", path.name)))
