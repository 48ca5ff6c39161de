"""Sweeps on a real local Dask cluster, and the pieces of a sweep (grid, options, summaries).

The cluster results are checked against the same runs made one by one with
``contin run`` and, for the folds at H = 1, against the closed form of the
Duffing amplitude equation.
"""

import json
import os
import signal
import threading
import time
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import brentq

from conftest import no_hang
from contin.app.cli import main
from contin.output.results import read_csv
from contin.scene.parse import SceneError
from contin.app.sweep import SweepOptions, run_sweep
from contin.app.sweep_grid import GridAxis, grid_points, parse_grid
from contin.app.sweep_index import summarize_point
from contin.analyses.intervals import stable_intervals

ROOT = Path(__file__).resolve().parents[2]
DUFFING = str(ROOT / "scenes/duffing.yaml")
# small settings: no plots of the points, H = 1 (closed-form folds) or 3
FAST = ("analysis.harmonics=1", "output.plots=false")
# slow enough (a few seconds a point) to be caught in the middle of a run
SLOW = ("analysis.harmonics=3", "output.plots=false", "analysis.continuation={ds: 0.08, ds_max: 0.08}")


@pytest.fixture
def cluster(dask_cluster):
    return dask_cluster


def duffing_folds(F, c, lo=0.5, hi=3.0):
    """Folds met by the branch traced upwards from w = lo, of [(1 - w^2 + 3/4 A^2)^2 + (c w)^2] A^2 = F^2.

    The folds are the zeros of the discriminant of the cubic in A^2. The
    branch climbs the resonance and turns back at the upper fold, then turns
    again at the lower one; if the upper fold lies beyond ``hi`` the branch
    leaves the range before meeting either.
    """

    def disc(w):
        a3, a2, a1, a0 = 9 / 16, 1.5 * (1 - w**2), (1 - w**2) ** 2 + (c * w) ** 2, -(F**2)
        return 18 * a3 * a2 * a1 * a0 - 4 * a2**3 * a0 + a2**2 * a1**2 - 4 * a3 * a1**3 - 27 * a3**2 * a0**2

    ws = np.linspace(lo, hi, 4001)
    d = np.array([disc(w) for w in ws])
    roots = sorted(brentq(disc, ws[i], ws[i + 1], xtol=1e-15) for i in np.nonzero(np.sign(d[:-1]) != np.sign(d[1:]))[0])
    return roots if len(roots) == 2 else []


def assert_same_csv(a, b):
    ra, rb = read_csv(a), read_csv(b)
    assert list(ra) == list(rb)
    for col in ra:
        if ra[col].dtype.kind in "fb":
            np.testing.assert_allclose(ra[col].astype(float), rb[col].astype(float), rtol=1e-12, atol=1e-13,
                                       err_msg=f"{a}: column {col}")
        else:
            assert list(ra[col]) == list(rb[col]), col


# ---------------------------------------------------------------- on the cluster
@pytest.mark.slow  # the cluster runs a sweep in test_a_worker_killed_in_the_middle_of_a_run_does_not_lose_its_point
def test_sweep_on_two_workers_equals_the_runs_one_by_one(cluster, tmp_path):
    grid = (parse_grid("model.parameters.F=0.3,0.5"), parse_grid("model.parameters.c=0.05,0.1,0.2"))
    opts = SweepOptions(DUFFING, grid, str(tmp_path / "sweep"), overrides=FAST, scheduler=cluster.scheduler_address,
                        progress=False)
    with no_hang(180):
        result = run_sweep(opts)
    assert [r["status"] for r in result.records] == ["complete"] * 6
    assert all(int(r["worker"].rsplit(":", 1)[1]) != os.getpid() for r in result.records)  # ran on the workers
    index = read_csv(tmp_path / "sweep" / "sweep.csv")
    assert len(index["point"]) == 6 and (tmp_path / "sweep" / "sweep_map.png").stat().st_size > 5000
    for i, p in enumerate(grid_points(grid)):
        F, c = dict(p.values)["model.parameters.F"], dict(p.values)["model.parameters.c"]
        ref = tmp_path / f"ref{i}"
        assert main(["run", DUFFING, "-o", str(ref), "-q", *sum((["--set", s] for s in FAST), []),
                     "--set", f"model.parameters.F={F}", "--set", f"model.parameters.c={c}"]) == 0
        got = tmp_path / "sweep" / "points" / p.name
        assert_same_csv(got / "branches.csv", ref / "branches.csv")
        assert_same_csv(got / "special_points.csv", ref / "special_points.csv")
        # the index row of the point: its values, and its folds at the closed-form values
        row = list(index["point"]).index(p.name)
        assert index["model.parameters.F"][row] == F and index["model.parameters.c"][row] == c
        folds = sorted(float(v) for v in str(index["fold_at"][row]).split(";") if v not in ("", "nan"))
        expected = duffing_folds(F, c)
        assert len(folds) == len(expected) == int(index["n_fold"][row])
        np.testing.assert_allclose(folds, expected, atol=1e-7)


