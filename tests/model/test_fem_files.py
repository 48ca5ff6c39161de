"""Rotor ``.npz`` files: every array's zip entry and ``.npy`` header checked before its data is inflated
(load_matrices in contin/model/fem/matrices.py); what is not a rotor file is a message naming the file."""

import io
import tracemalloc
import zipfile
from pathlib import Path

import numpy as np
import pytest

import contin.model.fem.matrices as matrices
from contin.model.fem.matrices import RotorMatrices, load_matrices

DATA = Path(__file__).resolve().parent / "data"
ROTOR = DATA / "spline_rotor.npz"


def _members() -> dict:
    with np.load(ROTOR, allow_pickle=False) as z:
        return {k: z[k] for k in z.files}


def _npy(array=None, header=None, data: bytes | None = None) -> bytes:
    """The bytes of an ``.npy`` file: of ``array``, or a ``header`` dict followed by ``data``."""
    buf = io.BytesIO()
    if array is not None:
        np.lib.format.write_array(buf, array, allow_pickle=False)
    else:
        np.lib.format.write_array_header_1_0(buf, header)
        buf.write(data)
    return buf.getvalue()


def _zip(path: Path, members: dict, raw: dict | None = None) -> Path:
    """An ``.npz`` of ``members`` (arrays), with some members given as raw ``.npy`` bytes."""
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as zf:
        for name, value in members.items():
            zf.writestr(name + ".npy", (raw or {}).get(name) or _npy(value))
        for name, value in (raw or {}).items():
            if name not in members:
                zf.writestr(name + ".npy", value)
    return path


def test_a_shipped_rotor_file_reads_as_before(tmp_path):
    r = load_matrices(ROTOR)
    z = _members()  # the plain read, as the file was written
    assert np.array_equal(r.stiffness, z["stiffness"]) and np.array_equal(r.positions, z["positions"])
    assert r.n_nodes == z["positions"].size == 7 and r.discs.shape == z["discs"].shape
    assert [b.node for b in r.bearings] == [int(k) for k in z["bearing_nodes"]]
    t, c, k = r.bearings[0].splines["kxx"]
    assert np.array_equal(t, z["bearing0_kxx_t"]) and np.array_equal(c, z["bearing0_kxx_c"])
    assert k == z["bearing0_kxx_k"]
    s = load_matrices(tmp_path / "x.npz", ROTOR.read_bytes())  # bytes already read: the path only names it
    assert np.array_equal(s.mass, r.mass)


def test_a_header_claiming_a_huge_matrix_is_refused_before_allocating(tmp_path):
    """(1e6, 1e6) doubles would be 7.3 TiB; numpy would allocate them before reading a byte."""
    raw = _npy(header={"descr": "<f8", "fortran_order": False, "shape": (1_000_000, 1_000_000)}, data=bytes(64))
    path = _zip(tmp_path / "huge.npz", {k: v for k, v in _members().items() if k != "mass"}, {"mass": raw})
    tracemalloc.start()
    try:
        with pytest.raises(ValueError, match=r"array 'mass'.*shape \(28, 28\), found \(1000000, 1000000\)"):
            load_matrices(path)
        assert tracemalloc.get_traced_memory()[1] < 50 * 2**20
    finally:
        tracemalloc.stop()


def test_a_zip_entry_claiming_more_than_deflate_can_give_is_refused(tmp_path):
    path = _zip(tmp_path / "forged.npz", _members())
    data = bytearray(path.read_bytes())
    # claim 3.9e9 uncompressed bytes for mass.npy in both its local header and the central directory
    with zipfile.ZipFile(path) as zf:
        info = zf.getinfo("mass.npy")
    claim = (3_900_000_000).to_bytes(4, "little")
    data[info.header_offset + 22: info.header_offset + 26] = claim
    central = data.rfind(b"PK\x01\x02", 0, len(data))
    while data[central + 46: central + 46 + 8] != b"mass.npy":
        central = data.rfind(b"PK\x01\x02", 0, central)
    data[central + 24: central + 28] = claim
    path.write_bytes(bytes(data))
    with pytest.raises(ValueError, match=r"array 'mass'.*(uncompressed|more than deflate)"):
        load_matrices(path)


def test_an_array_over_the_cap_is_refused_without_inflating_it(tmp_path, monkeypatch):
    """A zip bomb: zeros compress about 1000 to 1; the entry's size is refused before its data is inflated."""
    monkeypatch.setattr(matrices, "MAX_ARRAY_BYTES", 2**20)
    n = 4 * 128  # 2 MiB matrices of zeros, a few kB compressed
    m = {**_members(), "positions": np.linspace(0.0, 1.0, 128), "discs": np.zeros((0, 4))}
    for k in ("mass", "damping", "stiffness", "gyroscopic"):
        m[k] = np.zeros((n, n))
    m["bearing_nodes"] = np.zeros(0, int)
    m["bearing_tags"] = np.array([], dtype=str)
    m = {k: v for k, v in m.items() if not k.startswith("bearing") or k in ("bearing_nodes", "bearing_tags")}
    path = tmp_path / "bomb.npz"
    np.savez_compressed(path, **m)
    assert path.stat().st_size < 100_000
    with pytest.raises(ValueError, match=r"array 'mass': expected at most 1048576 bytes uncompressed"):
        load_matrices(path)


