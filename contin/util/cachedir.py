"""Where contin keeps compiled code: one private, checked cache directory.

Generated kernel modules (:mod:`contin.model.codegen`) and numba's compiled
code of every contin kernel (:mod:`contin.util.jit`) are cached on disk.
Importing a module file, or letting numba load its cache index (a pickle),
runs whatever that file holds, so a directory is used only if nobody but the
current user (and root) can have put or changed anything in it
(:func:`check_private_dir`):

- missing components are created one by one with mode 0700;
- the directory itself (``os.lstat``, not following links) must be a real
  directory, not a symbolic link, owned by the effective uid and not writable
  by group or others;
- every directory on the way to it, both as written and after resolving
  symbolic links, must be owned by root or by the effective uid and be either
  not writable by group or others, or sticky (like ``/tmp``: others can then
  neither rename nor delete our entries).

The cache directory is the first acceptable one of ``$CONTIN_CACHE_DIR`` (if
set, else the user's cache directory from :mod:`platformdirs`, e.g.
``~/.cache/contin/kernels`` on Linux) and a per-user directory
``contin-kernels-<uid>`` under the system temporary directory
(:func:`candidate_dirs`). A directory that fails is skipped with one
:class:`~contin.util.warning.ContinWarning` naming it and the reason (once per process,
:func:`accepted`). With none acceptable nothing is cached on disk.

This module imports neither numba nor anything from contin: the command line
can ask where the cache is without loading the compiler.
"""

from __future__ import annotations

import hashlib
import os
import stat
import tempfile
import warnings
from pathlib import Path

import platformdirs

from contin.util.warning import ContinWarning

__all__ = ["accepted", "candidate_dirs", "check_private_dir", "claim_source_dir", "is_claimed", "kernel_cache_dir",
           "numba_cache_dir"]

#: refused directories already warned about in this process, with the reason
_WARNED: set[tuple[str, str]] = set()
#: directories outside the package whose source files (generated kernel modules) are cached like contin's own
_CLAIMED: set[str] = set()
#: the installed package (contin/), every source file below it is contin's
PACKAGE_DIR = os.path.dirname(os.path.dirname(os.path.realpath(__file__)))
#: subdirectory of the cache directory holding numba's index and compiled code
NUMBA_SUBDIR = "numba"


def kernel_cache_dir() -> Path:
    """Preferred cache directory: ``$CONTIN_CACHE_DIR``, else the user's cache directory for contin.

    The default is ``platformdirs.user_cache_path("contin") / "kernels"``
    (``~/.cache/contin/kernels`` on Linux, honouring ``$XDG_CACHE_HOME``). It
    is used only if :func:`check_private_dir` accepts it.
    """
    env = os.environ.get("CONTIN_CACHE_DIR")
    if env:
        return Path(env).expanduser()
    return platformdirs.user_cache_path("contin", appauthor=False) / "kernels"


def _euid() -> int | None:
    """Effective uid, or None where the platform has no POSIX owners (Windows)."""
    return os.geteuid() if hasattr(os, "geteuid") else None


def candidate_dirs():
    """The cache directories to try, in order: :func:`kernel_cache_dir`, then ``<tmp>/contin-kernels-<uid>``."""
    yield kernel_cache_dir()
    uid = _euid()
    yield Path(tempfile.gettempdir()) / f"contin-kernels-{'user' if uid is None else uid}"


def _ancestor_problem(directory: str, uid: int) -> str | None:
    """Why ``directory`` (an existing ancestor) lets someone else swap what lies below it, or None."""
    try:
        st = os.stat(directory)  # following links: the directory the path goes through
    except OSError as exc:
        return f"cannot inspect {directory}: {exc.strerror or exc}"
    if st.st_uid not in (0, uid):
        return f"{directory} belongs to another user (uid {st.st_uid})"
    if st.st_mode & (stat.S_IWGRP | stat.S_IWOTH) and not st.st_mode & stat.S_ISVTX:
        return f"{directory} is writable by group or others (mode {stat.S_IMODE(st.st_mode):04o}) and not sticky"
    return None


def _make_dirs(path: str) -> None:
    """Create the missing components of ``path`` one by one, each with mode 0700."""
    missing = []
    p = path
    while not os.path.lexists(p):
        missing.append(p)
        parent = os.path.dirname(p)
        if parent == p:
            break
        p = parent
    for p in reversed(missing):
        try:
            os.mkdir(p, 0o700)
        except FileExistsError:
            pass  # made meanwhile (by us in another process, or by someone else: the checks decide)


