import contextlib
import os
import signal

import numpy as np
from scipy.special import mathieu_a, mathieu_b
import pytest

from contin.util.blas import limit_blas_threads

limit_blas_threads(1)

# In CI (CI=true) the property tests draw the same examples on every run, so that a landing is judged on the
# change, not on the draw; elsewhere they draw anew each run, and a failure found is kept in .hypothesis/.
from hypothesis import settings as _hypothesis_settings  # noqa: E402

_hypothesis_settings.register_profile("ci", derandomize=True)
if os.environ.get("CI"):
    _hypothesis_settings.load_profile("ci")


def pytest_configure(config):
    """The slow tier (``-m slow``, ``-m ""``) runs the property tests at their full depth (see fuzz_examples);
    set here, before the test workers start, so that they inherit it."""
    expr = (config.getoption("markexpr", "") or "").replace(" ", "")
    if "notslow" not in expr and ("slow" in expr or expr == ""):
        os.environ["CONTIN_FUZZ_DEPTH"] = "full"


def fuzz_examples(n: int) -> int:
    """Examples a property test draws: all ``n`` in the slow tier, a quarter (at least 3) in the default one."""
    return n if os.environ.get("CONTIN_FUZZ_DEPTH") == "full" else max(3, n // 4)


@pytest.fixture
def rng():
    return np.random.default_rng(12345)


#: example scenes whose run falls short, exit 1, and the words each of their shortfalls holds: branches that end
#: at a grazing point harmonic balance cannot pass, leaving part of the range (docs/reference/outcomes.md)
FALLS_SHORT = {"rotor_c2_5.yaml": ("ended at a grazing point",),
               # shooting, handed the nu = 2 halves at their grazing points, does not get past them (yet)
               "rotor_f0_02.yaml": ("ended step_too_small",),
               # harmonic balance alone (method: hb): its branches stop at grazing points
               "rotor_fe_rig.yaml": ("ended at a grazing point", "stopped at a point it cannot pass")}


@pytest.fixture(scope="session")
def scene_run(tmp_path_factory):
    """``scene_run(name)``: the result directory of ``contin run scenes/<name>`` as shipped, run once per session.

    Several test modules check the same example scene's results against different truths; they read the
    directory and never write to it.
    """
    from pathlib import Path

    from contin.app.cli import main

    import json

    scenes = Path(__file__).resolve().parents[1] / "scenes"
    done = {}

    def run(name):
        if name not in done:
            out = tmp_path_factory.mktemp(Path(name).stem) / "out"
            code = main(["run", str(scenes / name), "-o", str(out), "-q"])
            if name in FALLS_SHORT:  # what they cover is checked all the same; their shortfall is the one known
                summary = json.loads((out / "summary.json").read_text())
                assert code == 1 and all(any(w in line for w in FALLS_SHORT[name]) for line in summary["shortfalls"]), \
                    summary
            else:
                assert code == 0
            done[name] = out
        return done[name]

    return run


def fd_jacobian(fun, x, eps=1e-7):
    """Central finite differences of ``fun`` at ``x`` (columns = d/dx_j)."""
    x = np.asarray(x, dtype=float)
    cols = []
    for j in range(x.size):
        e = np.zeros_like(x)
        e[j] = eps * max(1.0, abs(x[j]))
        cols.append((fun(x + e) - fun(x - e)) / (2 * e[j]))
    return np.column_stack(cols)


def mathieu_boundaries(eps, rmax):
    """Transition curves delta = a_r(q)/4, b_r(q)/4, q = 2 eps (Abramowitz & Stegun 20.1).

    x'' + (delta + eps cos t) x = 0 with t = 2z is y'' + (4 delta + 4 eps cos 2z) y = 0,
    Mathieu's equation with a = 4 delta, q = -2 eps; the set of curves {a_r, b_r} is
    the same for q and -q. Even r: 2 pi-periodic solutions (multiplier +1), odd r:
    4 pi-periodic (multiplier -1).
    """
    q = 2 * eps
    out = [(mathieu_a(0, q) / 4, 0)]
    for r in range(1, rmax + 1):
        out += [(mathieu_b(r, q) / 4, r), (mathieu_a(r, q) / 4, r)]
    return sorted(out)


@pytest.fixture(scope="session")
def dask_cluster():
    """One local Dask cluster (two single-threaded worker processes) for the sweep tests of every module:
    its start and the workers' first loading of the kernels are paid once."""
    from distributed import LocalCluster

    with no_hang(120):
        c = LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None)
    yield c
    c.close()


class Hang(Exception):
    """Raised by :func:`no_hang` when a call does not return (a hang, not a speed check)."""


@contextlib.contextmanager
def no_hang(seconds: int = 60):
    """Fail a call that does not return within a generous bound (a hang guard, not a timing)."""

    def alarm(signum, frame):
        raise Hang(f"no result after {seconds} s: the call hangs")

    previous = signal.signal(signal.SIGALRM, alarm)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)


def check_mathieu_tongues(eps, rmax, hi, harmonics, stability_options):
    """Trace x = 0 of the undamped Mathieu equation in delta and compare its stability
    changes with :func:`mathieu_boundaries`: located to 1e-6, classified pd (odd r) or
    bp (even r), with the critical multiplier at -1 or +1. Returns ``(hb, branch, found)``."""
    from contin.model.catalog import build_model
    from contin.engine.continuation import ContinuationOptions, continuation
    from contin.hb.problem import HarmonicBalance, HBOptions
    from contin.stability import StabilityMonitor, stability_events

    model = build_model("mathieu", {"c": 0.0, "g": 0.0, "eps": eps}, effects=["parametric"])
    hb = HarmonicBalance(model, "delta", HBOptions(harmonics=harmonics))
    mon = StabilityMonitor(hb, stability_options)
    lo, step = -0.3, 0.003  # narrower than the thinnest tongue checked (~0.008 for r = 3, eps = 0.5)
    opts = ContinuationOptions(ds=step / (hi - lo), ds_max=step / (hi - lo), detect_folds=False,
                               detect_branch_points=False, max_points=5000)
    br = continuation(hb, np.zeros(hb.size), lo, (lo, hi), opts, parameter_name="delta",
                      events=stability_events(mon), monitors=[mon])
    found = [p for p in br.special_points if p.kind.value in ("bp", "pd", "ns", "fold")]
    ref = mathieu_boundaries(eps, rmax)
    assert len(found) == len(ref), [p.parameter for p in found]
    for p, (d_ref, r) in zip(found, ref):
        assert p.located
        assert abs(p.parameter - d_ref) < 1e-6, (p.parameter, d_ref, r)
        assert p.kind.value == ("pd" if r % 2 else "bp")
        # double multiplier +-1 at the boundary; |mu -+ 1| ~ sqrt(location error) there
        assert abs(p.data["multiplier"] - (-1 if r % 2 else 1)) < 1e-3
    return hb, br, found
