"""The figure of a frequency response from its recorder (contin.analyses.response_figure): the dense curve on a
closed form, and the colour groups that hold whatever a panel draws."""

import math

import numpy as np

from contin.output.markers import start_group


def test_the_dense_curve_lies_on_the_duffing_amplitude_equation(tmp_path):
    """With H = 1 the harmonic balance of m x'' + c x' + k x + g x^3 = F cos(w t) is the classical
    amplitude equation ((k - m w^2) A + 3/4 g A^3)^2 + (c w A)^2 = F^2 (Nayfeh & Mook 1979, 4.1):
    the points drawn between the stored ones, read back from the checkpoint as a resumed run would, obey it."""
    from pathlib import Path

    from contin.analyses.branch_recorder import BranchRecorder
    from contin.analyses.response_figure import diagram_branches
    from contin.app.runner import run_scene
    from contin.output.checkpoint import read_records, rebuild_branches
    from contin.scene.build import build_model
    from contin.scene.parse import parse_scene

    text = (Path(__file__).resolve().parents[2] / "scenes" / "duffing.yaml").read_text()
    scene = parse_scene(text, "duffing.yaml", ["analysis.harmonics=1", "output.plots=false"])
    run_scene(scene, tmp_path, progress=False)
    model = build_model(scene)
    rec = BranchRecorder(tmp_path, model.dof_names, "w", 5, 1, append=True, model=model)
    rec.restore(rebuild_branches(read_records(tmp_path / "state.jsonl"), "w"))
    rec.close()
    (branch,), special = diagram_branches(rec, "amp_x")
    stored = np.asarray(rec.curves[0]["x"])
    w, A = branch["x"], branch["y"]
    added = ~np.isin(w, stored)
    assert added.sum() >= 20  # points between the stored ones, where the curve bends
    p = model.parameters
    lhs = ((p["k"] - p["m"] * w ** 2) * A + 0.75 * p["g"] * A ** 3) ** 2 + (p["c"] * w * A) ** 2
    np.testing.assert_allclose(lhs[added], p["F"] ** 2, rtol=1e-3)
    # the folds are on the curve, and a change of stability is drawn where it was located
    assert sum(s["kind"] == "fold" for s in special) == 2
    switches = 0
    for s in special:
        k = int(np.flatnonzero((w == s["x"]) & (A == s["y"]))[0])
        flags = branch["stable"]
        if flags[k - 1] != flags[k + 1]:  # the new style starts at the point itself
            assert flags[k] == flags[k + 1]
            switches += 1
    assert switches >= 1


def test_the_halves_of_a_branch_share_a_group_in_a_panel_of_a_torus_only_column():
    """A periodic branch has no value in a torus-only column (NaN): its halves, started at one point, still
    share one colour there, and a branch started elsewhere does not."""
    a = start_group(2, 2.16, [0.71, math.nan])
    assert a == start_group(2, 2.16, [0.71, float("nan")])
    assert a != start_group(2, 2.16, [0.72, math.nan]) and a != start_group(1, 2.16, [0.71, math.nan])
