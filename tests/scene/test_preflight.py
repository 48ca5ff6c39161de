"""Checks with the built model beyond the analyses' own (contin/scene/preflight.py): the texts figures draw,
parsed as matplotlib parses them, and ``continuation.unknown_scale`` against the problem's unknowns."""

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pytest  # noqa: E402

from contin.scene.build import build_model  # noqa: E402
from contin.scene.parse import SceneError, load_scene, parse_scene  # noqa: E402
from contin.scene.registry import check_scene  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
DUFFING = ("model: {builtin: duffing, effects: [damping, cubic, forcing]}\n"
           "analysis: {type: frequency_response, range: [0.5, 3], harmonics: 1, stability: none%s}\n")


def _check(text: str):
    scene = parse_scene(text)
    return check_scene(scene, build_model(scene))


def _draws(text: str) -> bool:
    """Whether matplotlib draws ``text`` (the truth the check must agree with)."""
    fig = plt.figure()
    try:
        fig.text(0.5, 0.5, text)
        fig.canvas.draw()
        return True
    except ValueError:
        return False
    finally:
        plt.close(fig)


BAD = [r"bad $\frac{$", r"$x^^2$", r"$\undefinedcommand$", r"$\alpha_{$"]
GOOD = [r"rotor speed $\Omega/\omega_0$", "a plain 5 $ price", r"$x_{1}$ and $\dot{y}$", "no math at all", r"\$5"]


@pytest.mark.parametrize("text", BAD + GOOD)
def test_mathtext_error_agrees_with_drawing(text):
    from contin.output.labels import mathtext_error

    assert (mathtext_error(text) is None) == _draws(text)


@pytest.mark.parametrize("output, key", [
    (r"{labels: {w: 'bad $\frac{$'}}", "output.labels.w"),
    (r"{title: 'response $x^^2$'}", "output.title"),
    (r"{units: {w: '$\undefinedcommand$'}}", "output.units.w"),
])
def test_output_texts_that_cannot_be_drawn_are_refused_at_check_time(output, key):
    with pytest.raises(SceneError, match="matplotlib says") as exc:
        _check(DUFFING % "" + f"output: {output}\n")
    assert exc.value.key == key


def test_a_custom_models_symbols_and_name_are_checked():
    scene = ("model:\n  name: 'oscillator $\\frac{$'\n  dofs: [x]\n  parameters: {k: 1, F: 0.1, w: 1}\n"
             "  mass: [[1]]\n  stiffness: [[k]]\n  excitation: [{dof: x, expr: 'F*cos(tau)'}]\n%s"
             "analysis: {type: frequency_response, range: [0.5, 2], harmonics: 1, stability: none}\n")
    with pytest.raises(SceneError) as exc:
        _check(scene % "  symbols: {k: '\\kappa_{'}\n")
    assert exc.value.key == "model.symbols.k"
    with pytest.raises(SceneError) as exc:
        _check(scene % "")
    assert exc.value.key == "model.name"


def test_the_shipped_labels_pass():
    for name in ("rotor_fe_rig.yaml", "two_dof_frf.yaml", "belt_forced_on.yaml", "duffing_fold_curve.yaml"):
        scene = load_scene(ROOT / "scenes" / name)
        check_scene(scene, build_model(scene))


@pytest.mark.parametrize("extra, key, match", [
    (", continuation: {unknown_scale: [1, 1]}", "analysis.continuation.unknown_scale",
     r"a list of 3 \(one per unknown: 1 dof x 3 coefficients\), found 'a list of 2 numbers'"),
    (", starts: [{start: 1.0, continuation: {unknown_scale: [1, 1, 1, 1]}}]",
     "analysis.starts[0].continuation.unknown_scale", "a list of 3"),
    (", switch: [pd], stability: floquet, continuation: {unknown_scale: [1, 1, 1]}",
     "analysis.continuation.unknown_scale", r"a single positive number \(the branches analysis.switch: \[pd\]"),
])
def test_unknown_scale_of_the_wrong_length_is_refused(extra, key, match):
    text = DUFFING % extra
    if "stability: floquet" in extra:
        text = text.replace("stability: none, ", "")
    with pytest.raises(SceneError, match=match) as exc:
        _check(text)
    assert exc.value.key == key


def test_unknown_scale_of_the_right_length_or_a_number_passes():
    _check(DUFFING % ", continuation: {unknown_scale: [1, 2, 3]}")
    _check(DUFFING % ", continuation: {unknown_scale: 2.0}")


@pytest.mark.parametrize("scene, setting, key, length", [
    ("belt_static.yaml", "analysis.continuation", "analysis.continuation.unknown_scale", 5),
    ("belt_backbone.yaml", "analysis.continuation", "analysis.continuation.unknown_scale", 57),
    ("duffing_fold_curve.yaml", "analysis.curve_continuation", "analysis.curve_continuation.unknown_scale", 4),
])
def test_unknown_scale_of_the_other_continuations(scene, setting, key, length):
    path = ROOT / "scenes" / scene
    ok = load_scene(path, [f"{setting}.unknown_scale=[{', '.join(['1'] * length)}]"])
    check_scene(ok, build_model(ok))
    bad = load_scene(path, [f"{setting}.unknown_scale=[1, 1]"])
    with pytest.raises(SceneError, match=f"a list of {length} ") as exc:
        check_scene(bad, build_model(bad))
    assert exc.value.key == key
