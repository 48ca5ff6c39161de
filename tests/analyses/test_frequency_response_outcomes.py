"""``frequency_response`` says ``complete`` only where it did all its scene asked: no cap the scene did not set,
no range end it did not reach, no requested switch dropped without a word."""

from contin.app.runner import run_scene
from contin.output.results import read_csv
from contin.scene.parse import parse_scene
from linear_scene import LINEAR_OSCILLATOR

LINEAR = LINEAR_OSCILLATOR + """  continuation: {ds: 0.01, ds_max: 0.01%s}
output: {plots: false}
"""


def test_a_cap_the_scene_did_not_set_is_a_shortfall_one_it_set_is_not(tmp_path, monkeypatch):
    from contin.engine import options

    # the default cap as a smaller number, for speed: 20 points of the ~100 the range needs
    monkeypatch.setattr(options, "DEFAULT_MAX_POINTS", 20, raising=False)
    short = run_scene(parse_scene(LINEAR % ""), tmp_path / "default", progress=False)
    assert short["status"] == "incomplete"
    (line,) = short["analysis"]["shortfalls"]
    assert line.startswith("branch 0 (nu=1) ended default_max_points after 20 points: stored the default cap of "
                           "20 points (max_points was not set)")
    assert "raise max_points (continuation.max_points in a scene) to go on" in line
    assert line.endswith(", 2.5] not covered")
    capped = run_scene(parse_scene(LINEAR % ", max_points: 20"), tmp_path / "set", progress=False)
    assert capped["status"] == "complete" and capped["analysis"]["shortfalls"] == []
    assert capped["analysis"]["branches"][0]["status"] == "max_points"


DUFFING = """
model:
  builtin: duffing
  parameters: {m: 1, c: 0.1, k: 1, g: 1, F: 0.5}
  effects: [damping, cubic, forcing]
analysis:
  type: frequency_response
  parameter: w
  range: [0.5, %s]
  harmonics: 9
  stability: none
  continuation: {max_points: 12}
output: {plots: false}
"""


def test_a_huge_range_is_followed_from_its_start_not_ended_there(tmp_path):
    """The start tangent's parameter component, ~1/1e17 in the range's scale, once lost its sign: one point,
    "range_end: reached the end of the parameter range at w=0.5", complete (1e50 and 1e300: tests/engine)."""
    summary = run_scene(parse_scene(DUFFING % "1.0e17"), tmp_path / "out", progress=False)
    (b,) = summary["analysis"]["branches"]
    assert b["status"] == "max_points" and b["points"] == 12, b["message"]
    w = read_csv(tmp_path / "out" / "branches.csv")["w"]
    assert w[0] == 0.5 and all(w[1:] > w[:-1])  # into the range, not out of it at its start
    kinds = list(read_csv(tmp_path / "out" / "special_points.csv").get("kind", []))
    assert "end" not in kinds


MATHIEU = """
model:
  builtin: mathieu
  parameters: {eps: 0.4, c: 0.1, g: 1.0, w: 1.0}
  effects: [damping, parametric, cubic]
analysis:
  type: frequency_response
  parameter: delta
  range: [-0.2, 0.8]
  harmonics: 4
  stability: hill
  switch: [pd]
  continuation: {locate_max_iter: 2}
output: {plots: false}
"""


def test_a_requested_switch_at_a_point_that_was_not_located_starts_from_its_bracket(tmp_path):
    """Two iterations cannot locate the period doublings (where x = 0 loses stability): the points are tabled
    as unlocated (they once were dropped without a word), and the switch asked at each starts from the best
    point of its final bracket. The nu = 2 branches are those switched at the located points (same scene,
    the default location): their amplitudes agree along the parameter."""
    import numpy as np

    summary = run_scene(parse_scene(MATHIEU), tmp_path / "out", progress=False)
    pd = [r for r in zip(*(read_csv(tmp_path / "out" / "special_points.csv")[k] for k in ("kind", "located")))
          if r[0] == "pd"]
    assert len(pd) == 2 and not any(located for _, located in pd)
    children = [b for b in summary["analysis"]["branches"] if b["parent"] == 0]
    assert len(children) == 2 and all(b["nu"] == 2 for b in children)
    for b in children:
        assert b["origin"]["located"] is False and "switched from the bracket" in b["origin"]["note"]
    assert summary["status"] == "complete", summary.get("shortfalls")

    located = run_scene(parse_scene(MATHIEU.replace("  continuation: {locate_max_iter: 2}\n", "")),
                        tmp_path / "located", progress=False)
    assert [b["nu"] for b in located["analysis"]["branches"]] == [1, 2, 2]
    ours, ref = read_csv(tmp_path / "out" / "branches.csv"), read_csv(tmp_path / "located" / "branches.csv")
    for bid in (1, 2):
        a, r = ours["branch"] == bid, ref["branch"] == bid
        # compare inside the common part of the two curves, by the measure at the same delta
        lo = max(ours["delta"][a].min(), ref["delta"][r].min())
        hi = min(ours["delta"][a].max(), ref["delta"][r].max())
        assert hi - lo > 0.05
        grid = np.linspace(lo, hi, 7)[1:-1]
        order_a, order_r = np.argsort(ours["delta"][a]), np.argsort(ref["delta"][r])
        ya = np.interp(grid, ours["delta"][a][order_a], ours["amp_x"][a][order_a])
        yr = np.interp(grid, ref["delta"][r][order_r], ref["amp_x"][r][order_r])
        assert np.max(np.abs(ya - yr)) < 1e-3 * np.max(np.abs(yr))