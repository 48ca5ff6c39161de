"""Result files written without harm to what is not contin's.

Three ways a file is written, all refusing to follow a symbolic link or to
replace anything but a regular file:

- :func:`replace_file`: a whole file (``summary.json``, ``coefficients.csv``,
  ``results.npz``, a figure) is written to a temporary file made beside it with
  exclusive creation (``O_CREAT | O_EXCL | O_NOFOLLOW``, a random name), flushed
  to disk, then renamed onto the target; readers see the old file or the new
  one, never a part. The target must be absent or a regular file.
- :func:`create_stream` and :func:`append_stream`: a file written as the run
  goes (``branches.csv``, ``state.jsonl``). A new stream removes a regular file
  of the same name and creates the file exclusively; an appended stream is
  opened with ``O_APPEND | O_NOFOLLOW`` and checked to be a regular file.
- :func:`write_user_file`: a file the user named on the command line
  (``contin absorber --json FILE``). The user chose it, so a link is followed
  as the shell would; a regular file is replaced as above, while a device, a
  pipe or a terminal (``/dev/null``, ``/dev/stdout``, a FIFO) is written in
  place, never created, truncated or replaced.

Every ``OSError`` raised while writing names the file (``filename``), so that
a full disk says which file it could not write. A target that is refused
raises :class:`UnsafeTarget`.
"""

from __future__ import annotations

import errno
import os
import secrets
import stat
from pathlib import Path
from typing import Callable

__all__ = ["UnsafeTarget", "file_kind", "replace_file", "create_stream", "append_stream", "write_user_file", "is_temporary_name",
           "open_regular"]

_NOFOLLOW = getattr(os, "O_NOFOLLOW", 0)
_CLOEXEC = getattr(os, "O_CLOEXEC", 0)
_BINARY = getattr(os, "O_BINARY", 0)
_NONBLOCK = getattr(os, "O_NONBLOCK", 0)
#: the suffix of temporary files: ``.<name>.<12 hex digits>.tmp``
_TMP_SUFFIX = ".tmp"


class UnsafeTarget(OSError):
    """A place contin will not write: a symbolic link, a directory or a special file where a result file goes."""


