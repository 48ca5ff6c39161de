"""numba kernels are compiled with cache=True: a second process loads them instead of compiling."""

import subprocess
import sys

CODE = """
from contin.catalog import build_model
from contin.harmonic_balance import HarmonicBalance, HBOptions
from contin import aft
from contin.elements import polynomial
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
