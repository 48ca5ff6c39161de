"""``analysis.method: auto``: harmonic balance handed to shooting where it cannot pass a grazing point.

Truth from outside the code: the one-sided stop's linear response reaches the
stop where ``F / |1 - w^2 + i c w| = g`` (closed form), and each orbit past it
closes after one forcing period under scipy's DOP853 (the code's RK4 is not
used).
"""

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from contin.app.runner import run_scene
from contin.output.checkpoint import read_records
from contin.output.results import read_csv
from contin.scene.parse import parse_scene

#: x'' + 0.05 x' + x + 300 (x - 1)_+ = 0.2 cos(w t): a stop at x = 1; no method key: auto for a contact model
GAP = """\
model:
  name: gap_oscillator
  dofs: [x]
  parameters: {m: 1, c: 0.05, k: 1, g: 1, kc: 300, F: 0.2, w: 0.6}
  mass: [[m]]
  damping: [[c]]
  stiffness: [[k]]
  forces:
    - {type: gap, dof: x, clearance: g, stiffness: kc, damping: 0, sides: '+'}
  excitation:
    - {dof: x, amplitude: F, order: 1}
  frequency: w
analysis:
  type: frequency_response
  parameter: w
  range: [0.6, 1.1]
  harmonics: 15
  samples: 512
  stability: none
  shooting: {steps_per_period: 1024}
output: {measure: amp_x, plots: false}
"""

W_GRAZE = brentq(lambda w: 0.2 / np.hypot(1 - w * w, 0.05 * w) - 1.0, 0.5, 0.99)


def _closes(z, w):
    """``max |phi_T(z) - z|`` of the stop oscillator by DOP853 with steps below 1e-3 (the contact's corner
    resolved by the step bound; contin's RK4 is not used)."""
    def rhs(t, y):
        return [y[1], -0.05 * y[1] - y[0] - 300.0 * max(y[0] - 1.0, 0.0) + 0.2 * np.cos(w * t)]

    sol = solve_ivp(rhs, (0.0, 2 * np.pi / w), z, method="DOP853", rtol=1e-12, atol=1e-13, max_step=1e-3)
    return float(np.abs(sol.y[:, -1] - z).max())


@pytest.mark.slow  # a harmonic-balance branch and a shooting branch (~4 s)
def test_auto_passes_the_grazing_point_by_shooting_and_covers_the_range(tmp_path):
    out = tmp_path / "out"
    s = run_scene(parse_scene(GAP), out, progress=False)
    assert s["status"] == "complete" and s["shortfalls"] == []
    b0, b1 = s["analysis"]["branches"]
    assert (b0["method"], b0["status"], b0["end"], b0["handed_over_to"]) == ("hb", "boundary", "handover", 1)
    assert (b1["method"], b1["status"], b1["handed_over_from"]) == ("shooting", "range_end", 0)
    # shooting takes over a few points before the grazing point, where the truncated series and the flow agree
    # (contin.analyses.handover), and locates the grazing point itself on its own branch
    assert b1["origin"]["kind"] == "handover" and W_GRAZE - 0.05 < b1["origin"]["parameter"] < W_GRAZE
    sp = read_csv(out / "special_points.csv")
    for branch in (0, 1):
        graze = [float(w) for b, k, w in zip(sp["branch"], sp["kind"], sp["w"]) if k == "grazing" and int(b) == branch]
        assert graze == [pytest.approx(W_GRAZE, abs=1e-8)]
    rows = read_csv(out / "branches.csv")
    on = np.asarray(rows["branch"]) == 1
    w1 = np.asarray(rows["w"])[on]
    assert w1.min() == pytest.approx(b1["origin"]["parameter"]) and w1.max() == 1.1  # on to the range's end
    assert np.all(np.asarray(rows["max_x"])[on][w1 > W_GRAZE + 0.01] > 1.0)  # in contact past the grazing point
    states = {r["row"]: np.asarray(r["u"], float) for r in read_records(out / "state.jsonl") if r["type"] == "point"}
    for j in np.flatnonzero(on)[1::5]:
        assert _closes(states[int(j)][:2], float(rows["w"][j])) < 1e-6


def interrupted_and_resumed(tmp_path, monkeypatch, interrupt):
    """The stop oscillator run through, and run again with a Ctrl-C once ``interrupt(progress lines so far)`` says
    so, then resumed: ``(rows of the first, rows of the resumed, the progress lines of the interrupted)``, both
    runs' float columns checked equal."""
    import signal

    from contin.app.cli import main
    from contin.app.progress import Progress

    scene = tmp_path / "gap.yaml"
    scene.write_text(GAP)
    assert main(["run", str(scene), "-o", str(tmp_path / "ref"), "-q"]) == 0
    update, calls = Progress.update, []

    def ctrl_c(self, text, **kwargs):
        calls.append(text)
        if interrupt(calls):
            signal.raise_signal(signal.SIGINT)
        update(self, text, **kwargs)

    monkeypatch.setattr(Progress, "update", ctrl_c)
    assert main(["run", str(scene), "-o", str(tmp_path / "run"), "-q"]) == 130
    monkeypatch.setattr(Progress, "update", update)
    assert main(["run", str(scene), "-o", str(tmp_path / "run"), "-q", "--resume"]) == 0
    a, b = read_csv(tmp_path / "ref" / "branches.csv"), read_csv(tmp_path / "run" / "branches.csv")
    assert len(a["w"]) == len(b["w"])
    for col in a:
        if a[col].dtype.kind == "f":
            np.testing.assert_allclose(b[col], a[col], rtol=1e-9, atol=1e-12, err_msg=col)
    return a, b, calls


@pytest.mark.slow  # the run twice, once interrupted in its shooting branch (~4 s)
def test_a_run_interrupted_after_the_handover_resumes_to_the_same_rows(tmp_path, monkeypatch):
    _, _, calls = interrupted_and_resumed(tmp_path, monkeypatch, lambda calls: len(calls) == 25)
    assert calls[24].startswith("branch 1 (nu=1)")  # the shooting branch's 7th point


@pytest.mark.slow  # a harmonic-balance branch and the handover's tries (~3 s)
def test_a_flow_too_coarse_for_the_contact_meets_no_branch_and_the_shortfall_says_which_steps(tmp_path):
    """At 32 RK4 steps a period the stop's contact (stiffness 300, its period a fifth of the forcing's) is not
    resolved: no shooting orbit lies within reach of the truncated series, the branch ends at its grazing
    point and the shortfall names the steps the flow was integrated at and the key that sets them."""
    s = run_scene(parse_scene(GAP.replace("shooting: {steps_per_period: 1024}", "shooting: {steps_per_period: 32}")),
                  tmp_path / "out", progress=False)
    assert s["status"] == "incomplete" and len(s["analysis"]["branches"]) == 1
    b0 = s["analysis"]["branches"][0]
    assert b0["status"] == "boundary" and "32 steps a period" in b0["handover_failed"]
    assert any("shooting could not take it over" in line and "analysis.shooting.steps_per_period" in line
               for line in s["shortfalls"])
