"""A package's public names, imported from its modules on first use (PEP 562).

A layer package re-exports the names other layers use from it (its public
face, ``__all__``), so that ``from contin.hb import harmonic_balance`` works,
without importing every module of the package when the package is imported:
a module that needs one kernel does not load them all, and ``import contin``
stays cheap.
"""

from __future__ import annotations

import importlib
import sys

__all__ = ["lazy_exports", "UTIL_FACE", "util_getattr"]


def lazy_exports(package: str, face: dict[str, str]):
    """The public names of a package and its PEP 562 ``__getattr__`` and ``__dir__``, importing on first use.

    Parameters
    ----------
    package : str
        The package's ``__name__``.
    face : dict
        A module of the package (its name inside the package, e.g.
        ``"problem"`` for ``contin.hb.problem``) -> the public names it
        defines, separated by spaces (one string: it compiles faster than a
        list, and packages are compiled at start-up where no bytecode is
        cached).

    Returns
    -------
    __all__ : list of str
    __getattr__, __dir__ : callable
        To be bound to those names in the package's ``__init__``.

    Examples
    --------
    In ``contin/hb/__init__.py``::

        __all__, __getattr__, __dir__ = lazy_exports(__name__, {"problem": "HarmonicBalance HBOptions"})
    """
    where = {name: module for module, names in face.items() for name in names.split()}

    def __getattr__(name: str):
        module = where.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(f"{package}.{module}"), name)
        setattr(sys.modules[package], name, value)  # found directly from now on
        return value

    def __dir__():
        return sorted(set(vars(sys.modules[package])) | set(where))

    return list(where), __getattr__, __dir__


#: :mod:`contin.util`'s public names by module (kept here: ``import contin`` imports that package, not this module)
UTIL_FACE = {
    "warning": "ContinWarning",
    "naming": "suggest is_real is_finite_real",
    "jit": "njit",
    "blas": "limit_blas_threads",
    "cachedir": "kernel_cache_dir candidate_dirs check_private_dir claim_source_dir accepted",
    "safe_files": ("open_regular create_stream append_stream replace_file "
                   "write_user_file file_kind is_temporary_name"),
    "lazy": "lazy_exports",
    "options": "from_mapping",
}
_util_all, _util_names = lazy_exports("contin.util", UTIL_FACE)[:2]


def util_getattr(name: str):
    """:mod:`contin.util`'s module ``__getattr__``: its public names, and its ``__all__``, on first use."""
    if name == "__all__":
        return list(_util_all)
    return _util_names(name)
