"""Tests of contin.engine.options: validation, configuration mappings, copies."""

import dataclasses

import pytest

from contin.engine.options import ContinuationOptions, Scaling, as_options


def test_options_validation_names_the_field():
    with pytest.raises(ValueError, match="ds_min"):
        ContinuationOptions(ds_min=-1)
    with pytest.raises(ValueError, match="ContinuationOptions.shrink"):
        ContinuationOptions(shrink=1.5)
    with pytest.raises(ValueError, match="direction"):
        ContinuationOptions(direction=0)
    with pytest.raises(ValueError, match="max_points"):
        ContinuationOptions(max_points=2.5)
    with pytest.raises(ValueError, match="scaling"):
        ContinuationOptions(scaling="sometimes")
    with pytest.raises(ValueError, match="unknown_scale"):
        ContinuationOptions(unknown_scale=[1.0, -1.0])
    with pytest.raises(ValueError, match="ds_max"):
        ContinuationOptions(ds=0.5)


def test_options_from_dict_and_replace():
    with pytest.raises(ValueError, match="ds_max") as info:
        ContinuationOptions.from_dict({"ds_mx": 0.1})
    assert "ds_mx" in str(info.value)
    opts = ContinuationOptions.from_dict({"ds": 0.01, "scaling": "none", "unknown_scale": [1.0, 2.0]})
    assert opts.scaling is Scaling.NONE
    assert opts.unknown_scale == (1.0, 2.0)
    assert dataclasses.replace(opts, ds=0.05).ds == 0.05
    assert opts.replace(max_points=7).max_points == 7
    with pytest.raises(ValueError, match="newton_tol"):
        opts.replace(newton_tl=1e-8)
    with pytest.raises(ValueError, match="ds_min"):
        dataclasses.replace(opts, ds_min=1.0)
    assert ContinuationOptions.from_dict(opts.to_dict()) == opts


def test_values_are_normalised_to_plain_types():
    opts = ContinuationOptions(ds=1, ds_max=2, max_points=10, scaling="AUTO", parameter_scale=3, unknown_scale=2)
    assert type(opts.ds) is float and type(opts.ds_max) is float and type(opts.parameter_scale) is float
    assert type(opts.max_points) is int and opts.scaling is Scaling.AUTO and opts.unknown_scale == 2.0
    assert opts.to_dict()["scaling"] == "auto" and str(Scaling.NONE) == "none"
    assert opts.field_names()[:3] == ["ds", "ds_min", "ds_max"]


def test_as_options():
    assert as_options(None) == ContinuationOptions()
    opts = ContinuationOptions(ds=0.01)
    assert as_options(opts) is opts
    assert as_options({"ds": 0.01}) == opts
    with pytest.raises(TypeError, match="options must be ContinuationOptions or a mapping, got int"):
        as_options(3)
    with pytest.raises(ValueError, match="did you mean 'ds_max'"):
        as_options({"ds_mx": 0.1})


def test_max_points_unset_is_the_default_cap_and_set_is_the_callers():
    """Unset, ``max_points`` is None (a cap nobody asked for, 2000 points); set, it is the caller's."""
    from contin.engine.options import DEFAULT_MAX_POINTS

    opts = ContinuationOptions()
    assert opts.max_points is None and opts.point_cap == DEFAULT_MAX_POINTS == 2000
    assert ContinuationOptions(max_points=7).point_cap == 7
    assert ContinuationOptions.from_dict(opts.to_dict()) == opts  # None survives a configuration round trip
    for bad in (0, -3, 2.5, True, "100"):
        with pytest.raises(ValueError, match=r"ContinuationOptions.max_points must be None or an integer >= 1"):
            ContinuationOptions(max_points=bad)
