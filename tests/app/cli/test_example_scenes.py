"""Example scenes: check -> run -> files, compared with the closed form of each case."""

from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq
from scipy.special import mathieu_a, mathieu_b

from contin.app.cli import main
from contin.output.results import read_csv

ROOT = Path(__file__).resolve().parents[3]


def run(scene, scene_run):
    assert main(["check", str(ROOT / "scenes" / scene)]) == 0
    out = scene_run(scene)  # the run shared with tests/hard/test_invariants.py
    return read_csv(out / "branches.csv"), read_csv(out / "special_points.csv")


def test_mathieu_scene_stability_changes_on_the_transition_curves(scene_run):
    rows, sp = run("mathieu.yaml", scene_run)
    q = 2 * 0.4
    ref = {"bp": [mathieu_a(0, q) / 4, mathieu_b(2, q) / 4, mathieu_a(2, q) / 4],
           "pd": [mathieu_b(1, q) / 4, mathieu_a(1, q) / 4]}
    for kind, values in ref.items():
        got = np.sort(sp["delta"][sp["kind"] == kind])
        np.testing.assert_allclose(got, np.sort(values), atol=1e-6)
    # stable between the tongues [a0/4, b1/4], [a1/4, b2/4] and beyond a2/4 (up to b3/4 = 2.2)
    d, st = rows["delta"], rows["stable"]
    inside = (((d > ref["bp"][0] + 1e-3) & (d < ref["pd"][0] - 1e-3))
              | ((d > ref["pd"][1] + 1e-3) & (d < ref["bp"][1] - 1e-3)) | (d > ref["bp"][2] + 1e-3))
    outside = ((d < ref["bp"][0] - 1e-3) | ((d > ref["pd"][0] + 1e-3) & (d < ref["pd"][1] - 1e-3))
               | ((d > ref["bp"][1] + 1e-3) & (d < ref["bp"][2] - 1e-3)))
    assert inside.sum() >= 5 and outside.sum() >= 3
    assert np.all(st[inside]) and not np.any(st[outside])


def damped_mathieu_pd(c, eps):
    """delta where the linear damped Mathieu equation has a multiplier -1 (independent monodromy)."""

    def trace_plus_det(delta):
        def rhs(t, z):
            x, v = z[:2], z[2:]
            return np.concatenate([v, -c * v - (delta + eps * np.cos(t)) * x])

        sol = solve_ivp(rhs, (0, 2 * np.pi), [1, 0, 0, 1], method="DOP853", rtol=1e-12, atol=1e-13)
        Phi = np.array([[sol.y[0, -1], sol.y[1, -1]], [sol.y[2, -1], sol.y[3, -1]]])
        return 1 + np.trace(Phi) + np.linalg.det(Phi)  # characteristic polynomial at -1

    return brentq(trace_plus_det, 0.0, 0.25), brentq(trace_plus_det, 0.25, 0.6)


def test_mathieu_duffing_scene_switches_at_period_doubling(scene_run):
    rows, sp = run("mathieu_duffing_pd.yaml", scene_run)
    pds = np.sort(sp["delta"][(sp["kind"] == "pd") & (sp["branch"] == 0)])
    np.testing.assert_allclose(pds, damped_mathieu_pd(0.1, 0.4), atol=1e-6)
    nu2 = rows["nu"] == 2
    assert nu2.any()
    # the subharmonic branches carry the odd harmonics of w/2 (h1 is the w/2 component)
    assert np.all(rows["h1_x"][nu2 & (rows["amp_x"] > 1e-3)] > 1e-4)
    # they are born at the pd points: their smallest amplitudes sit next to the pd parameters
    for b in np.unique(rows["branch"][nu2]):
        sel = rows["branch"] == b
        start = rows["delta"][sel][np.argmin(rows["amp_x"][sel])]
        assert np.min(np.abs(pds - start)) < 1e-2


def test_absorber_exercise_matches_den_hartog_and_the_closed_form_frf(scene_run):
    rows, sp = run("absorber_exercise.yaml", scene_run)
    m1, k1, m2, F = 100.0, 5e5, 10.0, 1.0
    beta = m2 / m1
    p = np.sqrt(k1 / m1)
    k2 = k1 * beta / (1 + beta) ** 2
    c = 2 * m2 * p * np.sqrt(3 * beta / (8 * (1 + beta) ** 3))
    assert abs(k2 - 41322.31) < 0.01 and abs(c - 237.379) < 1e-3  # the exercise's answers
    M = np.diag([m1, m2])
    C = np.array([[c, -c], [-c, c]])
    K = np.array([[k1 + k2, -k2], [-k2, k2]])
    X1 = np.array([abs(np.linalg.solve(K - w**2 * M + 1j * w * C, [F, 0.0])[0]) for w in rows["w"]])
    np.testing.assert_allclose(rows["amp_x1"], X1, rtol=1e-10)
    # Den Hartog: both fixed points at height sqrt((2 + beta)/beta) delta_st; the optimum's true peak
    # lies slightly above them
    height = np.sqrt((2 + beta) / beta)
    peak = rows["amp_x1"].max() / (F / k1)
    assert height <= peak < 1.03 * height


def test_gap_oscillator_is_linear_inside_the_clearance_and_folds_beyond(scene_run):
    rows, sp = run("gap_oscillator.yaml", scene_run)
    c, F, g = 0.05, 0.2, 1.0
    w = rows["w"]
    free = rows["max_x"] < g - 1e-9  # never touches a stop: exactly the linear oscillator
    assert free.sum() > 10
    linear = F / np.sqrt((1 - w[free] ** 2) ** 2 + (c * w[free]) ** 2)
    np.testing.assert_allclose(rows["h1_x"][free], linear, rtol=1e-9)
    np.testing.assert_allclose(rows["h3_x"][free], 0.0, atol=1e-10)  # the Newton tolerance
    # beyond the clearance the stops harden the resonance: a jump region with two folds above w = 1
    folds = np.sort(sp["w"][sp["kind"] == "fold"])
    assert len(folds) == 2 and 1.0 < folds[0] < folds[1]
    assert rows["max_x"].max() > g