_KINDS = ((stat.S_ISLNK, "a symbolic link"), (stat.S_ISDIR, "a directory"), (stat.S_ISFIFO, "a named pipe (FIFO)"),
          (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket"))


def file_kind(mode: int) -> str:
    """What a file of ``st_mode`` ``mode`` is, in words ("a symbolic link", "a character device", ...)."""
    return next((name for test, name in _KINDS if test(mode)), "not a regular file")


def _refuse(path, mode: int) -> UnsafeTarget:
    code = errno.ELOOP if stat.S_ISLNK(mode) else errno.EISDIR if stat.S_ISDIR(mode) else errno.EEXIST
    return UnsafeTarget(code, f"{file_kind(mode)}, where contin writes a regular file of its own; contin neither "
                        "writes through it nor replaces it (remove it, or choose another output directory)", str(path))


def _regular_or_absent(path) -> os.stat_result | None:
    """The target's ``lstat``, None when absent; :class:`UnsafeTarget` unless it is a regular file."""
    try:
        st = os.lstat(path)
    except FileNotFoundError:
        return None
    if not stat.S_ISREG(st.st_mode):
        raise _refuse(path, st.st_mode)
    return st


def _named(exc: OSError, path) -> OSError:
    """``exc`` naming ``path`` (a write through a file object raises without a file name)."""
    if exc.filename is not None or isinstance(exc, UnsafeTarget):
        return exc
    new = OSError(exc.errno, exc.strerror or str(exc), str(path))
    new.__cause__ = exc
    return new


def is_temporary_name(name: str) -> bool:
    """Whether ``name`` is a temporary file of :func:`replace_file` (left behind by a killed process)."""
    if not (name.startswith(".") and name.endswith(_TMP_SUFFIX)):
        return False
    stem = name[:-len(_TMP_SUFFIX)]
    token = stem.rpartition(".")[2]
    return len(token) == 12 and all(c in "0123456789abcdef" for c in token)


def replace_file(path, write: Callable, binary: bool = False, encoding: str = "utf-8", newline: str | None = None,
                 sync: bool = True) -> None:
    """Write ``path`` whole through a temporary file and an atomic rename.

    Parameters
    ----------
    path : path
        The target: absent or a regular file (a link, a directory or a special
        file raises :class:`UnsafeTarget`, and nothing is written).
    write : callable
        ``write(fh)`` writes the content to the open file object ``fh``.
    binary : bool
        Open ``fh`` in binary mode (else text with ``encoding`` and ``newline``).
    sync : bool
        ``fsync`` the file before the rename, so that a crash leaves the old
        content or the new one.

    Raises
    ------
    OSError
        Naming ``path`` (a full disk, no permission, ...); the temporary file is
        removed and the target is unchanged.
    """
    path = Path(path)
    _regular_or_absent(path)
    tmp = path.with_name(f".{path.name}.{secrets.token_hex(6)}{_TMP_SUFFIX}")
    try:
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | _NOFOLLOW | _CLOEXEC | _BINARY, 0o666)
    except OSError as exc:
        raise _named(exc, path) from None
    try:
        with (os.fdopen(fd, "wb") if binary else os.fdopen(fd, "w", encoding=encoding, newline=newline)) as fh:
            write(fh)
            fh.flush()
            if sync:
                os.fsync(fh.fileno())
        _regular_or_absent(path)  # again: nothing may have been put there meanwhile
        os.replace(tmp, path)  # a rename replaces a link itself, never what it points at
    except BaseException as exc:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        if isinstance(exc, OSError):
            raise _named(exc, path) from None
        raise


class _Stream:
    """A file object whose write errors name its file (``filename``); otherwise the file object itself."""

    def __init__(self, fh, path):
        self._fh, self.path = fh, Path(path)

    @property
    def name(self) -> str:
        return str(self.path)

    def write(self, data):
        try:
            return self._fh.write(data)
        except OSError as exc:
            raise _named(exc, self.path) from None

    def writelines(self, lines):
        for line in lines:
            self.write(line)

    def flush(self):
        try:
            self._fh.flush()
        except OSError as exc:
            raise _named(exc, self.path) from None

    def sync(self):
        """Flush and ``fsync``."""
        self.flush()
        try:
            os.fsync(self._fh.fileno())
        except OSError as exc:
            raise _named(exc, self.path) from None

    def close(self):
        if self._fh.closed:
            return
        try:
            self._fh.close()
        except OSError as exc:
            raise _named(exc, self.path) from None

    @property
    def closed(self) -> bool:
        return self._fh.closed

    def fileno(self) -> int:
        return self._fh.fileno()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def _fdopen(fd: int, path, binary: bool, encoding: str, newline: str | None) -> _Stream:
    mode = "ab" if binary else "a"
    fh = os.fdopen(fd, mode) if binary else os.fdopen(fd, mode, encoding=encoding, newline=newline)
    return _Stream(fh, path)


def create_stream(path, binary: bool = False, encoding: str = "utf-8", newline: str | None = None) -> _Stream:
    """A new file at ``path``, created exclusively (a regular file there is removed first).

    Raises
    ------
    UnsafeTarget
        ``path`` is a link, a directory or a special file (left as it is).
    OSError
        Naming ``path``.
    """
    try:
        if _regular_or_absent(path) is not None:
            os.unlink(path)
        fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL | _NOFOLLOW | _CLOEXEC | _BINARY, 0o666)
    except OSError as exc:
        raise _named(exc, path) from None
    return _fdopen(fd, path, binary, encoding, newline)


