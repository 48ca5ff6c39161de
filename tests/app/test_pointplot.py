"""The point figure (`contin plot OUTDIR --point N`): closed orbits, spectrum names that cover nothing,
and a contact drawn with its clearance, checked on the drawn artists against explicit values."""

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.text import Text

from contin.app.point_drawing import contact_geometry, contact_panels
from contin.app.pointplot import draw_point
from contin.output.figures import new_figure
from contin.scene.build import build_model
from contin.scene.parse import parse_scene

#: the harmonic branch of the shipped scene rotor_f0_05 over a short range, at few harmonics
ROTOR = """
model: {builtin: bearing_rotor, parameters: {f0: 0.5}}
analysis:
  type: frequency_response
  parameter: w
  range: [1.6, 1.65]
  harmonics: 8
  samples: 128
  crossings: interval
  stability: none
  continuation: {ds: 0.01, newton_tol: 1.0e-9}
"""


def _figure(n_axes: int):
    fig = new_figure((4.2 * n_axes, 4.2))
    FigureCanvasAgg(fig)  # a renderer to measure the texts with, as when the figure is saved
    return fig, fig.subplots(1, n_axes)


def _harmonic_motion(S: int = 64, T: float = 2 * np.pi):
    t = np.linspace(0.0, T, S, endpoint=False)
    x = np.column_stack([np.cos(t) + 0.3 * np.sin(2 * t), 0.5 * np.sin(t)])
    xd = np.column_stack([-np.sin(t) + 0.6 * np.cos(2 * t), 0.5 * np.cos(t)])
    return t, x, xd


def _amps(n: int, H: int, nu: int, lines: dict) -> np.ndarray:
    """Amplitudes (H + 1, n): ``lines`` {k: amplitude} on every dof, a decaying tail elsewhere."""
    k = np.arange(H + 1)
    amps = np.repeat((1e-2 * 0.8 ** k)[:, None], n, axis=1)
    for j, a in lines.items():
        amps[j] = a * (1.0 - 0.05 * np.arange(n))
    return amps


def _overlap(a, b) -> bool:
    return a.x0 < b.x1 and b.x0 < a.x1 and a.y0 < b.y1 and b.y0 < a.y1


def test_time_history_and_orbit_are_closed_at_t_equal_T():
    T = 2 * np.pi / 1.3
    t, x, xd = _harmonic_motion(T=T)
    fig, axs = _figure(3)
    draw_point(axs, t, x, xd, _amps(2, 4, 1, {1: 1.0}), 1, ["x1", "x2"])
    for line in axs[0].get_lines():
        tt, yy = line.get_data()
        assert tt[-1] == pytest.approx(T, rel=1e-12) and yy[-1] == yy[0]
    X, Y = axs[1].get_lines()[0].get_data()
    assert (X[-1], Y[-1]) == (X[0], Y[0]) and len(X) == len(t) + 1


def test_phase_portrait_of_one_dof_is_closed():
    t, x, xd = _harmonic_motion()
    fig, axs = _figure(3)
    draw_point(axs, t, x[:, :1], xd[:, :1], _amps(1, 4, 1, {1: 1.0}), 1, ["x"])
    X, V = axs[1].get_lines()[0].get_data()
    assert (X[-1], V[-1]) == (X[0], V[0]) == (x[0, 0], xd[0, 0])


@pytest.mark.parametrize("nu, H, lines", [
    (2, 160, {0: 0.5, 1: 0.6, 2: 0.7, 3: 0.07, 4: 0.015}),   # 0, w/2, w, 3w/2, 2w: 1/40 of the axis apart
    (1, 8, {0: 0.5, 1: 0.9, 2: 0.03, 3: 0.01, 4: 0.005}),
])
def test_spectrum_names_cover_no_other_name(nu, H, lines):
    t, x, xd = _harmonic_motion()
    x4, xd4 = np.hstack([x, 0.1 * x]), np.hstack([xd, 0.1 * xd])
    fig, axs = _figure(3)
    draw_point(axs, t, x4, xd4, _amps(4, H, nu, lines), nu, ["x1", "y1", "x2", "y2"])
    fig.draw_without_rendering()
    renderer = fig.canvas.get_renderer()
    spec = axs[2]
    names = [a for a in spec.texts if a.get_text()]
    boxes = [Text.get_window_extent(a, renderer) for a in names]  # the text, without its leader line
    assert len(names) >= 3  # the main lines are named, not dropped
    assert {a.get_text() for a in names} <= {"$0$", "$w/2$", "$w$", "$3w/2$", "$2w$", "$3w$", "$4w$"}
    frame = spec.get_window_extent(renderer)
    for i, a in enumerate(boxes):
        assert frame.x0 <= a.x0 and a.x1 <= frame.x1 and frame.y0 <= a.y0 and a.y1 <= frame.y1
        for b, other in zip(boxes[i + 1:], names[i + 1:]):
            assert not _overlap(a, b), (names[i].get_text(), other.get_text())
    legend = spec.get_legend().get_window_extent(renderer)
    assert not any(_overlap(a, legend) for a in boxes)


