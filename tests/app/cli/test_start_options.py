"""Start options of a frequency response: from a time simulation, and both ways from the start."""

from pathlib import Path

import numpy as np

from contin.app.cli import main
from contin.output.results import read_csv

ROOT = Path(__file__).resolve().parents[3]


def test_duffing_started_from_simulation_both_ways(tmp_path):
    out = tmp_path / "d"
    code = main(["run", str(ROOT / "scenes/duffing.yaml"), "-o", str(out), "-q",
                 "--set", "analysis.harmonics=1", "--set", "analysis.start=1.0", "--set", "analysis.start_from=simulation",
                 "--set", "analysis.start_simulation={transient: 150, steps_per_period: 256}",
                 "--set", "analysis.both_ways=true", "--set", "analysis.stability=none"])
    assert code == 0
    rows = read_csv(out / "branches.csv")
    A, w = rows["h1_x"], rows["w"]
    np.testing.assert_allclose(((1 - w**2 + 0.75 * A**2) ** 2 + (0.1 * w) ** 2) * A**2, 0.25, atol=1e-9)
    ends = {int(b): (w[rows["branch"] == b][0], w[rows["branch"] == b][-1]) for b in np.unique(rows["branch"])}
    assert sorted(ends) == [0, 1]
    assert ends[0] == (1.0, 3.0) and ends[1] == (1.0, 0.5)  # both ways from the start, each to its range end
    sp = read_csv(out / "special_points.csv")
    assert list(sp["kind"]).count("fold") == 2  # the jump region lies on the rising side


def test_bad_start_simulation_key(tmp_path, capsys):
    code = main(["run", str(ROOT / "scenes/duffing.yaml"), "-o", str(tmp_path / "x"), "-q",
                 "--set", "analysis.start_from=simulation", "--set", "analysis.start_simulation={transients: 3}"])
    assert code == 2
    assert "analysis.start_simulation" in capsys.readouterr().err