def test_invalid_values_are_recorded_and_the_other_points_complete(cluster, tmp_path):
    # F=bad is refused when the model is built (on the worker); harmonics=0 by the scene schema
    grid = (parse_grid("model.parameters.F=0.3,bad"), parse_grid("analysis.harmonics=1,0"))
    opts = SweepOptions(DUFFING, grid, str(tmp_path / "s"), overrides=("output.plots=false",),
                        scheduler=cluster.scheduler_address, progress=False)
    with no_hang(120):
        result = run_sweep(opts)
    by_name = {r["point"]: r for r in result.records}
    assert by_name["F=0.3__harmonics=1"]["status"] == "complete"
    assert "model.parameters.F" in by_name["F=bad__harmonics=1"]["message"]
    assert "a finite number" in by_name["F=bad__harmonics=1"]["message"]
    assert "analysis.harmonics" in by_name["F=0.3__harmonics=0"]["message"]
    assert {r["point"] for r in result.failed} == {"F=bad__harmonics=1", "F=0.3__harmonics=0", "F=bad__harmonics=0"}
    for name in ("F=bad__harmonics=1", "F=0.3__harmonics=0"):
        summary = json.loads((tmp_path / "s" / "points" / name / "summary.json").read_text())
        assert summary["status"] == "failed" and summary["message"] == by_name[name]["message"]
    index = read_csv(tmp_path / "s" / "sweep.csv")
    assert sorted(index["status"]) == ["complete", "failed", "failed", "failed"]
    assert (tmp_path / "s" / "sweep_map.png").stat().st_size > 5000  # failed points are shown hatched


def points_running(outdir):
    """Temporary directories of runs in progress, with their branches.csv row counts."""
    out = {}
    for d in (Path(outdir) / "points").glob(".*.tmp-*"):
        try:
            out[d] = max(0, sum(1 for _ in open(d / "branches.csv")) - 1)
        except OSError:
            out[d] = 0
    return out


