"""A shooting branch that crawls is continued with its orbits cut at another section (contin.analyses.recut).

The stop oscillator of the handover tests: harmonic balance to its grazing point, shooting on to the range's
end. Here the shooting branch cut at ``t = 0`` is made to crawl past w = 0.95 (the engine's crawl check
answers yes there); the run continues it from its last orbit cut at the orbit's quiet section and covers the
range. Truth from outside the code: each continued orbit, integrated by scipy's DOP853 from its stored state
at its own section's time, closes after one forcing period; the amplitude (a property of the orbit, not of
the section) goes on from the crawled branch's last row.
"""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from contin.app.runner import run_scene
from contin.engine import continuation
from contin.engine.branch import BranchStatus
from contin.model.periodic import is_shooting
from contin.output.checkpoint import read_records
from contin.output.results import read_csv
from contin.scene.parse import parse_scene

from test_frequency_response_handover import GAP, interrupted_and_resumed

W_CRAWL = 0.95


def _closes(z, w, t0):
    """``max |phi_T(z) - z|`` from the time ``t0`` (DOP853, steps below 1e-3 for the contact's corner)."""
    def rhs(t, y):
        return [y[1], -0.05 * y[1] - y[0] - 300.0 * max(y[0] - 1.0, 0.0) + 0.2 * np.cos(w * t)]

    sol = solve_ivp(rhs, (t0, t0 + 2 * np.pi / w), z, method="DOP853", rtol=1e-12, atol=1e-13, max_step=1e-3)
    return float(np.abs(sol.y[:, -1] - z).max())


@pytest.fixture
def crawling(monkeypatch):
    """The engine's crawl check answers yes on a shooting branch cut at ``t = 0`` once it is past W_CRAWL."""
    goes_on = continuation._Engine._goes_on

    def made_to_crawl(self, cand, ds_try):
        opts = getattr(self.problem, "options", None)
        if (is_shooting(self.problem) and getattr(opts, "start_step", None) == 0 and self.pos.lam > W_CRAWL):
            self.builder.finish(BranchStatus.STEP_TOO_SMALL, "the branch crawled (made to by the test)")
            return False
        return goes_on(self, cand, ds_try)

    monkeypatch.setattr(continuation._Engine, "_goes_on", made_to_crawl)


def test_a_crawling_shooting_branch_goes_on_at_another_section_and_the_run_is_complete(tmp_path, crawling):
    out = tmp_path / "out"
    s = run_scene(parse_scene(GAP), out, progress=False)
    assert s["status"] == "complete" and s["shortfalls"] == []
    b0, b1, b2 = s["analysis"]["branches"]
    assert b0["handed_over_to"] == 1
    assert (b1["status"], b1["end"], b1["recut_to"]) == ("step_too_small", "recut", 2)
    assert (b2["method"], b2["status"], b2["recut_from"]) == ("shooting", "range_end", 1)
    rows = read_csv(out / "branches.csv")
    w, branch, amp = (np.asarray(rows[k]) for k in ("w", "branch", "amp_x"))
    w1, w2 = w[branch == 1], w[branch == 2]
    assert W_CRAWL < w1[-1] < W_CRAWL + 0.05 and w2[0] == w1[-1] and w2[-1] == 1.1
    assert amp[branch == 2][0] == pytest.approx(amp[branch == 1][-1], rel=1e-9)
    section = b2["origin"]["note"].split("at step ")[1].split()[0]
    k0, steps = int(section), 1024
    assert 0 < k0 < steps
    states = {r["row"]: np.asarray(r["u"], float) for r in read_records(out / "state.jsonl") if r["type"] == "point"}
    for j in np.flatnonzero(branch == 2)[::4]:
        wj = float(w[j])
        assert _closes(states[int(j)][:2], wj, k0 / steps * 2 * np.pi / wj) < 1e-6


@pytest.mark.slow  # the run twice, once interrupted in its continuation (~4 s)
def test_a_run_interrupted_in_the_continuation_resumes_to_the_same_rows(tmp_path, crawling, monkeypatch):
    def third_of_branch_2(calls):
        return calls[-1].startswith("branch 2 ") and sum(c.startswith("branch 2 ") for c in calls) == 3

    _, rows, _ = interrupted_and_resumed(tmp_path, monkeypatch, third_of_branch_2)
    assert set(np.asarray(rows["branch"])) == {0, 1, 2}