@pytest.mark.slow
def test_a_genuine_zip_bomb_is_refused_quickly_and_small(tmp_path):
    """1.07 GiB of zeros in 4.7 MB: refused by the entry's size, never inflated."""
    path = tmp_path / "bomb.npz"
    side = 12_000
    members = {k: v for k, v in _members().items() if k != "mass"}
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED, compresslevel=1) as zf:
        for name, value in members.items():
            zf.writestr(name + ".npy", _npy(value))
        with zf.open("mass.npy", "w", force_zip64=True) as fh:
            fh.write(_npy(header={"descr": "<f8", "fortran_order": False, "shape": (side, side)}, data=b""))
            block = bytes(1 << 24)
            for _ in range(side * side * 8 // len(block)):
                fh.write(block)
    tracemalloc.start()
    try:
        with pytest.raises(ValueError, match="array 'mass': expected at most"):
            load_matrices(path)
        assert tracemalloc.get_traced_memory()[1] < 100 * 2**20
    finally:
        tracemalloc.stop()


def test_a_truncated_file_is_a_message(tmp_path):
    path = tmp_path / "cut.npz"
    path.write_bytes(ROTOR.read_bytes()[: ROTOR.stat().st_size // 2])
    with pytest.raises(ValueError, match=r"cut\.npz: not a rotor matrix file .*not a complete zip archive"):
        load_matrices(path)


def test_a_damaged_member_is_a_message(tmp_path):
    data = bytearray(ROTOR.read_bytes())
    with zipfile.ZipFile(ROTOR) as zf:
        info = zf.getinfo("stiffness.npy")
    start = info.header_offset + 30 + len(info.filename) + len(info.extra)
    data[start + 10: start + 40] = bytes(30)  # inside the deflated stream
    (tmp_path / "bad.npz").write_bytes(bytes(data))
    with pytest.raises(ValueError, match=r"bad\.npz: array 'stiffness'"):
        load_matrices(tmp_path / "bad.npz")


def test_a_plain_npy_named_npz_is_a_message(tmp_path):
    path = tmp_path / "rotor.npz"
    with open(path, "wb") as fh:
        np.save(fh, np.eye(3))
    with pytest.raises(ValueError, match=r"rotor\.npz: not a rotor matrix file .*a single \.npy array"):
        load_matrices(path)


def test_a_complex_stiffness_is_refused_naming_it(tmp_path):
    m = _members()
    m["stiffness"] = m["stiffness"] + 1j * np.eye(m["stiffness"].shape[0])
    path = tmp_path / "complex.npz"
    np.savez_compressed(path, **m)
    with pytest.raises(ValueError, match=r"array 'stiffness': expected an \.npy array \(real numbers, found complex"):
        load_matrices(path)
    with pytest.raises(ValueError, match="rotor stiffness: expected real entries, found complex ones"):
        RotorMatrices(m["positions"], m["mass"], m["damping"], m["stiffness"], m["gyroscopic"])


@pytest.mark.parametrize("name, value, match", [
    ("mass", np.array([{"a": 1}], dtype=object), "objects or records"),
    ("bearing_nodes", np.array([0.5, 6.0]), "integers, found dtype float64"),
    ("positions", np.zeros((7, 2)), "shape 1-d, found \\(7, 2\\)"),
    ("discs", np.zeros((1, 3)), "shape \\(k, 4\\), found \\(1, 3\\)"),
])
def test_arrays_of_the_wrong_kind_are_named(tmp_path, name, value, match):
    m = _members()
    raw = None
    if value.dtype == object:  # written as numpy would with pickles allowed: never read (allow_pickle stays off)
        buf = io.BytesIO()
        np.lib.format.write_array(buf, value, allow_pickle=True)
        raw, m = {name: buf.getvalue()}, {k: v for k, v in m.items() if k != name}
    else:
        m[name] = value
    path = _zip(tmp_path / "kind.npz", m, raw)
    with pytest.raises(ValueError, match=f"array '{name}'.*{match}"):
        load_matrices(path)


def test_a_device_is_not_read(tmp_path):
    link = tmp_path / "zero.npz"
    link.symlink_to("/dev/zero")
    with pytest.raises(ValueError, match="expected a regular file"):
        load_matrices(link)
