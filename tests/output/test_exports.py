"""Data exports: stability codes, coefficient names, refused formats (the exports of the example runs are
checked with their other invariants in tests/hard/test_invariants.py)."""

import numpy as np
import pytest

from contin.output.exports import coefficient_names, stability_code, write_exports


def test_stability_codes_and_coefficient_names():
    np.testing.assert_array_equal(stability_code(np.array([True, False])), [1, 0])
    np.testing.assert_array_equal(stability_code(np.array([1.0, np.nan, 0.0])), [1, -1, 0])
    np.testing.assert_array_equal(stability_code(np.array(["true", "", "false"], dtype=object)), [1, -1, 0])
    assert coefficient_names(["x", "y"], 1) == ["a0_x", "a0_y", "a1_x", "a1_y", "b1_x", "b1_y"]


def test_unknown_export_format_is_refused(tmp_path):
    with pytest.raises(ValueError, match="unknown export format 'xls'"):
        write_exports(tmp_path, ["xls"], {"status": "complete"})
