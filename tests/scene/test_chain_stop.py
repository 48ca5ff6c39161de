"""scenes/chain_stop.yaml: a two-mass chain with a cubic spring and a one-sided stop has folds and no branch point."""

from pathlib import Path

import numpy as np
import pytest

from contin.app.cli import main
from contin.output.results import read_csv

ROOT = Path(__file__).resolve().parents[2]
SCENE = ROOT / "scenes" / "chain_stop.yaml"


@pytest.mark.slow
def test_the_chain_has_folds_and_no_branch_point_beside_them(scene_run, tmp_path):
    sp = read_csv(scene_run("chain_stop.yaml") / "special_points.csv")
    kinds, w = sp["kind"], sp["w"]
    folds = np.sort(w[kinds == "fold"])
    assert folds.size == 4  # two per resonance, the jump between them
    # the multiplier crossing +1 at each fold, a little off it at H = 9, was taken for a branch point
    assert "bp" not in set(kinds)
    for lo, hi in zip(sp["interval_lo"][kinds == "fold"], sp["interval_hi"][kinds == "fold"]):
        assert not np.any((kinds == "bp") & (w >= min(lo, hi) - 1e-3) & (w <= max(lo, hi) + 1e-3))
    # the folds of the truncated series against H = 25 (contact truncation: the upper folds to 2e-4)
    out = tmp_path / "h25"
    assert main(["run", str(SCENE), "-o", str(out), "-q", "--set", "analysis.harmonics=25",
                 "--set", "analysis.stability=none"]) == 0
    ref = read_csv(out / "special_points.csv")
    ref_folds = np.sort(ref["w"][ref["kind"] == "fold"])
    assert ref_folds.size == 4 and "bp" not in set(ref["kind"])
    np.testing.assert_allclose(folds, ref_folds, rtol=2e-4)
