"""Tests of contin.util.options (from_mapping): every option class reads a mapping one way."""

import dataclasses
import enum
import types

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from contin.bifurcation.torus_branch import TorusSettings
from contin.bifurcation.two_parameter import CurveOptions
from contin.engine.options import ContinuationOptions
from contin.hb.problem import HBOptions
from contin.stability.options import StabilityOptions
from contin.timedomain.shooting import ShootingOptions
from contin.util.options import check_keys, field_names, from_mapping


class Colour(str, enum.Enum):
    RED = "red"
    BLUE = "blue"


@dataclasses.dataclass(frozen=True)
class Inner:
    size: int = 1

    def __post_init__(self):
        if not isinstance(self.size, int) or self.size < 1:
            raise ValueError(f"Inner.size must be an integer >= 1, got {self.size!r}")


@dataclasses.dataclass(frozen=True)
class Outer:
    width: float = 1.0
    tags: tuple = ()
    colour: Colour = Colour.RED
    inner: Inner | None = None
    derived: int = dataclasses.field(default=0, init=False)

    def __post_init__(self):
        if not self.width > 0:
            raise ValueError(f"Outer.width must be > 0, got {self.width!r}")


CONVERT = {"tags": tuple, "colour": Colour, "inner": lambda m: from_mapping(Inner, m)}


def test_fields_are_converted_as_declared_and_then_validated_by_the_class():
    o = from_mapping(Outer, {"width": 2.0, "tags": ["a", "b"], "colour": "blue", "inner": {"size": 3}},
                     converters=CONVERT)
    assert o == Outer(2.0, ("a", "b"), Colour.BLUE, Inner(3))
    assert from_mapping(Outer, {}, converters=CONVERT) == Outer()
    assert from_mapping(Outer, {"inner": None}, converters=CONVERT).inner is None  # None: unset, not converted
    assert from_mapping(Outer, types.MappingProxyType({"width": 3.0})).width == 3.0  # any mapping
    with pytest.raises(ValueError, match=r"Outer.width must be > 0, got -1"):
        from_mapping(Outer, {"width": -1}, converters=CONVERT)


@pytest.mark.parametrize("d, match", [
    ({"colour": "green"}, r"^Outer.colour: 'green' is not a valid Colour$"),
    ({"inner": {"size": 0}}, r"^Outer.inner: Inner.size must be an integer >= 1, got 0$"),
    ({"inner": {"sise": 2}}, r"^Outer.inner: unknown option 'sise' of Inner \(did you mean 'size'\?\)"),
    ({"inner": [1]}, r"^Outer.inner: Inner.from_dict: expected a mapping of option names to values, got list$"),
])
def test_a_value_a_converter_refuses_is_named_by_its_field(d, match):
    with pytest.raises(ValueError, match=match):
        from_mapping(Outer, d, converters=CONVERT)


def test_unknown_keys_and_fields_not_in_the_constructor_are_refused_naming_the_nearest():
    with pytest.raises(ValueError, match=r"^unknown option 'widht' of Outer \(did you mean 'width'\?\); "
                                         r"expected one of \['width', 'tags', 'colour', 'inner'\]$"):
        from_mapping(Outer, {"width": 1.0, "widht": 2.0})
    with pytest.raises(ValueError, match="unknown option 'derived' of Outer"):
        from_mapping(Outer, {"derived": 1})
    with pytest.raises(ValueError, match=r"unknown option 3 of Outer; expected one of"):
        from_mapping(Outer, {3: 1})
    with pytest.raises(ValueError, match=r"unknown option 'w' of Outer; expected one of \['a', 'b'\]"):
        check_keys(Outer, ["a", "w"], valid=["a", "b"])


@pytest.mark.parametrize("d", [None, "width", [("width", 1.0)], 3])
def test_a_value_that_is_not_a_mapping_is_refused_naming_the_class(d):
    with pytest.raises(TypeError, match=r"^Outer.from_dict: expected a mapping of option names to values, got "):
        from_mapping(Outer, d)


