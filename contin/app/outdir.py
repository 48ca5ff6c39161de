"""The output directory of a run or a sweep: whose it is, what it holds, and who is writing it.

- :func:`check_outdir`: before anything is written, an ``OUTDIR`` that holds
  files and is not contin's is refused (unless ``force``), and so is one where a
  result file's name is taken by a link, a special file or a directory.
- :class:`OutdirLock`: an exclusive ``flock`` on ``OUTDIR/.contin.lock`` held
  for the whole run (or sweep); a second writer is refused with the holder's
  pid, command and start time. The lock is released when the process ends,
  however it ends; the file stays as the sign that the directory is contin's.
- :func:`clean_temporary_files`: the temporary files of writes a killed process
  never finished (:func:`contin.util.safe_files.replace_file`).

A directory is *contin's* when it holds ``.contin.lock``, or a ``summary.json``
or ``sweep.json`` that contin wrote (results of versions before the lock file).
"""

from __future__ import annotations

import errno
import json
import os
import shlex
import socket
import stat
import sys
from datetime import datetime, timezone
from pathlib import Path

from contin.scene.schema import SceneError
from contin.util.safe_files import is_temporary_name, open_regular

__all__ = ["LOCK_NAME", "OutdirLock", "check_outdir", "clean_temporary_files", "is_contins"]

#: the lock file, and the mark of a directory contin writes
LOCK_NAME = ".contin.lock"
#: suffixes of the files contin writes into a result directory
_RESULT_SUFFIXES = (".csv", ".json", ".jsonl", ".bin", ".npz", ".mat", ".png", ".pdf", ".svg")
#: directories contin makes inside one (convergence runs, sweep points)
_RESULT_DIRS = ("runs", "points")
#: a summary.json larger than this is no summary of contin's (a run's is kilobytes to a few megabytes)
_SUMMARY_LIMIT = 256 << 20
_NOFOLLOW = getattr(os, "O_NOFOLLOW", 0)
_CLOEXEC = getattr(os, "O_CLOEXEC", 0)


def _written_by_contin(path: Path, keys: tuple) -> bool:
    """Whether ``path`` is a regular file holding a JSON object with ``keys`` (contin's summary or sweep.json)."""
    try:
        with open_regular(path, limit=_SUMMARY_LIMIT) as fh:
            data = json.load(fh)
    except (OSError, ValueError):
        return False
    return isinstance(data, dict) and all(k in data for k in keys)


def is_contins(outdir: Path) -> bool:
    """Whether ``outdir`` is contin's: its lock file, or a ``summary.json`` or ``sweep.json`` contin wrote."""
    outdir = Path(outdir)
    try:
        if stat.S_ISREG(os.lstat(outdir / LOCK_NAME).st_mode):
            return True
    except OSError:
        pass
    summary = _written_by_contin(outdir / "summary.json", ("status", "scene", "versions"))
    return summary or _written_by_contin(outdir / "sweep.json", ("status", "scene", "grid"))


def check_outdir(outdir, force: bool = False, flag: str = "-o") -> None:
    """Refuse, before anything is written, an output directory contin must not write into.

    Parameters
    ----------
    outdir : path
        May not exist yet (nothing to check then).
    force : bool
        Write into a directory that holds files and is not contin's (``--force``).
    flag : str
        The option that named the directory, for the messages.

    Raises
    ------
    SceneError
        ``outdir`` is empty text, a file, holds visible entries without being
        contin's (and not ``force``), or holds a link, a special file or a
        directory under the name of a result file (even with ``force``: contin
        never writes through them).
    """
    if str(outdir) == "":
        raise SceneError(flag, "a directory name for the results", "")
    outdir = Path(outdir)
    try:
        st = os.stat(outdir)
    except FileNotFoundError:
        return
    except OSError as exc:
        raise SceneError(flag, "a directory for the results that can be read", str(outdir),
                         hint=f" ({exc.strerror})") from None
    if not stat.S_ISDIR(st.st_mode):
        raise SceneError(flag, "a directory for the results (new or existing)", str(outdir),
                         hint=" (a file of that name exists)")
    try:
        entries = sorted(os.listdir(outdir))
    except OSError as exc:
        raise SceneError(flag, "a directory for the results that can be read", str(outdir),
                         hint=f" ({exc.strerror})") from None
    visible = [e for e in entries if not e.startswith(".")]
    if visible and not force and not is_contins(outdir):
        shown = ", ".join(visible[:5]) + (", ..." if len(visible) > 5 else "")
        raise SceneError(flag, "a new or empty directory, or one contin wrote", str(outdir),
                         hint=f"; it holds {len(visible)} {'entry' if len(visible) == 1 else 'entries'} ({shown}) and no sign of contin "
                         f"({LOCK_NAME} or a summary of a run): choose another {flag}, or add --force to write "
                         "contin's files into it (files of the same names are replaced)")
    for name in entries:
        _check_entry(outdir / name, flag)


