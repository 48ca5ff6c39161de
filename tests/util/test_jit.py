"""contin's numba kernels cache their compiled code only in the private cache directory.

numba's cache index is a pickle, loaded (so run) by the next process that
calls the kernel. numba's own locators put it under ``$NUMBA_CACHE_DIR`` (a
directory the user may share with others) or in the ``__pycache__`` beside
the source (in ``site-packages``, where the folders outlive an uninstall).
contin's locator (:mod:`contin.util.jit`) claims the package's files and the
generated kernel modules and caches them in ``<cache directory>/numba/``,
checked private (:func:`contin.util.cachedir.check_private_dir`), or not at
all. Each test plants an index whose unpickling has a visible effect where
numba would look, or checks where the compiled code goes.
"""

from __future__ import annotations

import importlib
import importlib.util
import inspect
import os
import pathlib
import pickle
import subprocess
import sys
import warnings
from pathlib import Path

import numba
import numba.core.config
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from numba.core import caching

from contin import ContinWarning
from contin.hb import aft
from contin.model import codegen

from conftest import fuzz_examples

pytestmark = pytest.mark.skipif(not hasattr(os, "geteuid"), reason="POSIX owners and modes")

PACKAGE = Path(aft.__file__).resolve().parents[1]


class Payload:
    """Unpickling it creates ``marker``: planted code that ran."""

    def __init__(self, marker):
        self.marker = Path(marker)

    def __reduce__(self):
        return pathlib.Path.touch, (self.marker,)


def index_name(py_func) -> str:
    """numba's index file name of ``py_func``: ``<file stem>.<qualname>-<first line>.py<version><abiflags>.nbi``."""
    stem = Path(inspect.getfile(py_func)).stem
    name = (f"{stem}.{py_func.__qualname__}-{py_func.__code__.co_firstlineno}"
            f".py{sys.version_info[0]}{sys.version_info[1]}{getattr(sys, 'abiflags', '')}.nbi")
    return name


def plant(shared: Path, py_func, marker: Path) -> Path:
    """Put a code-running index where numba's ``NUMBA_CACHE_DIR`` locator looks for ``py_func``'s."""
    sub = caching.UserProvidedCacheLocator.get_suitable_cache_subpath(inspect.getfile(py_func))
    folder = shared / sub
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / index_name(py_func)
    path.write_bytes(pickle.dumps(Payload(marker)))
    return path


def files_below(root: Path) -> dict:
    """Every file below ``root`` with its size and modification time."""
    return {p: (p.stat().st_size, p.stat().st_mtime_ns) for p in root.rglob("*") if p.is_file()}


def compiled_files_below(root: Path) -> dict:
    return {p: s for p, s in files_below(root).items() if p.suffix in (".nbi", ".nbc")}


@pytest.fixture
def sandbox(tmp_path, monkeypatch):
    """``$HOME``, the system temporary directory (mode 1777, like ``/tmp``) and a not yet existing
    ``$CONTIN_CACHE_DIR`` under ``tmp_path``; numba's ``NUMBA_CACHE_DIR`` unset; fresh module tables."""
    home, tmp = tmp_path / "home", tmp_path / "tmp"
    home.mkdir(mode=0o700)
    tmp.mkdir()
    tmp.chmod(0o1777)
    monkeypatch.setenv("HOME", str(home))
    monkeypatch.delenv("XDG_CACHE_HOME", raising=False)
    monkeypatch.setenv("CONTIN_CACHE_DIR", str(tmp_path / "cache" / "kernels"))
    monkeypatch.setattr("tempfile.tempdir", str(tmp))
    monkeypatch.setattr(numba.core.config, "CACHE_DIR", "")
    monkeypatch.setattr(codegen, "_LOADED", {})
    if importlib.util.find_spec("contin.util.cachedir") is not None:
        monkeypatch.setattr("contin.util.cachedir._WARNED", set())
    before = set(sys.modules)
    yield tmp_path
    for name in set(sys.modules) - before:
        if name.startswith("contin_kernel_"):
            del sys.modules[name]


def shared_dir(sandbox: Path) -> Path:
    """A ``NUMBA_CACHE_DIR`` shared with others: world-writable and sticky, like ``/tmp``."""
    shared = sandbox / "shared"
    shared.mkdir()
    shared.chmod(0o1777)
    return shared


def cs_of_cosine(kernel):
    """``aft._cs`` on the rfft of ``cos(2 pi k / 4)``: ``C(1) = 1/2`` and ``S(1) = 0`` (closed form)."""
    return kernel(np.fft.rfft(np.cos(2 * np.pi * np.arange(4) / 4)), 1, 4)


