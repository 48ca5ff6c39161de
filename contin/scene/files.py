"""Reading the files a scene names: regular files only, under a size cap, read once and hashed.

A scene file, and a model file it names (a rotor's ``.npz``, ROSS's
``.toml``/``.json``), is opened without blocking (``O_NONBLOCK``: a named
pipe with no writer would block the ``open`` itself) and following links (a
scene given as a link to a regular file is fine); the file it leads to is
then checked with ``fstat``: a device (``/dev/zero``, ``/dev/urandom``), a
named pipe, a socket or a directory is refused before a byte is read, and so
is a file larger than its cap. The bytes are read once, at most the cap plus
one (a file that grows while it is read is refused too), and their sha256 is
kept (:attr:`contin.scene.parse.Scene.inputs`) so that a resumed run can tell
whether what the scene reads has changed.
"""

from __future__ import annotations

import errno
import hashlib
import os
import stat
from pathlib import Path

from contin.util.safe_files import file_kind

__all__ = ["SCENE_FILE_CAP", "MODEL_FILE_CAP", "SUMMARY_CAP", "InputFileError", "read_input", "input_key", "size_text"]

#: largest scene file read (bytes). A scene holds at most 100000 values
#: (:data:`contin.scene.parse.MAX_VALUES`), a few MiB of YAML; the YAML parser reads about 1 MiB a second
SCENE_FILE_CAP = 8 * 2**20
#: largest model file read (bytes): a rotor's ``.npz`` (its arrays are checked again, uncompressed, by
#: :func:`contin.model.fem.matrices.load_matrices`) or a ROSS rotor file
MODEL_FILE_CAP = 256 * 2**20
#: largest ``summary.json`` of a result directory read (``contin plot``, ``contin budget``)
SUMMARY_CAP = 64 * 2**20

_NONBLOCK = getattr(os, "O_NONBLOCK", 0)
_CLOEXEC = getattr(os, "O_CLOEXEC", 0)
_BINARY = getattr(os, "O_BINARY", 0)


class InputFileError(OSError):
    """A file a scene names that is not a regular file under its cap, or cannot be read."""


def size_text(nbytes: float) -> str:
    """``12.5 MiB``: a byte count in binary units."""
    value = float(nbytes)
    for unit in ("bytes", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"):
        if abs(value) < 1024 or unit == "EiB":
            return f"{value:.0f} bytes" if unit == "bytes" else f"{value:.3g} {unit}"
        value /= 1024
    return f"{nbytes:.3g} bytes"  # pragma: no cover


def input_key(path) -> str:
    """The key of ``path`` in :attr:`Scene.inputs <contin.scene.parse.Scene.inputs>`: its absolute, resolved form."""
    return str(Path(path).expanduser().resolve())


def read_input(path, cap: int) -> tuple[bytes, str]:
    """The bytes of the regular file ``path`` (at most ``cap`` of them) and their sha256 (hex).

    Parameters
    ----------
    path : path
        Followed if it is a link; what it leads to must be a regular file.
    cap : int
        Largest size accepted, in bytes.

    Raises
    ------
    InputFileError
        An ``OSError`` naming ``path`` (``filename``) whose ``strerror`` says
        why: missing or unreadable, not a regular file (``"a character device,
        not a regular file"``), or larger than ``cap`` (both sizes).
    """
    path = str(path)
    try:
        fd = os.open(path, os.O_RDONLY | _NONBLOCK | _CLOEXEC | _BINARY)
    except OSError as exc:
        raise InputFileError(exc.errno, exc.strerror or str(exc), path) from None
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise InputFileError(errno.EINVAL, f"{file_kind(st.st_mode)}, not a regular file", path)
        if st.st_size > cap:
            raise InputFileError(errno.EFBIG, f"{size_text(st.st_size)}, more than {size_text(cap)}", path)
        if _NONBLOCK:
            os.set_blocking(fd, True)
        chunks, total = [], 0
        while total <= cap:  # a file that grows as it is read stops at the cap
            chunk = os.read(fd, min(1 << 20, cap + 1 - total))
            if not chunk:
                break
            chunks.append(chunk)
            total += len(chunk)
        if total > cap:
            raise InputFileError(errno.EFBIG, f"more than {size_text(cap)} (it grew while it was read)", path)
    except InputFileError:
        raise
    except OSError as exc:
        raise InputFileError(exc.errno, exc.strerror or str(exc), path) from None
    finally:
        os.close(fd)
    data = b"".join(chunks)
    return data, hashlib.sha256(data).hexdigest()
