"""Small checks shared by every layer: "did you mean" hints and real-number tests."""

from __future__ import annotations

import difflib
import math
import numbers
from typing import Iterable

import numpy as np

__all__ = ["suggest", "is_real", "is_finite_real"]


def suggest(name, options: Iterable) -> str:
    """A ``" (did you mean 'x'?)"`` hint for a misspelt ``name``, or an empty string.

    A name that differs from an option only in case is suggested first (difflib
    misses one-letter names such as ``'W'`` for ``'w'``).
    """
    options = list(options)
    if isinstance(name, str):
        same = [o for o in options if isinstance(o, str) and o.lower() == name.lower() and o != name]
        if same:
            return f" (did you mean '{same[0]}'?)"
    close = difflib.get_close_matches(str(name), [str(o) for o in options], n=1)
    return f" (did you mean '{close[0]}'?)" if close else ""


def is_real(v) -> bool:
    """A real number (Python or numpy), booleans excluded."""
    return isinstance(v, numbers.Real) and not isinstance(v, (bool, np.bool_))


def is_finite_real(v) -> bool:
    """A finite real number (an integer beyond the float range is not)."""
    if not is_real(v):
        return False
    try:
        return math.isfinite(v)
    except OverflowError:
        return False