def test_rotor_bearing_drawn_with_its_clearance_circle_and_contact():
    model = build_model(parse_scene(ROTOR, "rotor.yaml"))
    p = model.parameter_vector({"delta": 0.13})
    contacts = contact_geometry(model, p)
    assert contacts == [{"type": "radial_gap", "dofs": (2, 3), "clearance": 0.13}]
    S = 90
    t = np.linspace(0.0, 2 * np.pi, S, endpoint=False)
    r = np.where(np.cos(t) > 0.5, 0.1302, 0.12)  # beyond the clearance on one arc only
    x = np.column_stack([np.cos(t), np.sin(t), r * np.cos(t), r * np.sin(t)])
    xd = np.gradient(x, t, axis=0)
    n_axes = 3 + len(contact_panels(contacts, 4))
    assert n_axes == 4  # the bearing (x2, y2) is not the disc's orbit (x1, y1): a panel of its own
    fig, axs = _figure(n_axes)
    draw_point(axs, t, x, xd, _amps(4, 6, 1, {1: 1.0}), 1, ["x1", "y1", "x2", "y2"], contacts=contacts)
    panel = axs[2]
    lines = {line.get_label(): line for line in panel.get_lines()}
    circle = np.column_stack(lines["clearance 0.13"].get_data())
    np.testing.assert_allclose(np.hypot(circle[:, 0], circle[:, 1]), 0.13, rtol=1e-12)
    assert np.ptp(np.arctan2(circle[:, 1], circle[:, 0])) > 6.2  # the whole circle
    orbit = np.column_stack(lines["orbit"].get_data())
    np.testing.assert_array_equal(orbit[-1], orbit[0])
    touch = np.column_stack(lines["in contact"].get_data())
    drawn = np.all(np.isfinite(touch), axis=1)
    np.testing.assert_array_equal(drawn[:-1], np.cos(t) > 0.5)
    assert panel.get_aspect() == 1.0 and panel.get_xlabel() == "$x_{2}$" and panel.get_ylabel() == "$y_{2}$"
    # the legend stands in a band above the curves: the y range reaches past the orbit and the circle
    assert panel.get_legend() is not None and panel.get_ylim()[1] > 0.13 * 1.3


CHAIN = """
model:
  dofs: [x1, x2]
  parameters: {k: 1, c: 0.02, g: 0.3, kc: 20, F: 0.1, w: 0.5}
  mass: [[1, 0], [0, 1]]
  damping: [["2*c", "-c"], ["-c", c]]
  stiffness: [["2*k", "-k"], ["-k", k]]
  forces:
    - {type: gap, dof: x2, clearance: g, stiffness: kc, sides: "+"}
  excitation:
    - {dof: x1, amplitude: F, order: 1}
  frequency: w
analysis: {type: frequency_response, parameter: w, range: [0.5, 2.0]}
"""


def test_stop_of_a_chain_drawn_in_its_orbit():
    model = build_model(parse_scene(CHAIN, "chain.yaml"))
    contacts = contact_geometry(model, model.parameter_vector({"g": 0.25}))
    assert contacts == [{"type": "gap", "dof": 1, "clearance": 0.25, "sides": "+"}]
    assert contact_panels(contacts, 2) == []  # x2 is the orbit's vertical axis
    t, x, xd = _harmonic_motion()
    fig, axs = _figure(3)
    draw_point(axs, t, x, xd, _amps(2, 4, 1, {1: 1.0}), 1, ["x1", "x2"], contacts=contacts)
    stop = next(line for line in axs[1].get_lines() if line.get_label().startswith("stop"))
    assert stop.get_label() == "stop at 0.25" and np.all(np.asarray(stop.get_ydata()) == 0.25)
    touch = next(line for line in axs[1].get_lines() if line.get_label() == "in contact")
    y = np.asarray(touch.get_ydata(), float)
    np.testing.assert_array_equal(np.isfinite(y)[:-1], x[:, 1] > 0.25)


def test_both_sided_stop_of_one_dof_in_its_phase_portrait():
    contacts = [{"type": "gap", "dof": 0, "clearance": 0.4, "sides": "both"}]
    t, x, xd = _harmonic_motion()
    fig, axs = _figure(3)
    draw_point(axs, t, x[:, :1], xd[:, :1], _amps(1, 4, 1, {1: 1.0}), 1, ["x"], contacts=contacts)
    stops = [line for line in axs[1].get_lines() if np.ptp(np.asarray(line.get_xdata(), float)) == 0
             and len(line.get_xdata()) == 2]
    assert sorted(float(s.get_xdata()[0]) for s in stops) == [-0.4, 0.4]
    assert "stops at \u00b10.4" in [line.get_label() for line in axs[1].get_lines()]


