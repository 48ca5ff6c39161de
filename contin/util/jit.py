"""The ``njit`` of contin's kernels: numba's, with compiled code cached only in contin's private cache directory.

numba finds where a ``cache=True`` function keeps its compiled code by asking
its cache locators in turn; the first, ``NUMBA_CACHE_DIR``'s, claims every
file, and the next one writes into the ``__pycache__`` beside the source. The
index there is a pickle, loaded (and so run) by the next process: from a
directory another user can write, that is their code running as ours; in
``site-packages`` those folders outlive a ``pip uninstall`` and turn the
leftover ``contin/`` into a namespace package that hides an editable install.

So importing this module puts :class:`ContinCacheLocator` first in numba's
list. It claims every source file below the installed ``contin`` package and
in the directories of generated kernel modules
(:func:`contin.util.cachedir.claim_source_dir`), and puts their cache in
``<cache directory>/numba/<folder>_<hash>/`` (:func:`contin.util.cachedir.numba_cache_dir`),
checked private like the generated modules, whatever ``NUMBA_CACHE_DIR``
says. Where no private directory is acceptable (each refusal warned about
once), or where ``NUMBA_CACHE_LOCATOR_CLASSES`` replaces numba's list, the
kernel is compiled without a disk cache: each process compiles it again, and
nothing is read from or written to an unchecked place.

Every contin kernel is decorated with :func:`njit` from here (the package's
modules and the generated sources alike), so the locator is in place before
any ``cache=True`` function is made.
"""

from __future__ import annotations

import inspect
import os

import numba
from numba.core import caching, config

from contin.util import cachedir

__all__ = ["ContinCacheLocator", "NoPrivateCache", "disk_cached", "install_locator", "njit"]

# the names numba gave these across versions (0.60: _CacheImpl; later: CacheImpl)
_CacheImpl = getattr(caching, "CacheImpl", None) or caching._CacheImpl


#: the options :func:`njit` gives every kernel unless told otherwise
DEFAULT_OPTIONS = {"nogil": True}
#: their name in the cache directory: numba's index keys a kernel by its source and signature, not by its
#: options, so code compiled under other defaults (holding the GIL) must not be found there
DEFAULTS_TAG = ",".join(f"{k}={v}" for k, v in sorted(DEFAULT_OPTIONS.items()))


class NoPrivateCache(RuntimeError):
    """A contin kernel's compiled code has no private directory to go to (it is compiled without disk cache)."""


class ContinCacheLocator(caching._SourceFileBackedLocatorMixin, caching._CacheLocator):
    """numba cache locator of contin's kernels: a private per-folder directory of contin's cache directory.

    Parameters
    ----------
    py_func : function
        The kernel's Python function.
    py_file : str
        Its source file.
    cache_path : str or Path
        The checked directory of its index and compiled code.
    """

    def __init__(self, py_func, py_file, cache_path):
        self._py_file = py_file
        self._lineno = py_func.__code__.co_firstlineno
        self._cache_path = os.fspath(cache_path)

    def get_cache_path(self):
        return self._cache_path

    @classmethod
    def from_function(cls, py_func, py_file):
        """This locator for a contin source file; None for any other (numba's locators then decide).

        Raises
        ------
        NoPrivateCache
            For a contin file when no private directory is acceptable: never
            fall through to numba's locators (``NUMBA_CACHE_DIR``, ``__pycache__``).
        """
        if not cachedir.is_claimed(py_file):
            return None
        path = cachedir.numba_cache_dir(py_file, DEFAULTS_TAG)
        if path is None:
            raise NoPrivateCache(f"no private cache directory for the kernels of {py_file}")
        self = cls(py_func, py_file, path)
        try:
            self.ensure_cache_path()  # writable (the check made and vetted it)
        except OSError as exc:
            raise NoPrivateCache(f"cannot write the cache directory {path}: {exc}") from exc
        return self


def install_locator() -> None:
    """Put :class:`ContinCacheLocator` first in numba's locator list (idempotent)."""
    classes = _CacheImpl._locator_classes
    if classes and classes[0] is ContinCacheLocator:
        return
    while ContinCacheLocator in classes:
        classes.remove(ContinCacheLocator)
    classes.insert(0, ContinCacheLocator)


install_locator()


def _cacheable(func) -> bool:
    """Whether ``func``'s compiled code may be cached on disk: a contin file that our locator is asked about."""
    if getattr(config, "CACHE_LOCATOR_CLASSES", ""):
        return False  # numba would ask the user's locators only: ours would not be consulted
    install_locator()  # in case something reordered numba's list since import
    try:
        py_file = inspect.getfile(func)
    except TypeError:
        return False
    return os.path.isfile(py_file) and cachedir.is_claimed(py_file)


def njit(*args, **kwargs):
    """``numba.njit``; with ``cache=True``, cached in contin's private cache directory or not at all.

    The kernels leave the GIL (``nogil=True`` unless said otherwise): they touch no Python object, and
    branches traced side by side (:mod:`contin.analyses.side_by_side`) run them in threads.

    Parameters
    ----------
    *args, **kwargs
        As for :func:`numba.njit` (a function or signatures, then options).

    Returns
    -------
    Dispatcher or callable
        The compiled function, or a decorator when no function is given.
    """
    kwargs = {**DEFAULT_OPTIONS, **kwargs}
    if not kwargs.get("cache"):
        return numba.njit(*args, **kwargs)
    if args and inspect.isfunction(args[0]):
        return njit(*args[1:], **kwargs)(args[0])

    def decorate(func):
        opts = dict(kwargs)
        if not _cacheable(func):
            opts["cache"] = False
        try:
            disp = numba.njit(*args, **opts)(func)
        except NoPrivateCache:
            opts["cache"] = False
            disp = numba.njit(*args, **opts)(func)
        cache = getattr(disp, "_cache", None)
        if opts["cache"] and not isinstance(getattr(getattr(cache, "_impl", None), "locator", None),
                                            ContinCacheLocator):
            disp._cache = caching.NullCache()  # another locator took it: use none rather than an unchecked place
        return disp

    return decorate


def disk_cached(dispatcher) -> bool:
    """Whether ``dispatcher`` (a kernel of :func:`njit`) has compiled code in the disk cache, or no disk cache at
    all (then no other process could compile it for this one): what :mod:`contin.app.compile_ahead` asks."""
    cache_file = getattr(getattr(dispatcher, "_cache", None), "_cache_file", None)
    index = getattr(cache_file, "_index_path", None)
    return index is None or os.path.exists(index)
