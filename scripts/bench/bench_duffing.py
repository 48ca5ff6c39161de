"""Benchmark: contin's compiled AFT harmonic balance against a plain numpy/scipy one, and pyHarm.

Both problems are traced by the same continuation engine over the forced
Duffing oscillator x'' + 0.1 x' + x + x^3 = F cos(w t), w in [0.5, 3], at
``H = 5`` harmonics and the same ``N = 4H+1`` samples (exact for the cubic).
The baseline builds the AFT with dense trigonometric matrices (x = E U,
R = W E^T f / N, J = W E^T diag(df/dx) E / N + ...), the textbook numpy
implementation. The script prints time per continuation point, per Newton
iteration (one residual-and-Jacobian evaluation plus one linear solve), and
the ratio, all measured in this run.

Equal accuracy: both discretise the same problem (same H and N) and converge
to the same tolerance, so their branches must coincide; the script prints
the largest difference between the two branches' points and the peak
amplitude of each, with its error against a converged reference (H = 25).

pyHarm (``pip install pyHarm-os``, an open harmonic-balance package) is timed
on the same branch at the same H when it can be imported; otherwise the
script says so and skips it.

    python scripts/bench/bench_duffing.py [--harmonics 5] [--repeat 3] [--quick]
"""

from __future__ import annotations

import argparse
import os
import time

# Multithreaded BLAS on matrices of ~100 rows busy-waits between calls and makes
# timings of one implementation depend on the other's calls; one thread is
# both faster and repeatable at these sizes.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np

from contin.model.catalog import build_model
from contin.engine.continuation import ContinuationOptions, continuation
from contin.hb.problem import HarmonicBalance, HBOptions


class NumpyDuffingHB:
    """Plain numpy AFT harmonic balance of the Duffing oscillator (baseline)."""

    def __init__(self, H, N, c=0.1, k=1.0, g=1.0, F=0.5):
        self.H, self.N = H, N
        self.c, self.k, self.g, self.F = c, k, g, F
        th = 2 * np.pi * np.arange(N) / N
        cols, dcols = [np.ones(N)], [np.zeros(N)]
        for h in range(1, H + 1):
            cols += [np.cos(h * th), np.sin(h * th)]
            dcols += [-h * np.sin(h * th), h * np.cos(h * th)]
        self.E = np.column_stack(cols)
        self.Ed = np.column_stack(dcols)
        self.P = np.diag([1.0] + [2.0] * (2 * H)) @ self.E.T / N
        self.size = 2 * H + 1
        self.fext = np.zeros(self.size)
        self.fext[1] = F

    def _lin(self, w):
        A = np.zeros((self.size, self.size))
        dA = np.zeros_like(A)
        A[0, 0] = self.k
        for h in range(1, self.H + 1):
            i, j = 2 * h - 1, 2 * h
            A[i, i] = A[j, j] = self.k - (h * w) ** 2
            A[i, j] = h * w * self.c
            A[j, i] = -h * w * self.c
            dA[i, i] = dA[j, j] = -2 * h * h * w
            dA[i, j] = h * self.c
            dA[j, i] = -h * self.c
        return A, dA

    def residual(self, u, w):
        A, _ = self._lin(w)
        x = self.E @ u
        return A @ u + self.P @ (self.g * x**3) - self.fext

    def linearize(self, u, w):
        A, dA = self._lin(w)
        x = self.E @ u
        R = A @ u + self.P @ (self.g * x**3) - self.fext
        J = A + self.P @ ((3 * self.g * x**2)[:, None] * self.E)
        return R, J, dA @ u

    def unknown_scale(self):
        return None


class Counting:
    """Counts residual-and-Jacobian evaluations of a problem."""

    def __init__(self, problem):
        self.problem = problem
        self.calls = 0

    def residual(self, u, lam):
        return self.problem.residual(u, lam)

    def linearize(self, u, lam):
        self.calls += 1
        return self.problem.linearize(u, lam)

    def unknown_scale(self):
        return None


def trace(problem, u0, opts):
    cp = Counting(problem)
    t = time.perf_counter()
    br = continuation(cp, u0, 0.5, (0.5, 3.0), opts, parameter_name="w")
    return time.perf_counter() - t, br, cp.calls


def per_call(problem, u, lam, repeat):
    t = time.perf_counter()
    for _ in range(repeat):
        R, J, Jl = problem.linearize(u, lam)
        np.linalg.solve(J, R)
    return (time.perf_counter() - t) / repeat


def peak_amplitude(br) -> float:
    """Largest first-harmonic amplitude sqrt(a1^2 + b1^2) over the branch's points."""
    U = br.unknowns
    return float(np.max(np.hypot(U[:, 1], U[:, 2])))