def test_a_worker_killed_in_the_middle_of_a_run_does_not_lose_its_point(cluster, tmp_path):
    from distributed import Client

    outdir = tmp_path / "s"
    grid = (parse_grid("model.parameters.F=0.3,0.5"),)
    with no_hang(240):
        with Client(cluster) as client:
            opts = SweepOptions(DUFFING, grid, str(outdir), overrides=SLOW, scheduler=cluster.scheduler_address,
                                progress=False)
            box = {}
            sweep = threading.Thread(target=lambda: box.setdefault("result", run_sweep(opts)))
            sweep.start()
            victim = None
            t0 = time.time()
            while victim is None and sweep.is_alive() and time.time() - t0 < 120:
                running = [d for d, rows in points_running(outdir).items() if rows > 20]
                if running:
                    name = running[0].name.split(".tmp-")[0][1:]
                    for addr, keys in client.processing().items():
                        if any(f"contin-point-{name}-" in str(k) for k in keys):
                            victim = (name, addr, client.run(os.getpid, workers=[addr])[addr])
                            break
                time.sleep(0.05)
            assert victim is not None, "no run was caught in the middle"
            name, addr, pid = victim
            os.kill(pid, signal.SIGKILL)
            sweep.join()
    result = box["result"]
    assert [r["status"] for r in result.records] == ["complete"] * 2
    record = json.loads((outdir / "points" / name / "point.json").read_text())
    assert record["status"] == "complete" and int(record["worker"].rsplit(":", 1)[1]) != pid  # run again elsewhere
    assert not list((outdir / "points").glob(".*"))  # the killed run's temporary directory is gone
    assert (outdir / "sweep_map.png").stat().st_size > 5000  # one axis: stable intervals and folds over F
    # the point run again is the same as a run in one go
    F = dict(next(p.values for p in grid_points(grid) if p.name == name))["model.parameters.F"]
    ref = tmp_path / "ref"
    assert main(["run", DUFFING, "-o", str(ref), "-q", *sum((["--set", s] for s in SLOW), []),
                 "--set", f"model.parameters.F={F}"]) == 0
    assert_same_csv(outdir / "points" / name / "branches.csv", ref / "branches.csv")


# ---------------------------------------------------------------- the grid and the options
def test_grid_lists_and_ranges():
    a = parse_grid("model.parameters.F=0:0.6:13")
    assert a.key == "model.parameters.F" and len(a.values) == 13
    assert a.values[0] == 0.0 and a.values[3] == 0.15 and a.values[-1] == 0.6 and a.values[1] == 0.05
    b = parse_grid("analysis.stability=hill,both")
    assert b.values == ("hill", "both")
    c = parse_grid("analysis.harmonics=3,5")
    assert c.values == (3, 5) and all(type(v) is int for v in c.values)
    assert parse_grid("model.parameters.c=1e-3,-2").values == (1e-3, -2)
    assert parse_grid("model.parameters.F=1:-1:3").values == (1.0, 0.0, -1.0)
    pts = grid_points((parse_grid("model.parameters.F=0.1,0.2"), c))
    assert [p.name for p in pts] == ["F=0.1__harmonics=3", "F=0.1__harmonics=5", "F=0.2__harmonics=3",
                                     "F=0.2__harmonics=5"]
    assert pts[1].overrides == ("model.parameters.F=0.1", "analysis.harmonics=5")
    # two axes with the same last key part are named in full
    same = grid_points((parse_grid("model.parameters.w=1,2"), parse_grid("analysis.continuation.w=1")))
    assert same[0].name == "model.parameters.w=1__analysis.continuation.w=1"


def test_an_axis_spells_the_option_that_gives_it_back():
    # as typed when parsed (so the resume command of an interrupted sweep is the command given), else its values
    for text in ("model.parameters.F=0:0.6:13", "analysis.stability=hill,both", "model.parameters.c=1e-3,-2"):
        assert parse_grid(text).option() == text
    axis = GridAxis("model.parameters.F", (0.1, 2, "1", True))
    assert axis.option() == "model.parameters.F=0.1,2,'1',true"
    assert parse_grid(axis.option()) == axis


@pytest.mark.parametrize("spec,fragment", [
    ("F", "dotted.key=SPEC"),
    ("model.parameters.F=", "a list v1,v2,... or a range"),
    ("model.parameters.F=0:1", "start:stop:count"),
    ("model.parameters.F=0:1:1", "count of at least 2"),
    ("model.parameters.F=0:1:2.5", "count is an integer"),
    ("model.parameters.F=a:1:3", "start and stop are numbers"),
    ("model.parameters.F=1:1:3", "start different from stop"),
    ("model.parameters.F=0.1,0.1", "distinct values"),
    ("model.parameters.F=0.1,,0.2", "a value between the commas"),
    ("model.parameters.F=inf", "finite"),
    ("model..F=1", "dotted scene key"),
])
def test_bad_grid_names_the_option(spec, fragment):
    with pytest.raises(SceneError) as info:
        parse_grid(spec)
    assert str(info.value).startswith("--grid") and fragment in str(info.value)


