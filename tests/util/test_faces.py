"""The lower layers' packages re-export their faces lazily, and the package's modules share no private names.

A layer package (``contin.hb``, ``contin.engine``, ...) offers the names other
layers use from it (``__all__``), each the very object its module defines,
imported on first use (PEP 562) so that ``import contin`` loads none of them.
Between any two modules of the package no private name (``_x``) is imported,
and a function-level import of a contin module says beside it why it is
deferred (an import cycle, or start-up time).
"""

import ast
import functools
import importlib
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from contin.util.lazy import lazy_exports

PACKAGE = Path(__file__).resolve().parents[2] / "contin"
#: the layers whose packages re-export their faces
FACED = ("util", "engine", "model", "hb", "stability", "timedomain", "modal", "bifurcation", "output")


def _defining_module(package, name):
    """The module of ``package`` that binds ``name`` (its ``_FACE`` entry, or the eager import's source)."""
    face = getattr(package, "_FACE", None)
    if face is None and package.__name__ == "contin.util":
        from contin.util.lazy import UTIL_FACE as face
    if face is None:
        return None
    return next(f"{package.__name__}.{m}" for m, names in face.items() if name in names.split())


@pytest.mark.parametrize("layer", FACED)
def test_every_exported_name_is_its_modules_object(layer):
    package = importlib.import_module(f"contin.{layer}")
    assert package.__all__ and len(set(package.__all__)) == len(package.__all__)
    for name in package.__all__:
        obj = getattr(package, name)
        where = _defining_module(package, name)
        if where is not None:
            assert obj is getattr(importlib.import_module(where), name), (layer, name)
        assert name in dir(package)
    with pytest.raises(AttributeError, match=rf"module 'contin\.{layer}' has no attribute 'no_such_name'"):
        getattr(package, "no_such_name")


def test_the_factory_and_the_old_private_names_are_reachable():
    from contin.hb import harmonic_balance
    from contin.hb.factory import harmonic_balance as defined
    from contin.model.catalog import _load, load_builtin_models
    from contin.modal.modes import check_mass

    assert harmonic_balance is defined and _load is load_builtin_models
    with pytest.raises(ValueError, match="M must be symmetric"):
        check_mass(np.array([[1.0, 0.5], [0.0, 1.0]]))


def test_import_contin_imports_no_layer_module():
    code = ("import sys, contin, contin.util; "
            "print(sorted(m for m in sys.modules if m.startswith('contin.') and m.count('.') > 1 "
            "and not m.startswith('contin.util.')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    loaded = eval(out.stdout)
    assert not [m for m in loaded if m.split(".")[1] in FACED], loaded


def test_lazy_exports_refuses_and_lists():
    module = type(sys)("contin_test_face")
    sys.modules[module.__name__] = module
    try:
        names, getattr_, dir_ = lazy_exports(module.__name__, {"x": "a b", "y": "c"})
        assert names == ["a", "b", "c"] and {"a", "b", "c"} <= set(dir_())
        with pytest.raises(AttributeError, match="module 'contin_test_face' has no attribute 'd'"):
            getattr_("d")
    finally:
        del sys.modules[module.__name__]


#: ``from contin... import a, b`` or ``import (a,\n b)`` (the names' text as written)
FROM_IMPORT = re.compile(r"^[ \t]*from (contin[\w.]*) import (\([^)]*\)|[^\n]*)", re.M)
#: an import of a contin module that is indented: inside a function (or a block), where the AST then tells which
INDENTED = re.compile(r"^[ \t]+(?:from|import) contin", re.M)


@functools.lru_cache(maxsize=None)
def _sources():
    """``(path, module name, text)`` of every file of the package (read once: the checks are cheap on text)."""
    out = []
    for path in sorted(PACKAGE.rglob("*.py")):
        name = ".".join(path.relative_to(PACKAGE.parent).with_suffix("").parts).removesuffix(".__init__")
        out.append((path, name, path.read_text()))
    return out


def test_every_module_is_read():
    assert any(m == "contin.app.cli" for _, m, _ in _sources()) and any(m == "contin" for _, m, _ in _sources())


def test_no_private_name_is_imported_across_modules():
    found = []
    for path, module, text in _sources():
        for m in FROM_IMPORT.finditer(text):
            if m.group(1) == module:
                continue
            names = [n.split("#")[0].strip().split(" as ")[0] for n in m.group(2).strip("()").replace("\n", ",").split(",")]
            found += [f"{path.relative_to(PACKAGE)}: {m.group(1)}.{n}" for n in names
                      if n.startswith("_") and not n.startswith("__")]
    assert not found, "private names imported from another module (make them public):\n" + "\n".join(found)


def test_each_function_level_import_says_why_it_is_deferred():
    bare = []
    for path, _, text in _sources():
        if not INDENTED.search(text):
            continue
        lines = text.splitlines()
        tree = ast.parse(text)
        inner = {id(n) for f in ast.walk(tree) if isinstance(f, (ast.FunctionDef, ast.AsyncFunctionDef))
                 for n in ast.walk(f) if isinstance(n, (ast.Import, ast.ImportFrom))}
        for node in ast.walk(tree):
            if id(node) not in inner:
                continue
            names = [node.module or ""] if isinstance(node, ast.ImportFrom) else [a.name for a in node.names]
            if any(n.startswith("contin") for n in names) and "deferred" not in lines[node.lineno - 1]:
                bare.append(f"{path.relative_to(PACKAGE)}:{node.lineno}")
    assert not bare, "function-level imports without a '# deferred: why' beside them:\n" + "\n".join(bare)