def append_stream(path, binary: bool = False, encoding: str = "utf-8", newline: str | None = None) -> _Stream:
    """``path`` opened to append (created if absent); never a link, and checked to be a regular file.

    Raises
    ------
    UnsafeTarget
        ``path`` is a link, a directory or a special file.
    OSError
        Naming ``path``.
    """
    # O_NONBLOCK: a FIFO without a reader is refused at once instead of blocking the open
    flags = os.O_WRONLY | os.O_APPEND | os.O_CREAT | _NOFOLLOW | _CLOEXEC | _BINARY | _NONBLOCK
    try:
        fd = os.open(path, flags, 0o666)
    except OSError as exc:
        if exc.errno in (errno.ELOOP, errno.ENXIO, errno.EISDIR):
            try:
                raise _refuse(path, os.lstat(path).st_mode) from None
            except FileNotFoundError:
                pass
        raise _named(exc, path) from None
    try:
        mode = os.fstat(fd).st_mode
        if not stat.S_ISREG(mode):
            raise _refuse(path, mode)
        if _NONBLOCK:
            os.set_blocking(fd, True)
    except BaseException:
        os.close(fd)
        raise
    return _fdopen(fd, path, binary, encoding, newline)


def open_regular(path, encoding: str | None = "utf-8", errors: str = "strict", newline: str | None = None,
                 limit: int | None = None, follow: bool = False):
    """``path`` opened to read, only if it is a regular file (and of at most ``limit`` bytes).

    A named pipe or a device in a result directory would block the read or never end it.
    A link is refused unless ``follow`` (a link to a regular file is then read: result
    directories kept by data-management tools hold their files as links).

    Raises
    ------
    UnsafeTarget, OSError
        Naming ``path``; ``EFBIG`` for a file over ``limit``.
    """
    try:
        fd = os.open(path, os.O_RDONLY | (0 if follow else _NOFOLLOW) | _CLOEXEC | _BINARY | _NONBLOCK)
    except OSError as exc:
        if exc.errno == errno.ELOOP and not follow:
            raise _refuse(path, stat.S_IFLNK) from None
        raise _named(exc, path) from None
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise _refuse(path, st.st_mode)
        if limit is not None and st.st_size > limit:
            raise OSError(errno.EFBIG, f"larger than the {limit} bytes contin writes there", str(path))
        if _NONBLOCK:
            os.set_blocking(fd, True)
    except BaseException:
        os.close(fd)
        raise
    if encoding is None:
        return os.fdopen(fd, "rb")
    return os.fdopen(fd, "r", encoding=encoding, errors=errors, newline=newline)


def write_user_file(path, write: Callable, binary: bool = False, encoding: str = "utf-8",
                    newline: str | None = None) -> None:
    """Write a file the user named (``--json FILE``): replaced when it is a regular file, in place otherwise.

    A link is followed (the user named it, as in ``> FILE`` of a shell); a
    regular file, or none, is written through :func:`replace_file` at the
    place the link leads to; a device, a pipe or a terminal is opened for
    writing as it is (never created, truncated or replaced). A directory
    raises ``IsADirectoryError``.

    Raises
    ------
    OSError
        Naming ``path`` (``/dev/full``: ``ENOSPC``).
    """
    path = Path(path)
    try:
        st = os.stat(path)
    except FileNotFoundError:
        st = None
    except OSError as exc:
        raise _named(exc, path) from None
    if st is not None and stat.S_ISDIR(st.st_mode):
        raise IsADirectoryError(errno.EISDIR, "a directory, where a file was asked for", str(path))
    if st is not None and not stat.S_ISREG(st.st_mode):
        try:
            fd = os.open(path, os.O_WRONLY | _CLOEXEC | _BINARY)
            with (os.fdopen(fd, "wb") if binary else os.fdopen(fd, "w", encoding=encoding, newline=newline)) as fh:
                write(fh)
                fh.flush()
        except OSError as exc:
            raise _named(exc, path) from None
        return
    target = Path(os.path.realpath(path)) if path.is_symlink() else path
    replace_file(target, write, binary=binary, encoding=encoding, newline=newline)