def test_planted_index_under_numba_cache_dir_does_not_run_for_a_package_kernel(sandbox, monkeypatch):
    """The reported case for the package's own kernels: ``NUMBA_CACHE_DIR`` is a shared sticky directory in
    which another user put an index for a contin kernel. The kernel is made as at import time in a process
    started with that variable (``numba.njit(cache=True)`` on the package's function)."""
    shared = shared_dir(sandbox)
    marker = sandbox / "planted-code-ran"
    planted = plant(shared, aft._cs.py_func, marker)
    monkeypatch.setattr(numba.core.config, "CACHE_DIR", str(shared))
    before = files_below(shared)
    kernel = numba.njit(cache=True)(aft._cs.py_func)
    c, s = cs_of_cosine(kernel)
    assert c == pytest.approx(0.5) and s == pytest.approx(0.0, abs=1e-15)
    assert not marker.exists(), f"the planted index {planted} was loaded"
    assert files_below(shared) == before, "something was written under NUMBA_CACHE_DIR"
    assert Path(kernel._cache._cache_path).is_relative_to(os.environ["CONTIN_CACHE_DIR"])


def test_planted_index_under_numba_cache_dir_does_not_run_for_a_generated_kernel(sandbox, monkeypatch):
    """The same for a generated kernel module: its file is in the accepted private directory, but numba
    looked for its index under ``NUMBA_CACHE_DIR``."""
    shared = shared_dir(sandbox)
    marker = sandbox / "planted-code-ran"
    source = ("# contin test kernel: planted index\nfrom numba import njit\n\n\n"
              "@njit(cache=True)\ndef bump(x):\n    return x + 1\n")
    module_file = Path(os.environ["CONTIN_CACHE_DIR"]) / f"{codegen.module_name(source)}.py"
    sub = caching.UserProvidedCacheLocator.get_suitable_cache_subpath(str(module_file))
    (shared / sub).mkdir()
    lineno = source.split("\n").index("@njit(cache=True)") + 1
    name = f"{module_file.stem}.bump-{lineno}.py{sys.version_info[0]}{sys.version_info[1]}{sys.abiflags}.nbi"
    (shared / sub / name).write_bytes(pickle.dumps(Payload(marker)))
    monkeypatch.setattr(numba.core.config, "CACHE_DIR", str(shared))
    before = files_below(shared)
    module = codegen.load_module(source)
    assert Path(module.__file__) == module_file
    assert index_name(module.bump.py_func) == name  # the name numba gives it, planted
    assert module.bump(1) == 2
    assert not marker.exists(), "the planted index was loaded"
    assert files_below(shared) == before, "something was written under NUMBA_CACHE_DIR"


def test_package_kernels_cache_in_the_private_directory_not_in_the_package(sandbox):
    """Nothing compiled lands below the package (left behind by ``pip uninstall``, it hides an editable
    install); the index is in ``$CONTIN_CACHE_DIR/numba/<folder>_<hash>``, made with mode 0700."""
    before = compiled_files_below(PACKAGE)
    kernel = numba.njit(cache=True)(aft._cs.py_func)
    assert cs_of_cosine(kernel)[0] == pytest.approx(0.5)
    cache = Path(os.environ["CONTIN_CACHE_DIR"])
    folder = Path(kernel._cache._cache_path)
    assert folder.parent == cache / "numba" and folder.name.startswith("hb_")
    assert (folder / index_name(aft._cs.py_func)).is_file()
    assert oct(folder.stat().st_mode & 0o777) == oct(0o700)
    assert compiled_files_below(PACKAGE) == before
    # and the package's own kernels, decorated at import, are cached by the same locator
    assert type(aft.synthesize._cache._impl.locator).__name__ == "ContinCacheLocator"


def test_code_compiled_under_other_default_options_is_not_found(sandbox):
    """numba's index keys a kernel by its source and signature, not by its options: the options contin's
    ``njit`` adds (it leaves the GIL) name the cache folder, so a cache written under other defaults (code
    that holds the GIL) is another folder, never loaded for these."""
    from contin.util import cachedir, jit

    assert jit.DEFAULTS_TAG == "nogil=True" and aft.synthesize.targetoptions["nogil"]
    ours = cachedir.numba_cache_dir(aft.__file__, jit.DEFAULTS_TAG)
    assert Path(aft.synthesize._cache._cache_path).name == ours.name  # (decorated at import, under $HOME's cache)
    assert cachedir.numba_cache_dir(aft.__file__, "") != ours != cachedir.numba_cache_dir(aft.__file__, "nogil=False")
    assert ours.parent == Path(os.environ["CONTIN_CACHE_DIR"]) / "numba" and ours.name.startswith("hb_")


