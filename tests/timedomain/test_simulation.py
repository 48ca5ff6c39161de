"""Time simulation: compiled right-hand side, located contact switching (order of accuracy), errors, cache."""

import math
import subprocess
import sys
import textwrap

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from contin.model.elements import GapForce
from contin.model.base import ForceElement, Monomial
from contin.models.polynomial import polynomial_model
from contin.scene.build import build_model
from contin.scene.parse import parse_scene
from contin.timedomain.simulation import SimulationError, compile_model, simulate

# clearance oscillator with contact damping: x'' + c x' + x + gap(x) = F cos(w t),
# gap = k (x -+ g) + cc x' beyond |x| = g (the damping term switches on with a non-zero velocity)
OSC = {"c": 0.05, "F": 0.6, "w": 1.2, "g": 0.5, "k": 20.0, "cc": 0.5}
X0, V0, PERIODS = 0.3, 0.8, 4


def oscillator(clip=False, **over):
    params = dict(OSC, **over)
    model = polynomial_model(["x"], params, mass=[[1.0]], damping=[["c"]], stiffness=[[1.0]],
                             forcing=[{"dof": "x", "amplitude": "F"}], name="clearance_oscillator")
    names = list(model.parameters)
    model.forces.append(GapForce(0, Monomial.parse("g", names), Monomial.parse("k", names),
                                 Monomial.parse("cc", names), clip=clip))
    return model


def reference_oscillator(t_end, clip=False, p=OSC, start=(X0, V0)):
    """Event-driven DOP853 (rtol 1e-12): one smooth law per contact state, restarted at each switching.

    Returns the state at ``t_end`` and the number of switches."""
    return _reference(t_end, clip, p, start)[:2]


def _reference(t_end, clip, p, start, max_step=np.inf):
    c, F, w, g, k, cc = (p[n] for n in ("c", "F", "w", "g", "k", "cc"))
    t, y = 0.0, np.array(start, dtype=float)
    side = 1 if y[0] > g else (-1 if y[0] < -g else 0)  # contact side, 0 = free

    def force(s, x, v):
        return k * (x - s * g) + cc * v

    n_events, times = 0, []
    while t < t_end:
        def rhs(tt, z, s=side):
            x, v = z
            f = force(s, x, v) if s else 0.0
            return [v, F * math.cos(w * tt) - c * v - x - f]

        events = []
        if side == 0:
            for s in (1, -1):
                ev = (lambda tt, z, s=s: s * z[0] - g)
                ev.terminal, ev.direction = True, 1
                events.append(ev)
        else:
            ev = (lambda tt, z, s=side: s * z[0] - g)  # leaves the stop
            ev.terminal, ev.direction = True, -1
            events.append(ev)
            if clip:
                ev2 = (lambda tt, z, s=side: s * force(s, z[0], z[1]))  # the clipped force reaches zero
                ev2.terminal, ev2.direction = True, -1
                events.append(ev2)
        sol = solve_ivp(rhs, (t, t_end), y, method="DOP853", rtol=1e-12, atol=1e-14, events=events,
                        max_step=max_step)
        assert sol.success
        t, y = sol.t[-1], sol.y[:, -1]
        if sol.status == 1:
            n_events += 1
            times.append(t)
            if side == 0:
                side = 1 if len(sol.t_events[0]) else -1
            else:
                side = 0
    return y, n_events, times


def slope(S, err):
    return -np.polyfit(np.log(S), np.log(err), 1)[0]


@pytest.mark.parametrize("clip", [pytest.param(False, marks=pytest.mark.slow), True])  # one contact law by default
def test_event_location_restores_fourth_order(clip):
    T = 2 * math.pi / OSC["w"]
    yref, n_events = reference_oscillator(PERIODS * T, clip)
    assert n_events >= 10  # many contacts with a jump of the damping force
    model = oscillator(clip)
    located = {S: simulate(model, None, [X0], [V0], periods=PERIODS, steps_per_period=S) for S in (128, 256, 512, 1024)}
    plain = {S: simulate(model, None, [X0], [V0], periods=PERIODS, steps_per_period=S, locate_events=False)
             for S in (64, 128, 256, 512, 1024, 2048)}
    e_loc = {S: np.abs(r.final_state - yref).max() for S, r in located.items()}
    e_plain = {S: np.abs(r.final_state - yref).max() for S, r in plain.items()}
    order_loc = slope(list(e_loc), list(e_loc.values()))
    order_plain = slope(list(e_plain), list(e_plain.values()))
    assert order_loc > 3.5, e_loc
    assert order_plain < 2.0, e_plain  # about first order (1.4, clipped 1.1 measured)
    assert e_loc[512] < 1e-6 and e_plain[512] > 100 * e_loc[512]
    r = located[512]
    assert r.events == n_events and r.unresolved_events == 0
    assert plain[512].events == 0


