"""numba kernels are compiled with cache=True: a second process loads them instead of compiling."""

import subprocess
import sys

CODE = """
from contin.model.catalog import build_model
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.hb import aft
from contin.model.elements import polynomial
hb = HarmonicBalance(build_model('duffing'), 'w', HBOptions(harmonics=3))
u = hb.linear_solution(1.0)
hb.linearize(u, 1.0)
fns = [aft.synthesize, aft.nonlinear_terms, polynomial._poly_kernel]
print(sum(len(f.stats.cache_misses) for f in fns), sum(len(f.stats.cache_hits) for f in fns))
"""


def run():
    out = subprocess.run([sys.executable, "-c", CODE], capture_output=True, text=True, check=True).stdout.split()
    return int(out[0]), int(out[1])


def test_second_process_uses_the_cache():
    run()  # first run may compile and write the cache
    misses, hits = run()
    assert misses == 0 and hits >= 3


WHERE = """
import os
import contin.app.cli, contin.app.runner, contin.app.sweep
from contin.hb import aft
impl = aft.synthesize._cache._impl
print(os.environ.get("NUMBA_CACHE_DIR", "-"), type(impl.locator).__name__, aft.synthesize._cache._cache_path)
"""


def test_package_kernels_are_cached_in_the_private_cache_directory(tmp_path):
    """contin never sets ``NUMBA_CACHE_DIR``, and its own kernels' compiled code goes neither to the package's
    ``__pycache__`` nor to numba's directories: to ``$CONTIN_CACHE_DIR/numba/`` (:mod:`contin.util.jit`)."""
    import os
    from pathlib import Path

    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env["CONTIN_CACHE_DIR"] = str(tmp_path / "kernels")
    out = subprocess.run([sys.executable, "-c", WHERE], capture_output=True, text=True, check=True, env=env)
    numba_cache_dir, locator, path = out.stdout.split()
    assert numba_cache_dir == "-"
    assert locator == "ContinCacheLocator"
    assert Path(path).parent == tmp_path / "kernels" / "numba"