def reference_peak(quick: bool) -> float:
    """The peak amplitude with H = 25 (converged to rounding for this oscillator)."""
    hb = HarmonicBalance(build_model("duffing", {"F": 0.5}), "w", HBOptions(harmonics=9 if quick else 25))
    br = continuation(hb, hb.linear_solution(0.5), 0.5, (0.5, 3.0), ContinuationOptions(ds=0.02, ds_max=0.1),
                      parameter_name="w")
    return peak_amplitude(br)


PYHARM_DRIVER = r"""
import json, logging, sys, time
import numpy as np
import pyHarm

H, N = int(sys.argv[1]), int(sys.argv[2])
lin = {"M": np.array([[1.0]]), "C": np.array([[0.1]]), "K": np.array([[1.0]])}
lin["G"] = 0 * lin["M"]


def maestro(w_hi):
    return pyHarm.Maestro({
        "analysis": {"FRF": {"study": "frf", "puls_inf": 0.5, "puls_start": 0.5, "puls_sup": w_hi, "ds0": 0.02,
                             "ds_min": 1e-8, "ds_max": 0.1, "sign_ds": 1, "verbose": False, "stepsizer": "acceptance",
                             "predictor": "tangent", "corrector": "arc_length", "stopper": "bounds",
                             "solver": "NewtonRaphson"}},
        "system": {"type": "Base", "nh": H, "nti": N},
        "substructures": {"sub1": {"matrix": lin, "ndofs": 1}},
        "connectors": {
            "loading": {"type": "CosinusForcing", "connect": {"sub1": [0]}, "dirs": [0], "amp": 0.5},
            "cubic": {"type": "CubicSpring", "connect": {"sub1": [0]}, "dirs": [0], "k": 1.0},
        },
    })


logging.disable(logging.CRITICAL)
maestro(0.6).operate()  # warm-up: numba compilation or cache load
m = maestro(3.0)
t = time.perf_counter()
m.operate()
dt = time.perf_counter() - t
X = np.array([s.x for s in m.nls["FRF"].SolList if s.flag_accepted])
idx = [int(i) for i in m.getIndex("sub1", 0, 0)]
print("PYHARM_JSON " + json.dumps({"time": dt, "x": X.tolist(), "idx": idx, "version": pyHarm.__version__}))
"""


def pyharm_python(option):
    """An interpreter that can import pyHarm: ``--pyharm-python``, ``$PYHARM_PYTHON`` or this one."""
    import importlib.util
    import sys

    exe = option or os.environ.get("PYHARM_PYTHON")
    if exe:
        return exe
    return sys.executable if importlib.util.find_spec("pyHarm") is not None else None