def _check_entry(path: Path, flag: str) -> None:
    """A result file's name must be a regular file (a result directory's a directory), never a link."""
    name = path.name
    is_dir_name = name in _RESULT_DIRS
    if not (is_dir_name or name == LOCK_NAME or name.endswith(_RESULT_SUFFIXES)):
        return
    try:
        mode = os.lstat(path).st_mode
    except OSError:
        return
    ok = stat.S_ISDIR(mode) if is_dir_name else stat.S_ISREG(mode)
    if not ok:
        what = ("a symbolic link" if stat.S_ISLNK(mode) else "a directory" if stat.S_ISDIR(mode)
                else "a special file (a pipe, a device or a socket)" if not stat.S_ISREG(mode) else "a file")
        raise SceneError(flag, f"an output directory where {name} is contin's own "
                         f"{'directory' if is_dir_name else 'regular file'}", str(path),
                         hint=f" ({what}; contin never writes through it or replaces it): remove it, or choose "
                         f"another {flag}")


def clean_temporary_files(outdir) -> int:
    """Remove the temporary files of writes a killed process left in ``outdir``; returns how many."""
    n = 0
    try:
        names = os.listdir(outdir)
    except OSError:
        return 0
    for name in names:
        if is_temporary_name(name):
            path = Path(outdir) / name
            try:
                if stat.S_ISREG(os.lstat(path).st_mode):
                    os.unlink(path)
                    n += 1
            except OSError:
                pass
    return n


def _holder_text(raw: bytes) -> str:
    """Who holds a lock, from its file's content (``pid``, ``command``, ``since``, ``host``)."""
    try:
        h = json.loads(raw.decode("utf-8"))
        pid, command, since = int(h["pid"]), str(h["command"]), str(h["since"])
    except (ValueError, KeyError, TypeError):
        return "another process (it has not said which yet)"
    host = h.get("host")
    where = f" on {host}" if host and host != socket.gethostname() else ""
    return f"process {pid}{where}, running since {since}: {command[:300]}"


def _command() -> str:
    """This process's command line (``contin ...`` for ``python -m contin ...``)."""
    argv = list(sys.argv) or [sys.executable]
    if Path(argv[0]).name in ("__main__.py", "contin"):
        argv[0] = "contin"
    return shlex.join(argv)


class OutdirLock:
    """An exclusive lock on an output directory (``OUTDIR/.contin.lock``), held from :meth:`acquire` to :meth:`release`.

    The lock is ``flock`` on the open file: the system releases it when the
    holder dies, even by SIGKILL, so a killed run never leaves it taken
    (a process the run started and that still runs holds it as well). On a file
    system without locks, it is not taken and the run goes on.

    Parameters
    ----------
    outdir : path
        An existing directory.
    flag : str
        The option that named it, for the message.
    """

    def __init__(self, outdir, flag: str = "-o"):
        self.path = Path(outdir) / LOCK_NAME
        self.flag = flag
        self._fd: int | None = None

    def acquire(self) -> "OutdirLock":
        """Take the lock, and write who holds it into the file.

        Raises
        ------
        SceneError
            Another process holds it (named: pid, command, since when), or the
            lock file is a link or not a regular file.
        """
        try:
            import fcntl
        except ImportError:  # pragma: no cover  (not POSIX: no lock)
            return self
        try:
            fd = os.open(self.path, os.O_RDWR | os.O_CREAT | _NOFOLLOW | _CLOEXEC, 0o666)
        except OSError as exc:
            if exc.errno == errno.ELOOP:
                raise SceneError(self.flag, f"an output directory whose {LOCK_NAME} is a regular file",
                                 str(self.path), hint=" (a symbolic link): remove it") from None
            raise
        try:
            if not stat.S_ISREG(os.fstat(fd).st_mode):
                raise SceneError(self.flag, f"an output directory whose {LOCK_NAME} is a regular file", str(self.path))
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                holder = _holder_text(os.pread(fd, 4096, 0))
                raise SceneError(self.flag, "an output directory no other contin process is writing",
                                 str(self.path.parent), hint=f"; it is written by {holder}. Wait for it to end, "
                                 f"or choose another {self.flag}") from None
            except OSError:
                return self._unlocked(fd)  # a file system without locks: go on unlocked
            since = datetime.now(timezone.utc).astimezone().isoformat(timespec="seconds")
            note = json.dumps({"pid": os.getpid(), "command": _command(), "since": since, "host": socket.gethostname()})
            os.ftruncate(fd, 0)
            os.pwrite(fd, (note + "\n").encode(), 0)
        except BaseException:
            os.close(fd)
            raise
        self._fd = fd
        return self

    def _unlocked(self, fd: int) -> "OutdirLock":
        os.close(fd)
        return self

    def release(self) -> None:
        """Say no one holds it (the file stays, empty), and let it go."""
        fd, self._fd = self._fd, None
        if fd is None:
            return
        try:
            os.ftruncate(fd, 0)
        except OSError:
            pass
        finally:
            os.close(fd)  # closing the last descriptor releases the flock

    def __enter__(self) -> "OutdirLock":
        return self.acquire()

    def __exit__(self, *exc) -> None:
        self.release()
