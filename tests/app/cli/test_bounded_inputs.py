"""Bad input refused before anything is written, exit 2 with a message: scene files that are no regular files,
scenes that ask more than the machine has, labels matplotlib cannot draw, ``contin plot`` on an absurd stored
row, ``contin sweep --grid`` beyond its cap, ``contin absorber`` values whose ratios underflow."""

import json
import os
import tracemalloc
from pathlib import Path

import pytest

from conftest import no_hang
from contin.app.cli import main
from contin.app.sweep_grid import GridAxis, grid_points, parse_grid
from contin.scene.parse import SceneError

try:
    import contin.scene.budget as budget
except ImportError:  # a tree without the estimate: the run below is not refused, and its test fails
    budget = None
MAX_GRID_POINTS = 100_000  # contin.app.sweep_grid.MAX_GRID_POINTS, as documented in docs/reference/cli.md

ROOT = Path(__file__).resolve().parents[3]
DUFFING = str(ROOT / "scenes" / "duffing.yaml")
FAST = ["-q", "--set", "analysis.harmonics=1", "--set", "output.plots=false"]


def run(argv, capsys):
    code = main(argv)
    err = capsys.readouterr().err
    assert "Traceback" not in err
    return code, " ".join(err.split())


@pytest.mark.parametrize("kind", ["zero", "urandom", "fifo"])
@pytest.mark.parametrize("command", ["check", "run"])
def test_a_scene_that_is_no_regular_file_exits_2_at_once(tmp_path, capsys, kind, command):
    scene = tmp_path / "scene.yaml"
    if kind == "fifo":
        os.mkfifo(scene)
    else:
        scene.symlink_to(f"/dev/{kind}")
    out = tmp_path / "out"
    with no_hang(20):
        code, err = run([command, str(scene)] + (["-o", str(out), "-q"] if command == "run" else []), capsys)
    assert code == 2 and "not a regular file" in err and "scene.yaml" in err
    assert not out.exists()


def test_a_run_that_cannot_fit_exits_2_and_writes_nothing(tmp_path, capsys, monkeypatch):
    if budget is not None:
        monkeypatch.setattr(budget, "machine_memory", lambda: (24.0 * 2**30, None, "available (MemAvailable)"))
    out = tmp_path / "out"
    code, err = run(["run", DUFFING, "-o", str(out), "-q", "--set", "analysis.stability=floquet",
                     "--set", "analysis.stability_options.steps_per_period=1000000000000"], capsys)
    assert code == 2 and "analysis.stability_options.steps_per_period" in err and "87.3 TiB" in err
    assert not out.exists()


def test_a_label_matplotlib_cannot_draw_is_refused_before_the_run(tmp_path, capsys):
    out = tmp_path / "out"
    code, err = run(["run", DUFFING, "-o", str(out), "-q", "--set", "analysis.harmonics=1",
                     "--set", r"output.labels={w: 'speed $\frac{w$'}"], capsys)
    assert code == 2 and "output.labels.w" in err and "matplotlib says" in err
    assert not out.exists()


def test_plot_of_a_row_claiming_a_huge_harmonic_count_is_refused_small(tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["run", DUFFING, "-o", str(out), *FAST, "--set", "analysis.continuation.max_points=4"]) == 0
    capsys.readouterr()
    state = out / "state.jsonl"
    records = [json.loads(line) for line in state.read_text().splitlines()]
    for rec in records:
        if rec["type"] == "point" and rec["row"] == 0:
            rec["H"] = 100_000_000
    state.write_text("".join(json.dumps(r) + "\n" for r in records))
    tracemalloc.start()
    try:
        code, err = run(["plot", str(out), "--point", "0"], capsys)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert code == 2 and "row 0 with 200000001 coefficients (1 dof x (2H+1), H = 100000000)" in err
    assert peak < 200 * 2**20  # refused before the problem of H = 1e8 (its samples alone: 3.2 GB) is made


def test_plot_of_a_row_still_draws(tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["run", DUFFING, "-o", str(out), *FAST, "--set", "analysis.continuation.max_points=3"]) == 0
    assert main(["plot", str(out), "--point", "1"]) == 0
    assert (out / "point_1.png").stat().st_size > 1000


def test_a_grid_range_beyond_the_cap_is_refused_before_its_values_are_made(capsys):
    tracemalloc.start()
    try:
        with pytest.raises(SceneError, match=r"--grid F: expected a range .*at most 100000, found '1000000000 values'"):
            parse_grid("F=0:1:1000000000")
        assert tracemalloc.get_traced_memory()[1] < 10 * 2**20
    finally:
        tracemalloc.stop()
    code, err = run(["sweep", DUFFING, "--grid", "model.parameters.F=0:1:1000000000", "--serial"], capsys)
    assert code == 2 and "1000000000 values" in err


def test_a_grid_whose_product_is_beyond_the_cap_is_refused():
    a, b = parse_grid("model.parameters.F=0:1:1000"), parse_grid("model.parameters.c=0:1:1000")
    with pytest.raises(SceneError, match=r"at most 100000 points .*found '1000000 points \(1000 x 1000\)'"):
        grid_points([a, b])
    assert len(grid_points([parse_grid("x=0:1:40"), parse_grid("y=0:1:25")])) == 1000
    with pytest.raises(SceneError, match="at most 100000 values"):
        parse_grid("x=" + ",".join(map(str, range(MAX_GRID_POINTS + 1))))
    with pytest.raises(SceneError, match="at most 100000 values"):
        GridAxis("x", tuple(range(MAX_GRID_POINTS + 1)))
    from contin.app.sweep_grid import MAX_GRID_POINTS as cap

    assert cap == MAX_GRID_POINTS


@pytest.mark.parametrize("args, fragment", [
    (["--m2", "1e-320"], "m2 = 1e-320 with m1 = 100.0 gives the mass ratio m2/m1 = 9.881e-323"),
    (["--m2", "1e+300"], "mass ratio m2/m1 = 1e+298"),
    (["--max-amplification", "1e+200"], "max_amplification = 1e+200 asks the mass ratio"),
])
def test_absorber_values_whose_ratios_break_the_design_exit_2(capsys, args, fragment):
    code, err = run(["absorber", "--m1", "100", "--k1", "5e5"] + args, capsys)
    assert code == 2 and fragment in err and "outside the 0.001 to 1000" in err