def pyharm_row(H, N, hb, contin_row, option):
    """Time pyHarm on the same branch (same H and N) if it can be run; say so otherwise.

    Its points are checked with contin's residual of the same discretised
    problem: equal accuracy means both solve the same equations to the same
    tolerance. pyHarm runs in a subprocess so that it can live in its own
    environment (``--pyharm-python``).
    """
    import json
    import subprocess
    import tempfile

    exe = pyharm_python(option)
    if exe is None:
        print("pyHarm: not importable here (pip install pyHarm-os, or --pyharm-python PATH); skipped")
        return
    try:
        with tempfile.TemporaryDirectory(prefix="bench_pyharm_") as cwd:  # pyHarm writes a context folder in its cwd
            r = subprocess.run([exe, "-c", PYHARM_DRIVER, str(H), str(N)], capture_output=True, text=True, timeout=900,
                               env=dict(os.environ, OPENBLAS_NUM_THREADS="1"), cwd=cwd)
        line = [x for x in r.stdout.splitlines() if x.startswith("PYHARM_JSON ")]
        if r.returncode != 0 or not line:
            raise RuntimeError((r.stderr or r.stdout).strip().splitlines()[-1] if (r.stderr or r.stdout).strip()
                               else f"exit status {r.returncode}")
        out = json.loads(line[-1][len("PYHARM_JSON "):])
    except Exception as exc:  # an optional third-party package: report, never fail the benchmark
        print(f"pyHarm: its run failed ({type(exc).__name__}: {exc}); skipped")
        return
    X = np.asarray(out["x"], dtype=float)
    t, pts = float(out["time"]), len(X)
    idx = out["idx"]
    res = max(float(np.max(np.abs(hb.residual(X[i, idx], X[i, -1])))) for i in range(pts))
    peak = float(np.max(np.hypot(X[:, idx[1]], X[:, idx[2]])))
    print(f"pyHarm {out['version']} (H = {H}, N = {N}, its pseudo-arclength with Newton-Raphson): {pts} points in "
          f"{t:.3f} s ({t / max(pts, 1) * 1e6:.0f} us per point); largest contin residual at its points {res:.1e}; "
          f"peak of its points {peak:.10f}")
    print(f"ratio pyHarm/contin: per point {t / max(pts, 1) / contin_row[4]:.2f}x, whole branch {t / contin_row[3]:.2f}x")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--harmonics", type=int, default=5)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--quick", action="store_true", help="small settings for CI")
    ap.add_argument("--pyharm-python", default=None,
                    help="a Python interpreter with pyHarm installed (default: $PYHARM_PYTHON, or this one)")
    a = ap.parse_args(argv)
    H = a.harmonics
    repeat = 1 if a.quick else a.repeat
    hb = HarmonicBalance(build_model("duffing", {"F": 0.5}), "w", HBOptions(harmonics=H))
    base = NumpyDuffingHB(H, hb.N)
    u0 = hb.linear_solution(0.5)
    opts = ContinuationOptions(ds=0.02, ds_max=0.1)
    trace(hb, u0, opts)  # warm-up: numba compilation or cache load
    rows = []
    branches = {}
    for name, prob in (("contin (numba AFT)", hb), ("plain numpy AFT", base)):
        best = None
        for _ in range(repeat):
            t, br, calls = trace(prob, u0, opts)
            best = t if best is None else min(best, t)
        branches[name] = br
        it = per_call(prob, br.unknowns[len(br) // 2], br.parameter[len(br) // 2], 200 if a.quick else 2000)
        rows.append((name, len(br), calls, best, best / len(br), best / calls, it))
    print(f"Duffing frequency response, H = {H}, N = {hb.N}, unknowns = {hb.size}, w in [0.5, 3]")
    print(f"{'implementation':22s} {'points':>7s} {'evals':>6s} {'branch [s]':>11s} {'per point [us]':>15s} "
          f"{'per eval [us]':>14s} {'eval+solve [us]':>16s}")
    for name, pts, calls, t, tp, te, it in rows:
        print(f"{name:22s} {pts:7d} {calls:6d} {t:11.4f} {tp * 1e6:15.1f} {te * 1e6:14.1f} {it * 1e6:16.1f}")
    c, b = rows
    print(f"ratio numpy/contin: per point {b[4] / c[4]:.2f}x, per Newton iteration (eval+solve) {b[6] / c[6]:.2f}x")
    if c[1] != b[1]:
        print("warning: the two implementations traced different numbers of points")
    # equal accuracy: the same discretised problem, so the same branch
    bc, bb = branches["contin (numba AFT)"], branches["plain numpy AFT"]
    n = min(len(bc), len(bb))
    du = float(np.max(np.abs(bc.unknowns[:n] - bb.unknowns[:n])))
    dw = float(np.max(np.abs(bc.parameter[:n] - bb.parameter[:n])))
    ref = reference_peak(a.quick)
    peaks = {k: peak_amplitude(v) for k, v in branches.items()}
    print(f"equal accuracy: largest difference between the two branches' points {du:.1e} (coefficients), "
          f"{dw:.1e} (w); peak amplitude contin {peaks['contin (numba AFT)']:.10f}, numpy "
          f"{peaks['plain numpy AFT']:.10f}, error against H = 25 {abs(peaks['contin (numba AFT)'] - ref):.1e}")
    res_c = max(float(np.max(np.abs(hb.residual(bc.unknowns[i], bc.parameter[i])))) for i in range(len(bc)))
    print(f"largest residual at contin's points {res_c:.1e}")
    pyharm_row(H, hb.N, hb, c, a.pyharm_python)
    print()
    print("one Newton iteration (residual + Jacobian + dense solve) as H grows, same point type:")
    print(f"{'H':>4s} {'N':>5s} {'unknowns':>9s} {'contin [us]':>12s} {'numpy [us]':>11s} {'ratio':>6s}")
    for Hs in ((9, 25) if a.quick else (9, 25, 50, 100)):
        hbs = HarmonicBalance(build_model("duffing", {"F": 0.5}), "w", HBOptions(harmonics=Hs))
        bs = NumpyDuffingHB(Hs, hbs.N)
        us = np.zeros(hbs.size)
        us[1], us[3 * 2 - 1] = 1.2, 0.05
        hbs.linearize(us, 1.5)
        n_rep = 50 if a.quick else 400
        tc = per_call(hbs, us, 1.5, n_rep)
        tn = per_call(bs, us, 1.5, n_rep)
        print(f"{Hs:4d} {hbs.N:5d} {hbs.size:9d} {tc * 1e6:12.1f} {tn * 1e6:11.1f} {tn / tc:6.2f}")


if __name__ == "__main__":
    main()
