"""Benchmark: the compiled flows of the rotor's 1/2-subharmonic orbit, one call at a time.

The bearing rotor at f0 = 0.5 (the main job), RK4 at T/4096 with the contact
switches located, two revolutions from the state a simulation from rest
reaches after ``--settle`` revolutions at ``--w``; each time is the fastest of
``--repeat`` runs of ``--number`` calls, one BLAS thread:

- ``residual``: the simulation module's ``integrate`` (a shooting residual);
- ``graze``: the variational module without the variational equations (the
  pass a grazing test reads);
- ``linearisation``: the variational equations with the column of
  ``dR/dlambda`` (as the continuation takes them), and ``without dR/dlambda``.

With ``--against PATH`` (a checkout of another version, such as a git
worktree) both versions run as fresh processes, alternately, ``--rounds``
times, and the ratios of their medians are printed (this version / the
other); they must integrate to the same end state.

    python scripts/bench/bench_flows.py [--w 2.16] [--settle 600] [--against PATH] [--rounds 3] [--quick]

``--quick``: one call of each, a short settling: the machinery, not the figures.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
S = 4096
KINDS = ("residual", "graze", "linearisation", "without dR/dlambda")


def measure(w: float, settle: int, number: int, repeat: int) -> dict:
    """The fastest time of each kind (ms) and the end state of the residual's flow."""
    from contin.model.catalog import build_model, load_builtin_models
    from contin.timedomain.simulation import simulate
    from contin.timedomain.variational import VariationalFlow

    load_builtin_models()
    model = build_model("bearing_rotor", {"f0": 0.5, "w": w})
    n = model.n_dof
    z = simulate(model, {}, np.zeros(n), np.zeros(n), periods=settle, steps_per_period=S).final_state
    flow = VariationalFlow(model, steps_per_period=S)
    p = model.parameter_vector()
    Minv, C, K, cst = flow.compiled.arguments(p)
    # d/dw of the linear terms and of the constants (their size does not matter for the time)
    sensitivity = (np.zeros_like(C), np.zeros_like(K), 0.1 * np.ones_like(cst), 0.0)
    h = 2.0 * np.pi / (w * S)
    mode0 = flow.compiled.mode_of(z, p).astype(np.int64)
    mode0 = mode0 if mode0.size else np.zeros(1, dtype=np.int64)

    def residual():
        y = z.copy()
        flow.compiled.module.integrate(y, mode0.copy(), 0, 2 * S, S, h, p, Minv, C, K, cst, True, 8, 2 * S + 1, 1,
                                       np.zeros((0, 2 * n)), np.zeros((3, 2 * n)), np.zeros(5, dtype=np.int64))
        return y

    calls = {"residual": residual,
             "graze": lambda: flow.run(z, p, 0, 2 * S, jacobian=False),
             "linearisation": lambda: flow.run(z, p, 0, 2 * S, factors=2, sensitivity=sensitivity),
             "without dR/dlambda": lambda: flow.run(z, p, 0, 2 * S, factors=2)}
    out = {}
    for kind in KINDS:
        calls[kind]()  # compiled or loaded from the cache before the clock starts
        best = np.inf
        for _ in range(repeat):
            t0 = time.perf_counter()
            for _ in range(number):
                calls[kind]()
            best = min(best, (time.perf_counter() - t0) / number)
        out[kind] = 1e3 * best
    out["state"] = residual().tolist()
    return out


def in_process(checkout: Path, args) -> dict:
    """:func:`measure` run by the code of ``checkout`` in a fresh process."""
    env = dict(os.environ, PYTHONPATH=str(checkout))
    cmd = [sys.executable, str(Path(__file__).resolve()), "--json", "--w", str(args.w), "--settle", str(args.settle),
           "--number", str(args.number), "--repeat", str(args.repeat)]
    done = subprocess.run(cmd, env=env, capture_output=True, text=True, check=True, cwd=checkout)
    return json.loads(done.stdout.strip().splitlines()[-1])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--w", type=float, default=2.16)
    ap.add_argument("--settle", type=int, default=600)
    ap.add_argument("--number", type=int, default=10)
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--against", type=Path, default=None)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--json", action="store_true", help=argparse.SUPPRESS)  # one measurement, for --against
    ap.add_argument("--quick", action="store_true")
    args = ap.parse_args(argv)
    if args.quick:
        args.settle, args.number, args.repeat, args.rounds = 10, 1, 1, 1
    if args.json:
        print(json.dumps(measure(args.w, args.settle, args.number, args.repeat)))
        return 0
    if args.against is None:
        res = measure(args.w, args.settle, args.number, args.repeat)
        for kind in KINDS:
            print(f"{kind:22s} {res[kind]:7.3f} ms")
        return 0
    runs = {"this": [], "other": []}
    for _ in range(max(1, args.rounds)):
        runs["this"].append(in_process(ROOT, args))
        runs["other"].append(in_process(args.against.resolve(), args))
    for kind in KINDS:
        a = statistics.median(r[kind] for r in runs["this"])
        b = statistics.median(r[kind] for r in runs["other"])
        print(f"{kind:22s} this {a:7.3f} ms, the other {b:7.3f} ms: {a / b:.3f}")
    same = all(r["state"] == runs["this"][0]["state"] for r in runs["this"] + runs["other"])
    print(f"the same end state bit for bit: {same}")
    return 0 if same else 1


if __name__ == "__main__":
    raise SystemExit(main())
