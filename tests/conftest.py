import contextlib
import os
import signal
from pathlib import Path

import numpy as np
from scipy.special import mathieu_a, mathieu_b
import pytest

from contin.util.blas import limit_blas_threads

limit_blas_threads(1)
# the test workers fill the cores: no second process compiling a run's kernels ahead (contin.app.compile_ahead,
# whose tests set CONTIN_COMPILE_AHEAD themselves); the workers inherit it
os.environ.setdefault("CONTIN_COMPILE_AHEAD", "0")

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


#: the slow tier's longest work units (pytest-xdist's scopes under ``--dist loadscope``: a module, or a class),
#: longest first: sent to the workers before the others (which go by their number of tests), so that none of
#: them starts last and keeps one worker busy alone at the end (docs/validation/testing.md)
LONG_FIRST = ("tests/hard/test_invariants.py",  # the connection check on the rotor, belt and chain scenes
              "tests/docs/test_snippets.py::TestTutorialsSlow",  # the rotor tutorial's runs
              "tests/analyses/test_frequency_response_ends.py",  # the first to ask for the main job
              "tests/test_install.py",
              "tests/docs/test_snippets.py::TestValidationSlow")  # the accuracy studies


def pytest_xdist_make_scheduler(config, log):
    """In the slow tier (``-m slow``), loadscope with :data:`LONG_FIRST` sent first; elsewhere xdist's own."""
    if config.getoption("dist", None) != "loadscope" or (config.getoption("markexpr", "") or "").strip() != "slow":
        return None
    from xdist.scheduler import LoadScopeScheduling

    if not hasattr(LoadScopeScheduling, "_assign_work_unit"):  # another xdist: its own order
        return None

    class LongFirst(LoadScopeScheduling):
        def _assign_work_unit(self, node):
            queue = getattr(self, "workqueue", None)
            if queue is not None:
                for prefix in reversed(LONG_FIRST):
                    for scope in [s for s in queue if s == prefix]:
                        queue.move_to_end(scope, last=False)
            super()._assign_work_unit(node)

    return LongFirst(config, log)


def fuzz_examples(n: int) -> int:
    """Examples a property test draws: all ``n`` in the slow tier, a quarter (at least 3) in the default one."""
    return n if os.environ.get("CONTIN_FUZZ_DEPTH") == "full" else max(3, n // 4)


@pytest.fixture
def rng():
    return np.random.default_rng(12345)


#: example scenes whose run falls short, exit 1, and the words each of their shortfalls holds: branches that end
#: at a grazing point harmonic balance cannot pass, leaving part of the range (docs/reference/outcomes.md)
FALLS_SHORT = {# harmonic balance alone (method: hb): its branches stop at grazing points
               "rotor_fe_rig.yaml": ("ended at a grazing point", "stopped at a point it cannot pass"),
               # natural steps of its tori end at tongues of large q, where no locking of small q is in reach
               "rotor_fig3.yaml": ("ended step_too_small",)}


class SceneRuns:
    """``scene_runs(name)``: the result directory of ``contin run scenes/<name> -o DIR`` as shipped, run once per
    test session whatever the number of test workers; ``scene_runs.printed(name)``: what the run printed.

    Several test modules (and, in the slow tier, the documentation pages that show the main job) check the same
    example scene's results against different truths; they read the directory and never write to it. With
    pytest-xdist each worker has its own session fixtures, so the run is shared through the session's common
    temporary directory under a file lock (the pattern of pytest-xdist's documentation): the first worker to ask
    runs the scene, the others wait for it and read its directory.
    """

    def __init__(self, root: Path, shared: bool):
        self.root, self.shared, self.done = root, shared, {}

    def _run(self, name: str, out: Path) -> dict:
        import io
        import traceback

        from contin.app.cli import main

        scene = Path(__file__).resolve().parents[1] / "scenes" / name
        buf = io.StringIO()
        try:
            # as a reader types it (progress goes to stderr and is not kept)
            with contextlib.redirect_stdout(buf):
                code = main(["run", str(scene), "-o", str(out)])
        except BaseException:  # noqa: BLE001  (told to every worker that asks for this run)
            return {"code": None, "printed": buf.getvalue(), "error": traceback.format_exc()}
        return {"code": code, "printed": buf.getvalue(), "error": None}

    def _record(self, name: str) -> dict:
        import json

        if name in self.done:
            return self.done[name]
        place = self.root / "scene_runs" / name.rsplit(".", 1)[0]
        place.mkdir(parents=True, exist_ok=True)
        status = place / "status.json"
        with _locked(place / "lock"):
            if status.is_file():  # run by another worker of this session
                record = json.loads(status.read_text())
            else:
                record = self._run(name, place / "out")
                status.write_text(json.dumps(record))
        record["out"] = place / "out"
        self.done[name] = record
        return record

    def __call__(self, name: str) -> Path:
        import json

        record = self._record(name)
        assert record["error"] is None, f"contin run scenes/{name} raised:\n{record['error']}"
        code, out = record["code"], record["out"]
        if name in FALLS_SHORT:  # what they cover is checked all the same; their shortfall is the one known
            summary = json.loads((out / "summary.json").read_text())
            assert code == 1 and all(any(w in line for w in FALLS_SHORT[name]) for line in summary["shortfalls"]), \
                summary
        else:
            assert code == 0, f"contin run scenes/{name} exited with {code}:\n{record['printed'][-2000:]}"
        return out

    def printed(self, name: str) -> str:
        """What ``contin run scenes/<name> -o DIR`` printed on stdout, ``DIR`` being :meth:`__call__`'s directory."""
        self(name)
        return self.done[name]["printed"]


@contextlib.contextmanager
def _locked(path):
    """An exclusive lock on ``path`` between the processes of one machine (POSIX ``flock``; none elsewhere)."""
    try:
        import fcntl
    except ImportError:  # no flock: each worker runs its own copy (``SceneRuns.shared`` is then False)
        yield
        return
    with open(path, "a") as f:
        fcntl.flock(f, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(f, fcntl.LOCK_UN)


@pytest.fixture(scope="session")
def scene_run(tmp_path_factory):
    """``scene_run(name)``: the result directory of ``contin run scenes/<name>`` as shipped, run once per session
    (shared between the test workers: :class:`SceneRuns`); ``scene_run.printed(name)``: what it printed."""
    try:
        import fcntl  # noqa: F401
        can_lock = True
    except ImportError:
        can_lock = False
    base = tmp_path_factory.getbasetemp()
    # under pytest-xdist every worker's base directory lies in the session's own one; without workers the
    # parent is shared by every session, so the runs stay in this session's base directory
    shared = can_lock and bool(os.environ.get("PYTEST_XDIST_WORKER"))
    return SceneRuns(base.parent if shared else base, shared)


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
