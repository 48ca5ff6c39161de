"""The figures of ``simulate`` (and ``contin plot --point``): spectra cut at a floor, lines named as multiples of w."""

import numpy as np
import pytest
from matplotlib.figure import Figure

from contin.analyses.simulate import SPECTRUM_FLOOR, draw_spectrum, frequency_text


@pytest.mark.parametrize("f, text", [(1.0, "$w$"), (0.5, "$w/2$"), (-0.5, "$-w/2$"), (1.5, "$3w/2$"),
                                     (2.0, "$2w$"), (1 / 3, "$w/3$"), (0.0, "$0$"), (0.5904, r"$0.59\,w$")])
def test_frequency_text_names_a_line_as_a_multiple_of_w(f, text):
    assert frequency_text(f) == text


def test_frequency_text_uses_the_models_symbol():
    assert frequency_text(-1.0, r"\Omega") == r"$-\Omega$"


def test_a_spectrum_is_cut_at_its_floor_and_its_main_lines_are_named():
    f = np.linspace(0.0, 3.0, 301)
    amp = np.full(f.size, 1e-17)  # rounding: never drawn
    amp[100], amp[50], amp[150] = 1.0, 0.3, 1e-3  # w, w/2, 3w/2
    ax = Figure().add_subplot()
    draw_spectrum(ax, f, amp)
    lo, hi = ax.get_ylim()
    assert ax.get_yscale() == "log" and lo == pytest.approx(SPECTRUM_FLOOR) and hi > 1.0
    assert np.min(ax.lines[0].get_ydata()) >= SPECTRUM_FLOOR
    assert sorted(t.get_text() for t in ax.texts) == ["$3w/2$", "$w$", "$w/2$"]
    # stems (harmonic amplitudes): the lines below the floor are left out
    ax = Figure().add_subplot()
    draw_spectrum(ax, [0.0, 1.0, 2.0, 3.0], [0.0, 1.0, 1e-18, 0.01], stems=True, annotate=False)
    assert len(ax.lines[0].get_xdata()) == 2 and not ax.texts