def test_a_contact_arc_shorter_than_a_step_is_located():
    """Undamped and unforced, x = V sin t touches each stop (|x| = g) by d = 1e-5 at t = pi/2 and 3 pi/2, for
    0.0126 of a step of 0.0205, in the middle of a step: both ends of the step are free, only the cubic turn
    of x - g shows the dip. Against the event-driven DOP853 reference to RK4's accuracy, 4 switches located;
    missing the arcs would leave an error 100 times larger (the free trajectory)."""
    S, d = 256, 1e-5
    p = dict(OSC, c=0.0, F=0.0, w=76.5 / 64)  # t = pi/2 and 3 pi/2 fall in the middle of steps 76 and 229
    start = (0.0, p["g"] + d)
    h = 2 * math.pi / p["w"] / S
    # the reference's steps short enough to see the arcs by sign changes (its own steps would step over them)
    yref, n_events, times = _reference(2 * math.pi / p["w"], False, p, start, max_step=1e-3)
    assert n_events == 4 and [int(t // h) for t in times] == [76, 76, 229, 229]
    model = oscillator(**{k: v for k, v in p.items() if k in ("c", "F", "w")})
    r = simulate(model, None, [start[0]], [start[1]], periods=1, steps_per_period=S)
    assert r.events == 4 and r.unresolved_events == 0
    err = np.abs(r.final_state - yref).max()
    assert err < 2e-8
    free = solve_ivp(lambda t, z: [z[1], -z[0]], (0.0, 2 * math.pi / p["w"]), start, method="DOP853", rtol=1e-12,
                     atol=1e-14).y[:, -1]
    assert np.abs(free - yref).max() > 100 * err


def test_linear_steady_state_matches_closed_form():
    # m x'' + c x' + k x = F cos(w t + phi): the simulation settles on X = F e^{i phi} / (k - m w^2 + i c w)
    p = {"m": 1.3, "c": 0.4, "k": 2.0, "F": 0.7, "w": 1.1}
    model = polynomial_model(["x"], p, mass=[["m"]], damping=[["c"]], stiffness=[["k"]],
                             forcing=[{"dof": "x", "amplitude": "F", "order": 1, "phase": 0.3}])
    X = p["F"] * np.exp(0.3j) / (p["k"] - p["m"] * p["w"] ** 2 + 1j * p["c"] * p["w"])
    r = simulate(model, None, periods=60, steps_per_period=1024, record_from=58, record_every=16)
    want_x = np.real(X * np.exp(1j * p["w"] * r.t))
    want_v = np.real(1j * p["w"] * X * np.exp(1j * p["w"] * r.t))
    np.testing.assert_allclose(r.x[:, 0], want_x, atol=1e-9)
    np.testing.assert_allclose(r.v[:, 0], want_v, atol=1e-9)
    # the section is the state at t = m T, on the step grid
    np.testing.assert_allclose(r.section[-1], [X.real, (1j * p["w"] * X).real], atol=1e-9)
    assert r.section.shape == (61, 2)
    np.testing.assert_allclose(np.diff(r.t), 16 * r.h, rtol=1e-12)
    assert r.steps == 60 * 1024 and r.periods == 60


CONTACT_MODEL = """
model:
  dofs: [x, y, z]
  parameters: {m: 1.2, c: 0.05, k: 1.0, kc: 0.3, g: 0.8, mu: 0.2, d: 0.15, eps: 0.1, F: "0.1*w**2", w: 1.3,
               gap: 0.2, kg: 50, cg: 0.4, delta: 0.3, kr: 80, cr: 0.6}
  mass: [[m, 0, 0], [0, "2*m", 0], [0, 0, m]]
  damping: [[c, 0, 0], [0, "c*(1 + 0.5*mu)", 0], [0, 0, c]]
  stiffness: [["k*(1 + 0.1*w)", -kc, 0], [-kc, "k + sqrt(kc)", 0], [0, 0, k]]
  forces:
    - {dof: x, expr: "g*x**3 + d*abs(x_dot)*x_dot + eps*cos(2*tau)*x"}
    - {dof: y, expr: "mu*(y**2 - 1)*y_dot + tanh(x - y) + 0.1*exp(0.2*x)*sin(y)"}
    - {type: gap, dof: x, clearance: gap, stiffness: kg, damping: cg, sides: both, clip: CLIPX}
    - {type: gap, dof: z, clearance: "0.5*gap", stiffness: kg, damping: cg, sides: "-", clip: CLIPZ}
    - {type: radial_gap, dofs: [y, z], clearance: delta, stiffness: kr, damping: cr, clip: CLIPR}
  excitation:
    - {dof: x, expr: "F*cos(tau) + 0.2*mu*sin(2*tau)"}
    - {dof: y, amplitude: "0.3*F", order: 1, phase: 0.4}
    - {dof: z, amplitude: mu, order: 2, phase: -0.2}
    - {dof: y, constant: "0.1*mu"}
analysis: {type: frequency_response, parameter: w, range: [0.5, 3.0], harmonics: 3, stability: none}
"""


def contact_model(clip_x, clip_z, clip_r):
    text = CONTACT_MODEL.replace("CLIPX", str(clip_x).lower()).replace("CLIPZ", str(clip_z).lower()) \
        .replace("CLIPR", str(clip_r).lower())
    return build_model(parse_scene(textwrap.dedent(text)))


@pytest.mark.parametrize("clips", [(False, False, False), (True, True, True)])
def test_compiled_rhs_equals_the_elements(clips, rng):
    model = contact_model(*clips)
    cm = compile_model(model)
    assert cm.n_switch == 2 + 2 + 1
    n = model.n_dof
    p = model.parameter_vector()
    M, C, K = model.linear(p)
    hits = set()
    for _ in range(40):
        x = rng.normal(scale=0.4, size=n)
        v = rng.normal(scale=1.0, size=n)
        tau = rng.uniform(0, 2 * np.pi)
        f = np.zeros((1, n))
        for el in model.forces:
            el.evaluate(x[None], v[None], np.array([tau]), p, f, np.zeros((1, n, n)), np.zeros((1, n, n)))
        fe = np.zeros((1, n))
        for el in model.excitations:
            el.evaluate(np.array([tau]), p, fe)
        want = np.concatenate([v, np.linalg.solve(M, fe[0] - C @ v - K @ x - f[0])])
        got = cm.rhs(np.concatenate([x, v]), tau, p)
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)
        hits.update(np.flatnonzero(cm.mode_of(np.concatenate([x, v]), p)))
    assert {0, 1, 3, 4} <= hits  # both gap sides on x, the '-' side on z and the radial contact were active
    # a frozen mode applies its law on the other side of the surface too (the extension used to locate events)
    y = np.zeros(2 * n)
    y[1], y[2] = 0.1, 0.05  # r = 0.11 < delta: free
    free = cm.rhs(y, 0.0, p)
    forced = cm.rhs(y, 0.0, p, mode=[0, 0, 0, 0, 1])
    r = math.hypot(0.1, 0.05)
    Fn = 80 * (r - 0.3)
    np.testing.assert_allclose((forced - free)[n + 1:], -Fn * np.array([0.1, 0.05]) / r / np.array([2.4, 1.2]),
                               rtol=1e-12)


@pytest.mark.slow  # located contact events: test_event_location_restores_fourth_order
def test_contact_model_runs_with_located_events():
    model = contact_model(False, True, False)
    r = {S: simulate(model, None, [0.5, -0.2, 0.1], [0.0, 1.0, -1.0], periods=2, steps_per_period=S)
         for S in (512, 1024, 4096)}
    assert r[512].events > 20 and r[512].unresolved_events == 0
    e512, e1024 = (np.abs(r[S].final_state - r[4096].final_state).max() for S in (512, 1024))
    assert e1024 < 1e-5 and e512 > 8 * e1024  # converging at about 4th order despite many contacts
    r = r[512]
    # the expression force uses abs(): its switching is not located, and the result says so
    assert any("not located" in note for note in r.notes)


@pytest.mark.slow  # expression forces against built-in ones: tests/test_custom.py
def test_expression_excitation_equals_harmonic_element():
    base = dict(OSC)
    m1 = oscillator()
    text = f"""
    model:
      dofs: [x]
      parameters: {base}
      mass: [[1]]
      damping: [[c]]
      stiffness: [[1]]
      forces: [{{type: gap, dof: x, clearance: g, stiffness: k, damping: cc}}]
      excitation: [{{dof: x, expr: "F*cos(tau) + 0*sin(3*tau)"}}]
    analysis: {{type: frequency_response, parameter: w, range: [0.5, 3.0], harmonics: 3, stability: none}}
    """
    m2 = build_model(parse_scene(textwrap.dedent(text)))
    r1 = simulate(m1, None, [X0], [V0], periods=3, steps_per_period=256)
    r2 = simulate(m2, None, [X0], [V0], periods=3, steps_per_period=256)
    np.testing.assert_allclose(r2.x, r1.x, atol=1e-12)
    assert r1.events == r2.events > 0


def test_step_too_large_for_a_stiff_contact_is_refused():
    # RK4 is unstable for h*sqrt(k) > 2.8: a stiff stop with 16 steps per period. With event location
    # the unstable contact steps would be chopped at every sign change and return a wrong answer.
    model = oscillator(k=1e5)
    with pytest.raises(SimulationError) as exc:
        simulate(model, None, [X0], [V0], periods=20, steps_per_period=16)
    msg = str(exc.value)
    assert "too large for the stiffest mode" in msg and "steps_per_period >= 592" in msg and "k=100000" in msg
    need = int(msg.split("steps_per_period >= ")[1].split()[0])
    simulate(model, None, [X0], [V0], periods=1, steps_per_period=need)  # accepted


def test_blow_up_is_reported_with_time_and_parameters():
    # x'' + x - 4 x^3 = 0 escapes to infinity in finite time from x0 = 1
    model = polynomial_model(["x"], {"a": -4.0, "w": 1.0}, mass=[[1.0]], stiffness=[[1.0]],
                             nonlinear=[{"dof": "x", "coef": "a", "x": {"x": 3}}])
    with pytest.raises(SimulationError) as exc:
        simulate(model, None, [1.0], [0.0], periods=5, steps_per_period=64)
    msg = str(exc.value)
    assert "non-finite state at t = " in msg and "a=-4" in msg and "w=1" in msg and "steps_per_period" in msg
    t = float(msg.split("t = ")[1].split()[0])
    assert 0 < t < 5 * 2 * math.pi


def test_bad_arguments():
    model = oscillator()
    with pytest.raises(ValueError, match="exactly one"):
        simulate(model, None, periods=1, t_end=3.0)
    with pytest.raises(ValueError, match="must be positive"):
        simulate(model, {"w": 0.0}, periods=1)
    with pytest.raises(ValueError, match="x0 must have 1"):
        simulate(model, None, [0.0, 1.0], periods=1)
    with pytest.raises(ValueError, match="steps_per_period"):
        simulate(model, None, periods=1, steps_per_period=2.5)

    class Strange(ForceElement):
        kind = "strange"

    model.forces.append(Strange())
    with pytest.raises(SimulationError, match="no compiled form"):
        simulate(model, None, periods=1)


def test_t_end_stop_request_and_progress():
    model = oscillator()
    r = simulate(model, None, [X0], [V0], t_end=2.0, steps_per_period=64)
    assert r.steps == math.ceil(2.0 / r.h - 1e-9) and r.t[-1] >= 2.0 - 1e-12
    calls = []
    r = simulate(model, None, [X0], [V0], periods=400, steps_per_period=64, progress=lambda d, t: calls.append(d),
                 should_stop=lambda: len(calls) >= 1)
    assert 0 < r.steps < 400 * 64 and len(calls) == 1 and r.t.size == r.x.shape[0] == r.steps + 1
    assert np.all(np.isfinite(r.x))


CACHE_CODE = """
from tests_sim_helper import oscillator
from contin.timedomain.simulation import compile_model, simulate
r = simulate(oscillator(), None, [0.3], [0.8], periods=1, steps_per_period=64)
fn = compile_model(oscillator()).module.integrate
print(len(fn.stats.cache_misses), len(fn.stats.cache_hits))
"""


def test_second_process_loads_the_compiled_integrator(tmp_path):
    helper = tmp_path / "tests_sim_helper.py"
    helper.write_text(textwrap.dedent(f"""
        from contin.model.elements import GapForce
        from contin.model.base import Monomial
        from contin.models.polynomial import polynomial_model

        def oscillator():
            params = {OSC!r}
            model = polynomial_model(["x"], params, mass=[[1.0]], damping=[["c"]], stiffness=[[1.0]],
                                     forcing=[{{"dof": "x", "amplitude": "F"}}], name="clearance_oscillator")
            names = list(model.parameters)
            model.forces.append(GapForce(0, Monomial.parse("g", names), Monomial.parse("k", names),
                                         Monomial.parse("cc", names)))
            return model
        """))

    def run():
        out = subprocess.run([sys.executable, "-c", CACHE_CODE], capture_output=True, text=True, check=True,
                             cwd=tmp_path).stdout.split()
        return int(out[0]), int(out[1])

    run()
    misses, hits = run()
    assert misses == 0 and hits >= 1


# ---------------------------------------------------------------- the `simulate` analysis
SIM_SCENE = """
model:
  dofs: [x]
  parameters: {c: 0.05, F: 0.3, w: 1.0, g: 1.0, k: 20.0, cc: 0.3}
  mass: [[1]]
  damping: [[c]]
  stiffness: [[1]]
  forces: [{type: gap, dof: x, clearance: g, stiffness: k, damping: cc}]
  excitation: [{dof: x, amplitude: F}]
analysis:
  type: simulate
  values: [0.5, 1.2]
  steps_per_period: 512
  transient: 150
  record: 20
  samples_per_period: 32
  initial: previous
output:
  plots: true
"""


def test_simulate_analysis_writes_rows_plots_and_summary(tmp_path):
    import json

    import contin.analyses.simulate  # noqa: F401  (registers the analysis and its scene schema)
    from contin.output.results import read_csv
    from contin.app.runner import run_scene

    summary = run_scene(parse_scene(SIM_SCENE), tmp_path, progress=False)
    assert summary["status"] == "complete"
    rows = read_csv(tmp_path / "simulation.csv")
    np.testing.assert_allclose(rows["w"], [0.5, 1.2])
    assert list(rows["class"]) == ["period-1", "period-1"]
    assert np.all(rows["whirl_fwd_1"] > 0) and np.all(rows["amp_x"] > 0)
    assert rows["events"][1] > 0 and rows["amp_x"][1] > 1.0  # the resonance reaches the stops
    assert summary["analysis"]["classes"] == {"period-1": 2}
    assert set(summary["plots"]) == {"simulation_0.png", "simulation_1.png", "simulation_summary.png"}
    for f in summary["plots"]:
        assert (tmp_path / f).stat().st_size > 0
    data = np.load(tmp_path / "simulation_1.npz")
    assert data["x"].shape == (20 * 32, 1) and data["section"].shape == (171, 2)
    assert json.loads((tmp_path / "summary.json").read_text())["timings"]["simulation"] > 0


@pytest.mark.parametrize("change, key", [("analysis.initial=[1, 2, 3]", "analysis.initial"),
                                         ("analysis.samples_per_period=48", "analysis.samples_per_period"),
                                         ("analysis.parameter=nope", "analysis.parameter"),
                                         ("analysis.steps_per_period=4", "analysis.steps_per_period"),
                                         ("analysis.colour=red", "analysis.colour")])
def test_simulate_analysis_bad_input_names_the_key(change, key, tmp_path):
    import contin.analyses.simulate  # noqa: F401
    from contin.app.runner import run_scene
    from contin.scene.parse import SceneError

    with pytest.raises(SceneError) as exc:
        run_scene(parse_scene(SIM_SCENE, overrides=[change]), tmp_path, progress=False)
    assert str(exc.value).startswith(key)
