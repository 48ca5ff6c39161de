"""Benchmark: first run on a cold numba cache against the same run on a warm one.

contin's kernels are compiled by numba with ``cache=True``: the first run in
a fresh environment compiles them (and the generated kernels of
:mod:`contin.model.codegen`), later runs load them from disk. Each scene below is run
twice with ``contin run`` in fresh processes that share two new, empty cache
directories (``NUMBA_CACHE_DIR`` and ``CONTIN_CACHE_DIR``): the first run
pays the compilation, the second only loads. The difference is the
first-run compile time; both are printed with their ratio.

``--quick`` (CI) compiles something small: the custom Duffing scene's
generated kernel (:mod:`contin.model.codegen`) in a new, empty ``CONTIN_CACHE_DIR``,
contin's own kernels loaded from numba's cache as they are.

    python scripts/bench/bench_compile.py [--quick]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

SCENES = {
    "duffing": ("duffing", []),
    "rotor": ("rotor_f0_05", ["analysis.range=[2.14, 2.15]", "analysis.start=2.14", "analysis.starts=[]"]),
    # the generated kernel of a custom model alone (--quick)
    "custom": ("custom_duffing", ["analysis.range=[0.5, 1.0]", "analysis.harmonics=3", "output.plots=false"]),
}


def run_once(scene: str, overrides, cache: Path, out: Path, numba_cache: bool = True) -> float:
    """Wall time of ``contin run`` in a fresh process with the kernel cache in ``cache`` (and numba's too,
    with ``numba_cache``)."""
    env = dict(os.environ, CONTIN_CACHE_DIR=str(cache / "kernels"), OPENBLAS_NUM_THREADS="1",
               PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    if numba_cache:
        env["NUMBA_CACHE_DIR"] = str(cache / "numba")
    cmd = [sys.executable, "-m", "contin", "run", str(ROOT / "scenes" / f"{scene}.yaml"), "-o", str(out), "-q"]
    for o in overrides:
        cmd += ["--set", o]
    t = time.perf_counter()
    r = subprocess.run(cmd, capture_output=True, text=True, env=env)
    dt = time.perf_counter() - t
    if r.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed:\n{r.stderr[-2000:]}")
    return dt


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true",
                    help="a custom model's generated kernel only, numba's cache kept (CI)")
    a = ap.parse_args(argv)
    names = ["custom"] if a.quick else ["duffing", "rotor"]
    print(f"{'scene':>8s} {'cold s':>8s} {'warm s':>8s} {'compile s':>10s} {'cold/warm':>10s}")
    for name in names:
        scene, overrides = SCENES[name]
        with tempfile.TemporaryDirectory(prefix="bench_compile_") as tmp:
            tmp = Path(tmp)
            cold = run_once(scene, overrides, tmp / "cache", tmp / "cold", numba_cache=not a.quick)
            warm = run_once(scene, overrides, tmp / "cache", tmp / "warm", numba_cache=not a.quick)
        print(f"{name:>8s} {cold:8.2f} {warm:8.2f} {cold - warm:10.2f} {cold / warm:10.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