def refuse(kind: str, directory: Path, monkeypatch) -> None:
    """Make ``directory`` (the ``$CONTIN_CACHE_DIR``) unacceptable in the way ``kind`` says."""
    if kind == "symlink":
        target = directory.parent / "target"
        target.mkdir(mode=0o700, parents=True)
        directory.symlink_to(target, target_is_directory=True)
    else:
        directory.mkdir(parents=True)
        directory.chmod({"group-writable": 0o770, "world-writable": 0o777}[kind])


@pytest.mark.parametrize("kind,reason", [("group-writable", "writable by group or others (mode 0770)"),
                                         ("world-writable", "writable by group or others (mode 0777)"),
                                         ("symlink", "it is a symbolic link")])
def test_refused_contin_cache_dir_is_not_used(sandbox, monkeypatch, kind, reason):
    """A ``$CONTIN_CACHE_DIR`` that fails the check is named once in a warning; the kernels go to the
    per-user temporary directory instead."""
    refused = Path(os.environ["CONTIN_CACHE_DIR"])
    refuse(kind, refused, monkeypatch)
    contents = files_below(refused.resolve())
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        first = numba.njit(cache=True)(aft._cs.py_func)
        second = numba.njit(cache=True)(aft.project.py_func)
    assert cs_of_cosine(first)[0] == pytest.approx(0.5)
    about = [str(w.message) for w in record if str(refused) in str(w.message)]
    assert len(about) == 1 and reason in about[0], about
    fallback = sandbox / "tmp" / f"contin-kernels-{os.geteuid()}" / "numba"
    for kernel in (first, second):
        assert Path(kernel._cache._cache_path).parent == fallback
    assert files_below(refused.resolve()) == contents


def test_no_acceptable_directory_means_no_disk_cache(sandbox, monkeypatch):
    """Every directory someone else's (simulated by another effective uid): the kernel is compiled without
    a disk cache, and numba's own locators are not asked (nothing in ``__pycache__`` or NUMBA_CACHE_DIR)."""
    shared = shared_dir(sandbox)
    marker = sandbox / "planted-code-ran"
    plant(shared, aft._cs.py_func, marker)
    monkeypatch.setattr(numba.core.config, "CACHE_DIR", str(shared))
    before, package_before = files_below(shared), compiled_files_below(PACKAGE)
    from contin.util.jit import NoPrivateCache, njit

    monkeypatch.setattr(os, "geteuid", lambda: os.stat(sandbox).st_uid + 1)
    with pytest.warns(ContinWarning, match="it belongs to another user"):
        kernel = njit(cache=True)(aft._cs.py_func)
    # numba's own njit on a contin file is refused outright rather than sent to numba's locators
    with pytest.raises(NoPrivateCache, match="no private cache directory for the kernels of .*aft.py"):
        numba.njit(cache=True)(aft._cs.py_func)
    assert cs_of_cosine(kernel)[0] == pytest.approx(0.5)
    assert isinstance(kernel._cache, caching.NullCache)
    assert not marker.exists()
    assert files_below(shared) == before and compiled_files_below(PACKAGE) == package_before


def test_locator_classes_override_turns_the_disk_cache_off(sandbox, monkeypatch):
    """``NUMBA_CACHE_LOCATOR_CLASSES`` makes numba ask only the user's locators: contin's kernels then
    get no disk cache rather than an unchecked one."""
    if not hasattr(numba.core.config, "CACHE_LOCATOR_CLASSES"):
        pytest.skip("this numba has no NUMBA_CACHE_LOCATOR_CLASSES")
    from contin.util.jit import njit

    shared = shared_dir(sandbox)
    marker = sandbox / "planted-code-ran"
    plant(shared, aft._cs.py_func, marker)
    monkeypatch.setattr(numba.core.config, "CACHE_DIR", str(shared))
    monkeypatch.setattr(numba.core.config, "CACHE_LOCATOR_CLASSES", "UserProvidedCacheLocator")
    kernel = njit(cache=True)(aft._cs.py_func)
    assert cs_of_cosine(kernel)[0] == pytest.approx(0.5)
    assert isinstance(kernel._cache, caching.NullCache) and not marker.exists()