def test_options_are_checked_on_construction():
    g = (parse_grid("model.parameters.F=0.1,0.2"),)
    with pytest.raises(SceneError, match="--workers"):
        SweepOptions(DUFFING, g, "o", workers=0)
    with pytest.raises(SceneError, match="--workers.*--scheduler"):
        SweepOptions(DUFFING, g, "o", workers=2, scheduler="tcp://127.0.0.1:8786")
    with pytest.raises(SceneError, match="--set model.parameters.F.*not swept"):
        SweepOptions(DUFFING, g, "o", overrides=("model.parameters.F=1",))
    with pytest.raises(SceneError, match="--grid model.parameters.F.*one --grid"):
        SweepOptions(DUFFING, g + g, "o")
    with pytest.raises(SceneError, match="--retries"):
        SweepOptions(DUFFING, g, "o", retries=-1)
    with pytest.raises(SceneError, match="--grid"):
        SweepOptions(DUFFING, (), "o")
    with pytest.raises(SceneError, match="--grid x.*distinct"):
        GridAxis("x", (1, 1.0))
    opts = SweepOptions(DUFFING, g, "o")
    with pytest.raises(Exception):
        opts.workers = 3  # frozen


# ---------------------------------------------------------------- the summary of a point
def write_csv(path, header, rows):
    path.write_text(",".join(header) + "\n" + "".join(",".join(map(str, r)) + "\n" for r in rows))


def test_stable_intervals_end_at_the_located_changes(tmp_path):
    # branch 0 (nu=1): stable, loses stability at a pd located at 0.35, stable again from a pd at 0.72;
    # branch 1 (nu=2): from the pd, stable until a fold at 0.9 (it turns back), unstable after it
    header = ["branch", "nu", "p", "stable", "n_unstable", "max_multiplier"]
    write_csv(tmp_path / "branches.csv", header, [
        (0, 1, 0.0, "true", 0, 0.5), (0, 1, 0.2, "true", 0, 0.6), (0, 1, 0.4, "false", 1, 1.2),
        (0, 1, 0.7, "false", 1, 1.1), (0, 1, 0.8, "true", 0, 0.9), (0, 1, 1.0, "true", 0, 0.8),
        (1, 2, 0.35, "true", 0, 0.99), (1, 2, 0.6, "true", 0, 0.9), (1, 2, 0.85, "true", 0, 0.95),
        (1, 2, 0.88, "false", 1, 1.05), (1, 2, 0.5, "false", 1, 1.3)])
    write_csv(tmp_path / "special_points.csv", ["branch", "kind", "p", "index"], [
        (0, "pd", 0.35, 2), (0, "pd", 0.72, 3), (1, "fold", 0.9, 9), (0, "end", 1.0, 5)])
    (tmp_path / "summary.json").write_text(json.dumps({"status": "complete", "analysis": {
        "parameter": "p", "branches": [{"status": "range_end"}, {"status": "range_end"}]}}))
    rows, sp = read_csv(tmp_path / "branches.csv"), read_csv(tmp_path / "special_points.csv")
    iv = stable_intervals(rows, sp, "p")
    assert iv == {1: [(0.0, 0.35), (0.72, 1.0)], 2: [(0.35, 0.9)]}
    s = summarize_point(tmp_path)
    assert s["n_pd"] == 2 and s["pd_at"] == "0.35;0.72" and s["n_fold"] == 1 and s["fold_at"] == "0.9"
    assert s["stable_nu1"] == "0.0..0.35;0.72..1.0" and s["stable_nu2_from"] == 0.35 and s["stable_nu2_to"] == 0.9
    assert s["stable_nu1_length"] == pytest.approx(0.35 + 0.28) and s["rows"] == 11 and s["branches"] == 2
    # without stability there are no intervals
    write_csv(tmp_path / "branches.csv", header, [(0, 1, 0.0, "", "", ""), (0, 1, 0.5, "", "", "")])
    assert stable_intervals(read_csv(tmp_path / "branches.csv"), sp, "p") == {}
