"""The excitation frequency of a finite-element rotor's scene is the builder's speed parameter, named once."""

from pathlib import Path

from contin.model.fem import builder
from contin.scene.build import build_model
from contin.scene.parse import load_scene, model_frequency

SCENE = Path(__file__).resolve().parents[2] / "scenes" / "rotor_fe_rig.yaml"


def test_the_speed_is_w_as_the_builder_documents():
    # the module docstring's table and docs/howto/fe-rotors.md: ``w`` is the speed Omega / w0
    assert builder.SPEED == "w" and "SPEED" in builder.__all__
    assert model_frequency({"from": "ross", "file": "rig.npz"}) == "w"
    assert model_frequency({"from": "ross", "file": "rig.npz"}, {"frequency": "kbn"}) == "kbn"  # the analysis's own


def test_the_built_rotor_declares_the_speed_as_its_frequency():
    scene = load_scene(SCENE)
    model = build_model(scene)
    assert model.frequency == builder.SPEED == model_frequency(scene.model, scene.analysis)
    assert builder.SPEED in model.parameters and model.symbols[builder.SPEED] == r"\Omega"


def test_model_frequency_reads_the_builders_name(monkeypatch):
    # renamed in the builder, the scene's frequency follows: nothing else hard-codes it
    monkeypatch.setattr(builder, "SPEED", "Omega")
    assert model_frequency({"from": "ross", "file": "rig.npz"}) == "Omega"
