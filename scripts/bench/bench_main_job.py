"""Benchmark: the main job against its harmonic-balance part alone, and its two directions side by side.

Times, as fresh processes run alternately (warm: compiled kernels cached by a first round that is
not counted), the median of ``--rounds`` rounds of

- the main job, ``contin run scenes/rotor_f0_05.yaml``: the harmonic branch and the whole
  1/2-subharmonic branch, handed over to shooting at its grazing points (each direction of its start
  and its shooting branch in a thread of its own, side by side);
- the same with ``CONTIN_THREADS=1`` (the directions one after the other);
- its harmonic-balance part alone (the 1/2-subharmonic start with ``method: hb``: the main job as it
  was before shooting, its subharmonic branch ending at its two grazing points, exit 1).

Printed: the medians and the ratios (the main job against its harmonic-balance part; one thread
against two), and whether the two main jobs wrote the same rows, special points and coefficients
(they must: each thread records into a log of its own, written in order afterwards).

    python scripts/bench/bench_main_job.py [--rounds 3] [--quick]

``--quick``: one round of a small scene (a one-sided stop followed both ways, one direction handed
over to shooting) instead: the machinery, not the figures.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import yaml

HERE = Path(__file__).resolve().parent
MAIN = HERE.parents[1] / "scenes" / "rotor_f0_05.yaml"

SMALL = HERE.parents[1] / "scenes" / "gap_oscillator.yaml"


def small_scene() -> dict:
    """The shipped gap oscillator with one stiff stop (x > 1), started at w = 0.7 and followed both ways: one
    direction reaches w = 0.6, the other grazes the stop at w = 0.897 and is handed over to shooting."""
    scene = yaml.safe_load(SMALL.read_text())
    scene["model"]["parameters"].update(kc=300, w=0.7)
    scene["model"]["forces"][0]["sides"] = "+"
    scene["analysis"].update(range=[0.6, 1.1], start=0.7, both_ways=True, continuation={"direction": -1},
                             samples=512, shooting={"steps_per_period": 1024})
    scene["output"]["plots"] = False
    return scene


def harmonic_balance_only(scene: dict) -> dict:
    """The scene with every start on harmonic balance alone (``method: hb``)."""
    out = dict(scene)
    out["analysis"] = dict(scene["analysis"], method="hb",
                           starts=[dict(s, method="hb") for s in scene["analysis"].get("starts") or []])
    return out


def run(scene: Path, outdir: Path, threads: int | None) -> tuple[float, int]:
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    if threads is not None:
        env["CONTIN_THREADS"] = str(threads)
    t0 = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "contin", "run", str(scene), "-o", str(outdir), "-q", "--force"],
                          env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - t0, done.returncode


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--quick", action="store_true")
    args = ap.parse_args(argv)
    rounds = 1 if args.quick else max(1, args.rounds)
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        full = small_scene() if args.quick else yaml.safe_load(MAIN.read_text())
        scenes = {"main job": (tmp / "main.yaml", full, None),
                  "main job, one thread": (tmp / "main.yaml", full, 1),
                  "harmonic balance alone": (tmp / "hb.yaml", harmonic_balance_only(full), None)}
        for path, scene, _ in scenes.values():
            path.write_text(yaml.safe_dump(scene, sort_keys=False))
        times = {name: [] for name in scenes}
        codes = {}
        warm = 0 if args.quick else 1  # a first round compiles and is not counted
        for r in range(warm + rounds):
            for name, (path, _, threads) in scenes.items():
                t, codes[name] = run(path, tmp / name.replace(" ", "_").replace(",", ""), threads)
                if r >= warm:
                    times[name].append(t)
        med = {name: statistics.median(v) for name, v in times.items()}
        for name in scenes:
            print(f"{name:24s} {med[name]:7.2f} s  (exit {codes[name]}; {', '.join(f'{t:.2f}' for t in times[name])})")
        print(f"main job / harmonic balance alone: {med['main job'] / med['harmonic balance alone']:.2f}")
        print(f"one thread / two: {med['main job, one thread'] / med['main job']:.2f}")
        same = all((tmp / "main_job" / f).read_bytes() == (tmp / "main_job_one_thread" / f).read_bytes()
                   for f in ("branches.csv", "special_points.csv", "coefficients.csv"))
        print(f"the same rows, special points and coefficients with one thread and two: {same}")
        if not same or codes["main job"] != 0:
            return 1
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