def test_only_dataclasses_are_option_classes():
    with pytest.raises(TypeError, match="an option class must be a dataclass, got <class 'dict'>"):
        from_mapping(dict, {})
    assert field_names(Outer) == ["width", "tags", "colour", "inner"]


# --------------------------------------------------------------------------
# the option classes of contin
# --------------------------------------------------------------------------
OPTION_CLASSES = {
    ContinuationOptions: ContinuationOptions.from_dict,
    StabilityOptions: StabilityOptions.from_dict,
    HBOptions: HBOptions.from_dict,
    ShootingOptions: ShootingOptions.from_dict,
    CurveOptions: CurveOptions.from_dict,
    TorusSettings: lambda d: TorusSettings.from_dict(d, 5),
}


@pytest.mark.parametrize("cls", OPTION_CLASSES, ids=lambda c: c.__name__)
@settings(max_examples=25, deadline=None)
@given(key=st.one_of(st.text(max_size=12), st.integers()))
def test_every_option_class_names_an_unknown_key_its_class_and_the_valid_ones(cls, key):
    read = OPTION_CLASSES[cls]
    valid = [f.name for f in dataclasses.fields(cls) if f.name != "options"]
    if key in valid or key in ("harmonics", "harmonics2", "samples", "samples2"):
        return
    with pytest.raises(ValueError, match=f"unknown option .* of {cls.__name__}.*; expected one of") as info:
        read({key: 1})
    assert repr(key) in str(info.value)


@pytest.mark.parametrize("cls, key, nearest", [
    (ContinuationOptions, "ds_mx", "ds_max"),
    (StabilityOptions, "Method", "method"),
    (HBOptions, "harmonic", "harmonics"),
    (ShootingOptions, "step_per_period", "steps_per_period"),
    (CurveOptions, "detekt", "detect"),
    (TorusSettings, "harmonic2", "harmonics2"),
    (TorusSettings, "period", "periods"),
], ids=lambda v: v if isinstance(v, str) else v.__name__)
def test_every_option_class_suggests_the_nearest_key(cls, key, nearest):
    with pytest.raises(ValueError, match=f"unknown option '{key}' of {cls.__name__} \\(did you mean '{nearest}'\\?\\)"):
        OPTION_CLASSES[cls]({key: 1})


@pytest.mark.parametrize("cls", OPTION_CLASSES, ids=lambda c: c.__name__)
@pytest.mark.parametrize("d", ["ds", [("a", 1)]])
def test_every_option_class_refuses_a_value_that_is_not_a_mapping(cls, d):
    with pytest.raises(TypeError, match=f"{cls.__name__}.from_dict: expected a mapping of option names to values"):
        OPTION_CLASSES[cls](d)


def test_torus_settings_read_their_grid_from_the_mapping_itself():
    t = TorusSettings.from_dict({"harmonics2": 4, "samples": None, "periods": 50.0, "locking_tol": None}, 7)
    assert (t.options.harmonics, t.options.harmonics2, t.options.samples) == (7, 4, None)
    assert t.periods == 50.0 and t.locking_tol == TorusSettings().locking_tol  # None keeps the default
    assert TorusSettings.from_dict(None, 3).options.harmonics == 3
    with pytest.raises(ValueError, match=r"^TorusSettings.options: TorusOptions.harmonics2 must be an integer >= 1"):
        TorusSettings.from_dict({"harmonics2": -1}, 5)
    with pytest.raises(ValueError, match="unknown option 'options' of TorusSettings"):
        TorusSettings.from_dict({"options": {"harmonics": 3}}, 5)  # the grid's keys sit in the mapping itself


def test_a_round_trip_through_to_dict_gives_the_same_options():
    for opts in (ContinuationOptions(ds=0.01, scaling="none", unknown_scale=[1.0, 2.0]),
                 StabilityOptions(method="hill", tolerance=1e-8)):
        assert type(opts).from_dict(opts.to_dict()) == opts
    assert CurveOptions.from_dict({"detect": ["cusp"]}).detect == ("cusp",)
    assert HBOptions.from_dict({"harmonics": 3, "samples": 9}) == HBOptions(harmonics=3, samples=9)
    assert ShootingOptions.from_dict({"subharmonic": 2}).subharmonic == 2