def check_private_dir(path, *, create: bool = True) -> str | None:
    """Whether ``path`` is a safe place to import generated code or load compiled code from.

    Parameters
    ----------
    path : str or Path
        Candidate directory (``~`` is expanded; relative paths are taken from
        the current directory).
    create : bool
        Create missing components (mode 0700) first.

    Returns
    -------
    str or None
        None if the directory is accepted; otherwise why it is refused. The
        directory must be a real directory (not a symbolic link) owned by the
        effective uid and not writable by group or others; each directory on
        the way to it, as written and after resolving links, must be owned by
        root or the effective uid and not writable by group or others unless
        it is sticky.
    """
    path = os.path.abspath(os.path.expanduser(os.fspath(path)))
    if create:
        try:
            _make_dirs(path)
        except OSError as exc:
            return f"cannot create it: {exc.strerror or exc}"
    try:
        st = os.lstat(path)
    except OSError as exc:
        return f"cannot inspect it: {exc.strerror or exc}"
    if stat.S_ISLNK(st.st_mode):
        return "it is a symbolic link"
    if not stat.S_ISDIR(st.st_mode):
        return "it is not a directory"
    uid = _euid()
    if uid is None:
        return None  # no POSIX owners or modes to check
    if st.st_uid != uid:
        return f"it belongs to another user (uid {st.st_uid}, not {uid})"
    if st.st_mode & (stat.S_IWGRP | stat.S_IWOTH):
        return f"it is writable by group or others (mode {stat.S_IMODE(st.st_mode):04o})"
    parents = []
    for base in (os.path.dirname(path), os.path.realpath(os.path.dirname(path))):
        d = base
        while True:
            if d not in parents:
                parents.append(d)
            up = os.path.dirname(d)
            if up == d:
                break
            d = up
    for d in parents:
        problem = _ancestor_problem(d, uid)
        if problem is not None:
            return problem
    return None


def accepted(d) -> Path | None:
    """``d`` made absolute if :func:`check_private_dir` accepts it, else None.

    Checked on every call (a few ``stat`` calls; a directory accepted earlier
    may have been replaced since); a refusal is warned about once per process.
    """
    key = os.path.abspath(os.path.expanduser(os.fspath(d)))
    reason = check_private_dir(key)
    if reason is None:
        return Path(key)
    if (key, reason) not in _WARNED:
        _WARNED.add((key, reason))
        warnings.warn(f"contin: not caching compiled kernels in {key}: {reason}", ContinWarning, stacklevel=3)
    return None


def claim_source_dir(directory) -> None:
    """Have numba cache the kernels of source files in ``directory`` like contin's own (generated modules)."""
    _CLAIMED.add(os.path.realpath(os.fspath(directory)))


def is_claimed(py_file) -> bool:
    """Whether ``py_file`` is contin's: below the installed package, or in a claimed directory."""
    real = os.path.realpath(os.fspath(py_file))
    folder = os.path.dirname(real)
    if folder in _CLAIMED:
        return True
    try:
        return os.path.commonpath([real, PACKAGE_DIR]) == PACKAGE_DIR
    except ValueError:  # another drive (Windows)
        return False


def numba_cache_dir(py_file, variant: str = "") -> Path | None:
    """The private directory of numba's cache files for the kernels of ``py_file``, or None if there is none.

    ``<cache directory>/numba/<folder>_<sha1 of the folder's path and variant>``:
    one subdirectory per source folder, so two modules of the same file name in
    different folders (numba names its index ``<file>.<function>-<line>``)
    never share an index; ``variant`` names what else the compiled code depends
    on that numba's index does not see (the options contin's ``njit`` adds).
    Created with mode 0700 and checked like the cache directory itself.
    """
    folder = os.path.dirname(os.path.abspath(os.fspath(py_file)))
    sub = f"{os.path.basename(folder)}_{hashlib.sha1((folder + chr(0) + variant).encode()).hexdigest()}"
    for candidate in candidate_dirs():
        root = accepted(candidate)
        if root is None:
            continue
        path = accepted(root / NUMBA_SUBDIR / sub)
        if path is not None:
            return path
    return None
