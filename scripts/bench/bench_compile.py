"""Benchmark: first run on a cold numba cache against the same run on a warm one.

contin's kernels are compiled by numba with ``cache=True``: the first run in
a fresh environment compiles them (the package's own and the generated kernels
of :mod:`contin.model.codegen`), later runs load them from the private kernel
cache (:mod:`contin.util.jit`; ``NUMBA_CACHE_DIR`` plays no part). Each scene
below is run twice with ``contin run`` in fresh processes that share one new,
empty ``CONTIN_CACHE_DIR``: the first run pays the compilation, the second
only loads. The difference is the first-run compile time; both are printed
with their ratio.

``--quick`` runs the small custom Duffing scene only; ``--main`` the main job itself
(``contin run scenes/rotor_f0_05.yaml``, about two minutes for both runs).

    python scripts/bench/bench_compile.py [--quick | --main]
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
    # the main job as the README runs it (--main)
    "main": ("rotor_f0_05", []),
    # the generated kernel of a custom model alone (--quick)
    "custom": ("custom_duffing", ["analysis.range=[0.5, 1.0]", "analysis.harmonics=3", "output.plots=false"]),
}


def run_once(scene: str, overrides, cache: Path, out: Path) -> float:
    """Wall time of ``contin run`` in a fresh process with the kernel cache in ``cache``."""
    env = dict(os.environ, CONTIN_CACHE_DIR=str(cache / "kernels"), OPENBLAS_NUM_THREADS="1",
               PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
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
                    help="the small custom Duffing scene only")
    ap.add_argument("--main", action="store_true", help="the main job, scenes/rotor_f0_05.yaml, only")
    a = ap.parse_args(argv)
    names = ["custom"] if a.quick else ["main"] if a.main else ["duffing", "rotor"]
    print(f"{'scene':>8s} {'cold s':>8s} {'warm s':>8s} {'compile s':>10s} {'cold/warm':>10s}")
    for name in names:
        scene, overrides = SCENES[name]
        with tempfile.TemporaryDirectory(prefix="bench_compile_") as tmp:
            tmp = Path(tmp)
            cold = run_once(scene, overrides, tmp / "cache", tmp / "cold")
            warm = run_once(scene, overrides, tmp / "cache", tmp / "warm")
        print(f"{name:>8s} {cold:8.2f} {warm:8.2f} {cold - warm:10.2f} {cold / warm:10.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
