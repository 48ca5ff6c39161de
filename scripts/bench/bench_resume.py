"""Kill -9 and resume: a run killed at several moments and resumed against the uninterrupted one.

For each scene, the uninterrupted run is made once; then, for each kill point,
a fresh run is killed with SIGKILL as soon as ``branches.csv`` holds that many
rows, and ``contin run --resume`` completes it. Printed per kill: the exit
status of the resume, the rows against the reference's, the largest difference
of any number in ``branches.csv``, whether ``special_points.csv`` has the same
points (kind, row index, parameter to 1e-9) and whether every branch of
``summary.json`` ends the same (points, status, message, special-point
counts), and the wall time of the killed and the resumed run together against
the uninterrupted one. The size of the uninterrupted run's checkpoint (``state.jsonl``,
``state.bin``, ``state_last.npz``) is printed with it.

    python scripts/bench/bench_resume.py            # scenes/mathieu_duffing_pd.yaml and scenes/rotor_f0_05.yaml
    python scripts/bench/bench_resume.py --quick    # the Mathieu-Duffing scene, two kills
"""

from __future__ import annotations

import argparse
import json
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from contin.output.results import read_csv

ROOT = Path(__file__).resolve().parents[2]
SCENES = {"scenes/mathieu_duffing_pd.yaml": (3, 10, 17, 24, 30), "scenes/rotor_f0_05.yaml": (4, 30, 50, 70, 90)}


def rows_in(path: Path) -> int:
    try:
        with open(path, encoding="utf-8") as fh:
            return max(0, sum(1 for _ in fh) - 1)
    except FileNotFoundError:
        return 0


def contin(scene: str, out: Path, *extra: str) -> tuple[int, float]:
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "contin", "run", str(ROOT / scene), "-o", str(out), "-q", *extra],
                          stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return proc.returncode, time.perf_counter() - t0


def killed(scene: str, out: Path, at_rows: int) -> float:
    t0 = time.perf_counter()
    proc = subprocess.Popen([sys.executable, "-m", "contin", "run", str(ROOT / scene), "-o", str(out), "-q"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    while rows_in(out / "branches.csv") < at_rows and proc.poll() is None:
        time.sleep(0.005)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    return time.perf_counter() - t0


STATE_FILES = ("state.jsonl", "state.bin", "state_last.npz")


def state_size(out: Path) -> str:
    """The checkpoint's files and their bytes."""
    sizes = {name: (out / name).stat().st_size for name in STATE_FILES if (out / name).is_file()}
    return f"{sum(sizes.values()) / 1e6:.3f} MB (" + ", ".join(f"{k} {v / 1e6:.3f}" for k, v in sizes.items()) + ")"


def branches(out: Path) -> list:
    keys = ("points", "status", "message", "special_points")
    summary = json.loads((out / "summary.json").read_text())
    return [{k: b[k] for k in keys} for b in summary["analysis"]["branches"]]


def compare(out: Path, ref: Path) -> tuple[str, str, bool, bool]:
    got, want = read_csv(out / "branches.csv"), read_csv(ref / "branches.csv")
    n, m = len(got["branch"]), len(want["branch"])
    diff = max(float(np.max(np.abs(got[c] - want[c]), initial=0.0)) for c in want
               if want[c].dtype.kind == "f" and n == m) if n == m else float("nan")
    sp, sp_ref = read_csv(out / "special_points.csv"), read_csv(ref / "special_points.csv")
    param = next(c for c in sp_ref if c not in ("branch", "kind"))
    same_sp = (len(sp["kind"]) == len(sp_ref["kind"]) and list(sp["kind"]) == list(sp_ref["kind"])
               and np.array_equal(sp["index"], sp_ref["index"])
               and np.allclose(sp[param], sp_ref[param], rtol=0.0, atol=1e-9))
    return f"{n}/{m}", f"{diff:.1e}", same_sp, branches(out) == branches(ref)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="one small scene, two kills")
    args = ap.parse_args(argv)
    scenes = {"scenes/mathieu_duffing_pd.yaml": (5, 20)} if args.quick else SCENES
    ok = True
    with tempfile.TemporaryDirectory(prefix="contin-resume-") as tmp:
        for scene, kills in scenes.items():
            ref = Path(tmp) / "ref"
            code, t_ref = contin(scene, ref)
            print(f"{scene}: uninterrupted run {t_ref:.1f} s, {rows_in(ref / 'branches.csv')} rows, exit {code}, "
                  f"checkpoint {state_size(ref)}")
            print(f"  {'killed at row':>13} {'resume exit':>11} {'rows':>8} {'max |diff|':>10} {'special points':>14} "
                  f"{'branch ends':>11} {'killed + resumed':>16}")
            for k in kills:
                out = Path(tmp) / f"k{k}"
                t_kill = killed(scene, out, k)
                code, t_resume = contin(scene, out, "--resume")
                rows, diff, same_sp, same_ends = compare(out, ref)
                ok = ok and code == 0 and same_sp and same_ends and float(diff) <= 1e-9
                print(f"  {k:>13} {code:>11} {rows:>8} {diff:>10} {'same' if same_sp else 'DIFFERENT':>14} "
                      f"{'same' if same_ends else 'DIFFERENT':>11} {t_kill + t_resume:>14.1f} s")
                shutil.rmtree(out)
            shutil.rmtree(ref)
    print("every resumed run equals the uninterrupted one" if ok else "SOME RESUMED RUNS DIFFER")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