def test_wrong_number_of_axes_is_refused_with_the_count():
    t, x, xd = _harmonic_motion()
    contacts = [{"type": "radial_gap", "dofs": (2, 3), "clearance": 0.1}]
    fig, axs = _figure(3)
    with pytest.raises(ValueError, match="axs must hold 4 axes"):
        draw_point(axs, t, np.hstack([x, x]), np.hstack([xd, xd]), _amps(4, 4, 1, {1: 1.0}), 1,
                   ["x1", "y1", "x2", "y2"], contacts=contacts)


@pytest.mark.slow
def test_contin_plot_of_a_rotor_point_draws_the_bearing_in_its_clearance(tmp_path, monkeypatch):
    """`contin run` on a short range of the rotor at few harmonics, then `contin plot --point`."""
    import contin.app.pointplot as pointplot
    from contin.app.cli import main

    out = tmp_path / "out"
    (tmp_path / "rotor.yaml").write_text(ROTOR)
    assert main(["run", str(tmp_path / "rotor.yaml"), "-o", str(out), "-q"]) == 0
    figures = []
    save = pointplot.save_figure
    monkeypatch.setattr(pointplot, "save_figure", lambda fig, *a, **k: figures.append(fig) or save(fig, *a, **k))
    assert main(["plot", str(out), "--point", "5"]) == 0
    assert (out / "point_5.png").is_file()
    axs = figures[0].axes
    assert len(axs) == 4 and axs[2].get_title() == "radial clearance of $x_{2}$, $y_{2}$"
    lines = {line.get_label(): line for line in axs[2].get_lines()}
    circle = np.column_stack(lines["clearance 0.1"].get_data())  # the model's delta = 0.1
    np.testing.assert_allclose(np.hypot(circle[:, 0], circle[:, 1]), 0.1, rtol=1e-12)
    orbit = np.column_stack(lines["orbit"].get_data())
    np.testing.assert_array_equal(orbit[-1], orbit[0])
    # the static force holds the bearing on its casing: in contact all round, just beyond the clearance
    r = np.hypot(orbit[:, 0], orbit[:, 1])
    assert np.all(r > 0.1) and np.all(r < 0.11)
    assert np.all(np.isfinite(lines["in contact"].get_xdata()))


def test_contin_plot_of_a_shooting_row_and_of_a_torus_row(tmp_path, capsys):
    """A row of a branch followed by shooting stores its state at t = 0: `contin plot` integrates it again and
    draws the orbit its row was written from (the orbit passes through the stored state); a row of a torus is
    no periodic solution, and is refused by name."""
    import contin.app.pointplot as pointplot
    from contin.app.cli import main
    from contin.output.results import read_csv

    out = tmp_path / "out"
    (tmp_path / "rotor.yaml").write_text(ROTOR.replace("range: [1.6, 1.65]", "range: [1.6, 1.62]")
                                         + "  method: shooting\n  shooting: {steps_per_period: 2048}\n")
    assert main(["run", str(tmp_path / "rotor.yaml"), "-o", str(out), "-q"]) == 0
    assert main(["plot", str(out), "--point", "2"]) == 0
    rec = pointplot.load_state_row(out, 2)
    assert rec["branch_record"]["method"] == "shooting"
    _, scene = pointplot.read_run_scene(out)
    scene.analysis["harmonics"] = rec["branch_record"]["H"]
    c = pointplot._shooting_coefficients(scene, build_model(scene), rec["branch_record"], rec)
    x0 = c.reshape(-1, 4)[0] + c.reshape(-1, 4)[1::2].sum(axis=0)  # x(0): the mean plus the cosines
    np.testing.assert_allclose(x0, np.asarray(rec["u"])[:4], atol=1e-3)  # H = 8 of an orbit in contact
    assert read_csv(out / "branches.csv")["amp_x1"][2] > 0

    torus = tmp_path / "torus"
    (tmp_path / "t.yaml").write_text("""\
model:
  name: van_der_pol
  dofs: [x]
  parameters: {mu: 0.1, F: 0.15, w: 1}
  mass: [[1]]
  damping: [["-mu"]]
  stiffness: [[1]]
  forces: [{dof: x, expr: "mu*x**2*x_dot"}]
  excitation: [{dof: x, expr: "F*cos(tau)"}]
  frequency: w
analysis: {type: frequency_response, parameter: w, range: [0.88, 0.9], start: 0.9, solution: torus,
           start_from: simulation, start_simulation: {transient: 100}, method: shooting, torus: {points: 11}}
output: {plots: false}
""")
    assert main(["run", str(tmp_path / "t.yaml"), "-o", str(torus), "-q"]) == 0
    capsys.readouterr()
    assert main(["plot", str(torus), "--point", "1"]) == 2
    assert "row 1 is a point of the quasi-periodic branch 0, a torus" in " ".join(capsys.readouterr().err.split())