def test_same_file_name_in_two_folders_gets_two_indexes(sandbox):
    """``kern.py`` in two claimed folders, each with ``f`` on the same line: numba names both indexes
    ``kern.f-<line>...``; one subfolder per source folder keeps them apart, and a later load of each
    returns its own value."""
    from contin.util.cachedir import claim_source_dir

    modules = {}
    for folder, value in (("a", 1), ("b", 2)):
        d = sandbox / "src" / folder
        d.mkdir(parents=True, mode=0o700)
        (d / "kern.py").write_text(f"from contin.util.jit import njit\n\n\n@njit(cache=True)\ndef f():\n"
                                   f"    return {value}\n")
        claim_source_dir(d)
        modules[folder] = d / "kern.py"

    def load(folder, tag):
        spec = importlib.util.spec_from_file_location(f"kern_{folder}_{tag}", modules[folder])
        mod = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(mod)
        return mod.f

    first = {k: load(k, "first") for k in modules}
    assert first["a"]() == 1 and first["b"]() == 2
    paths = {k: Path(f._cache._cache_path) for k, f in first.items()}
    assert paths["a"] != paths["b"] and all(p.parent.name == "numba" for p in paths.values())
    again = {k: load(k, "again") for k in modules}  # fresh dispatchers: these load from the disk cache
    assert again["a"]() == 1 and again["b"]() == 2
    assert all(len(f.stats.cache_hits) == 1 and not f.stats.cache_misses for f in again.values())


@settings(max_examples=fuzz_examples(40), deadline=None)
@given(suffix=st.text(alphabet="abcxyz0123456789-_.", min_size=1, max_size=12))
def test_a_folder_named_like_the_package_is_not_claimed(suffix):
    """``<site-packages>/contin-evil/x.py`` shares the package path as a prefix: not contin's."""
    from contin.util.cachedir import is_claimed

    assert is_claimed(PACKAGE / "hb" / "x.py")
    assert not is_claimed(str(PACKAGE) + suffix + "/x.py")


SUBPROCESS = """
import numpy as np
from contin.model.catalog import build_model
from contin.scene.build import build_model as build_scene_model
from contin.scene.parse import load_scene
from contin.hb.problem import HarmonicBalance, HBOptions
for model, lam in ((build_model('duffing'), 'w'), (build_scene_model(load_scene({scene!r})), 'w')):
    hb = HarmonicBalance(model, lam, HBOptions(harmonics=3))
    u = np.linspace(0.1, 0.7, hb.size)
    hb.linearize(u, 1.0)
mod = model.forces[0].kernels()
print(len(mod.evaluate.stats.cache_misses), len(mod.evaluate.stats.cache_hits))
"""


@pytest.mark.slow
def test_contin_process_with_a_shared_numba_cache_dir(tmp_path, monkeypatch):
    """End to end, as reported: a process started with ``NUMBA_CACHE_DIR`` pointing at a shared sticky
    directory holding an index for every kernel the run calls (package and generated), and a fresh
    ``$CONTIN_CACHE_DIR``. The planted code does not run, nothing is written there nor below the package,
    and a second process loads the generated kernel's compiled code from the private cache."""
    scene = str(PACKAGE.parent / "scenes/custom_duffing.yaml")
    shared = tmp_path / "shared"
    shared.mkdir()
    shared.chmod(0o1777)
    cache = tmp_path / "cache" / "kernels"
    marker = tmp_path / "planted-code-ran"
    # the generated module the run will load (its name is the hash of its source): built here once
    monkeypatch.setenv("CONTIN_CACHE_DIR", str(cache))
    monkeypatch.setattr(codegen, "_LOADED", {})
    from contin.scene.build import build_model
    from contin.scene.parse import load_scene

    generated = build_model(load_scene(scene)).forces[0].kernels()
    dispatchers = {id(v): v for name, m in list(sys.modules.items())
                   if name.startswith("contin.") or m is generated
                   for v in list(vars(m).values())
                   if isinstance(v, numba.core.dispatcher.Dispatcher)
                   and inspect.getfile(v.py_func) == getattr(m, "__file__", None)}
    assert len(dispatchers) > 20
    for d in dispatchers.values():
        plant(shared, d.py_func, marker)
    before, package_before = files_below(shared), compiled_files_below(PACKAGE)
    env = dict(os.environ, NUMBA_CACHE_DIR=str(shared), CONTIN_CACHE_DIR=str(cache))
    code = SUBPROCESS.format(scene=scene)
    for _ in range(2):
        out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=600)
        assert out.returncode == 0, out.stderr
        assert not marker.exists(), "a planted index was loaded"
    assert files_below(shared) == before
    assert compiled_files_below(PACKAGE) == package_before
    misses, hits = map(int, out.stdout.split())
    assert misses == 0 and hits >= 1
    assert list((cache / "numba").glob("*/*.nbi"))
