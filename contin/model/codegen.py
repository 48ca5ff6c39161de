"""Generated numba kernels: source text, an on-disk module cache, and loading.

numba's ``cache=True`` needs a function defined in a real source file (its
cache index is keyed by the file's path and time stamp), so generated code is
written to a module file in a cache directory and imported from there:

- the directory is the first acceptable one of ``$CONTIN_CACHE_DIR`` (if
  set, else the user's cache directory, ``~/.cache/contin/kernels`` on Linux)
  and a per-user directory ``contin-kernels-<uid>`` under the system
  temporary directory (:func:`contin.util.cachedir.candidate_dirs`);
- the file is named by a hash of its content, so the same model in another
  process finds the same file;
- it is written atomically (temporary file, then a hard link or
  ``os.replace``), so two processes racing to write it are safe, and an
  existing file with the right content is never rewritten (a new time stamp
  would invalidate numba's cache).

Importing a module file (and numba loading its pickled cache index) runs
whatever that file holds, so a directory is used only if nobody but the
current user (and root) can have put or changed anything in it
(:func:`check_private_dir`, from :mod:`contin.util.cachedir`): a real
directory of the effective uid, not writable by group or others, reached
through directories only root or the user can change (or sticky ones, like
``/tmp``); missing components are created with mode 0700. A directory that
fails is skipped with one :class:`~contin.util.warning.ContinWarning` naming it and the reason
(once per process). If none is acceptable, the kernels are compiled in memory
with numba's on-disk cache turned off: correct, only the compilation is paid
again by every process.

numba's compiled code of a generated module, like that of the package's own
kernels, is cached under ``<cache directory>/numba/`` (checked the same way)
by the locator of :mod:`contin.util.jit`, whatever ``NUMBA_CACHE_DIR`` says:
never next to the module file, in the package or in a directory the user
shares with others.

Only source produced by :mod:`contin.model.expressions` from checked expressions is
ever loaded; user text is never executed.
"""

from __future__ import annotations

import hashlib
import importlib.util
import os
import sys
import tempfile
import types
from pathlib import Path

# the private-directory check and the cache directory are shared with numba's cache of contin's own kernels
from contin.util import compile_ahead
from contin.util.cachedir import accepted, candidate_dirs, check_private_dir, claim_source_dir, kernel_cache_dir

__all__ = ["CODEGEN_VERSION", "check_private_dir", "kernel_cache_dir", "load_module", "module_name"]

#: bumped when the generated code changes meaning (part of the hashed text)
CODEGEN_VERSION = "1"

_LOADED: dict[str, types.ModuleType] = {}


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
    compile_ahead.wait_for(name)  # compiled in a second process now: wait, then load its cached code
    if name in _LOADED:
        return _LOADED[name]
    path = None
    for candidate in candidate_dirs():
        d = accepted(candidate)
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
        # numba's index and compiled code of this module: in the private cache directory too, never next to the
        # file or under $NUMBA_CACHE_DIR (contin.util.jit)
        claim_source_dir(path.parent)
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
