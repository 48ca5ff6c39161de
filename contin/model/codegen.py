"""Generated numba kernels: source text, an on-disk module cache, and loading.

numba's ``cache=True`` needs a function defined in a real source file (its
cache index is keyed by the file's path and time stamp), so generated code is
written to a module file in a cache directory and imported from there:

- the directory is the first acceptable one of ``$CONTIN_CACHE_DIR`` (if
  set), ``~/.cache/contin/kernels`` and a per-user directory
  ``contin-kernels-<uid>`` under the system temporary directory;
- the file is named by a hash of its content, so the same model in another
  process finds the same file, and numba finds its compiled code next to it
  (in ``__pycache__``);
- it is written atomically (temporary file, then a hard link or
  ``os.replace``), so two processes racing to write it are safe, and an
  existing file with the right content is never rewritten (a new time stamp
  would invalidate numba's cache).

Importing a module file (and numba loading its pickled cache next to it) runs
whatever that file holds, so a directory is used only if nobody but the
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

A directory that fails is skipped with one :class:`RuntimeWarning` naming it
and the reason (once per process). If none is acceptable, the kernels are
compiled in memory with numba's on-disk cache turned off: correct, only the
compilation is paid again by every process.

Only source produced by :mod:`contin.model.expressions` from checked expressions is
ever loaded; user text is never executed.

contin itself never sets ``NUMBA_CACHE_DIR``: the compiled code of the
package's own ``cache=True`` functions goes to the package's ``__pycache__``
(numba's default), or where the user points ``NUMBA_CACHE_DIR``.
"""

from __future__ import annotations

import hashlib
import importlib.util
import os
import stat
import sys
import tempfile
import types
import warnings
from pathlib import Path

__all__ = ["CODEGEN_VERSION", "check_private_dir", "kernel_cache_dir", "load_module", "module_name"]

#: bumped when the generated code changes meaning (part of the hashed text)
CODEGEN_VERSION = "1"

_LOADED: dict[str, types.ModuleType] = {}
#: refused directories already warned about in this process, with the reason
_WARNED: set[tuple[str, str]] = set()


def kernel_cache_dir() -> Path:
    """Preferred directory of generated kernel modules (``$CONTIN_CACHE_DIR`` or ``~/.cache/contin/kernels``).

    It is used only if :func:`check_private_dir` accepts it; see :func:`load_module`.
    """
    env = os.environ.get("CONTIN_CACHE_DIR")
    if env:
        return Path(env).expanduser()
    return Path.home() / ".cache" / "contin" / "kernels"


def module_name(source: str) -> str:
    """Module name of a generated source: ``contin_kernel_<hash of the content>``."""
    digest = hashlib.sha256(source.encode("utf-8")).hexdigest()[:24]
    return f"contin_kernel_{digest}"


def _write_atomic(path: Path, source: str) -> None:
    data = source.encode("utf-8")
    try:
        if path.read_bytes() == data:
            return  # same content: keep the file (and numba's cache) as it is
    except OSError:
        pass
    fd, tmp = tempfile.mkstemp(prefix=path.stem + ".", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        try:
            os.link(tmp, path)  # create only if absent: a racing writer's file is left untouched
        except FileExistsError:
            if path.read_bytes() != data:
                os.replace(tmp, path)  # a damaged file: replace it
        except OSError:
            os.replace(tmp, path)  # no hard links on this file system
    finally:
        try:
            os.unlink(tmp)
        except OSError:
            pass


def _euid() -> int | None:
    """Effective uid, or None where the platform has no POSIX owners (Windows)."""
    return os.geteuid() if hasattr(os, "geteuid") else None


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
    """Whether ``path`` is a safe place to import generated code from.

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


def _candidate_dirs():
    yield kernel_cache_dir()
    uid = _euid()
    yield Path(tempfile.gettempdir()) / f"contin-kernels-{'user' if uid is None else uid}"


def _accepted(d: Path) -> Path | None:
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
        warnings.warn(f"contin: not caching generated kernels in {key}: {reason}", RuntimeWarning, stacklevel=3)
    return None


def load_module(source: str) -> types.ModuleType:
    """Import a generated kernel module, writing it to the cache directory if needed.

    Parameters
    ----------
    source : str
        Complete module source (generated, never user text).

    Returns
    -------
    module
        Registered in ``sys.modules`` under :func:`module_name`, so numba can
        rebuild cached functions. Loaded from the first candidate directory
        that :func:`check_private_dir` accepts and where the file can be
        written; compiled in memory, without numba's disk cache, if there is
        none.
    """
    name = module_name(source)
    if name in _LOADED:
        return _LOADED[name]
    path = None
    for candidate in _candidate_dirs():
        d = _accepted(candidate)
        if d is None:
            continue
        try:
            p = d / f"{name}.py"
            _write_atomic(p, source)
            path = p
            break
        except OSError:
            continue
    if path is not None:
        spec = importlib.util.spec_from_file_location(name, path)
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module
        try:
            spec.loader.exec_module(module)
        except BaseException:
            sys.modules.pop(name, None)
            raise
    else:
        # No private, writable directory: no file at all, and numba's on-disk cache off (each process
        # compiles the kernels once; nothing is read from or written to a place others could reach).
        module = types.ModuleType(name)
        module.__file__ = f"<{name}>"
        sys.modules[name] = module
        code = compile(source.replace("cache=True", "cache=False"), module.__file__, "exec")
        exec(code, module.__dict__)  # noqa: S102  (generated source from checked expressions only)
    _LOADED[name] = module
    return module


def array_names(param_names, dof_names=(), *, x: str = "x[j, {}]", xd: str = "xd[j, {}]", tau: str = "tau[j]",
                p: str = "p[{}]", error=ValueError):
    """The function that spells a whitelisted expression name as generated code.

    Parameters
    ----------
    param_names, dof_names : sequence of str
    x, xd, tau, p : str
        Templates for a displacement, a velocity (``NAME_dot``), the phase and a
        parameter; ``{}`` takes the index.
    error : exception class
        Raised for a name that has no spelling (names are checked on parse, so
        this only guards against misuse).

    Returns
    -------
    callable
        ``name -> str``.
    """
    params, dofs = list(param_names), list(dof_names)

    def name_of(name: str) -> str:
        if name in params:
            return p.format(params.index(name))
        if name in dofs:
            return x.format(dofs.index(name))
        if name.endswith("_dot") and name[:-4] in dofs:
            return xd.format(dofs.index(name[:-4]))
        if name == "tau":
            return tau
        if name == "pi":
            return "np.pi"
        raise error(f"unknown name {name!r} in generated code")

    return name_of
