"""Schema primitives for scene sections: one :class:`Key` per allowed key.

Every analysis declares the keys of its ``analysis`` section with these
helpers; :func:`check_section` reports the first violation as a
:class:`SceneError` naming the dotted key, the expected form and the finding.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass
from typing import Any, Callable

from contin.util.naming import is_finite_real, suggest

__all__ = ["START_SIMULATION", "SceneError", "Key", "number", "integer", "string", "mapping", "listing", "anything",
           "flag", "int_range", "is_number", "is_int", "number_or_expr", "check_section", "NUMBER", "STR"]


class SceneError(ValueError):
    """Bad input in a scene, with the key path, expectation and finding."""

    def __init__(self, key: str, expected: str, found: Any = None, line: int | None = None, hint: str = ""):
        self.key, self.expected, self.found, self.line = key, expected, found, line
        # a str cites where the value came from instead of a line (a --set, contin.scene.parse.cite_override)
        where = f" ({line})" if isinstance(line, str) else f" (line {line})" if line else ""
        found_txt = "" if found is None else f", found {found!r}"
        super().__init__(f"{key}{where}: expected {expected}{found_txt}{hint}")


# ---------------------------------------------------------------- checkers
def is_number(v) -> bool:
    """A finite int or float (YAML gives no other numbers)."""
    return isinstance(v, (int, float)) and is_finite_real(v)


def is_int(v) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)


@dataclass(frozen=True)
class Key:
    """Schema of one key: a check, a description of the expected form, a default."""

    expected: str
    check: Callable[[Any], bool] = lambda v: True
    default: Any = None
    required: bool = False


NUMBER = "a finite number"
STR = "a string"


def number(default=None, required=False, positive=False, min_value=None):
    def check(v):
        if not is_number(v):
            return False
        if positive and v <= 0:
            return False
        return min_value is None or v >= min_value

    exp = "a positive number" if positive else NUMBER if min_value is None else f"a number >= {min_value}"
    return Key(exp, check, default, required)


def integer(default=None, minimum=None, required=False):
    exp = "an integer" if minimum is None else f"an integer >= {minimum}"
    return Key(exp, lambda v: is_int(v) and (minimum is None or v >= minimum), default, required)


def string(default=None, choices=None, required=False):
    if choices:
        return Key("one of " + ", ".join(repr(c) for c in choices), lambda v: v in choices, default, required)
    return Key(STR, lambda v: isinstance(v, str) and v != "", default, required)


def mapping(default=None):
    return Key("a mapping (key: value)", lambda v: isinstance(v, dict), {} if default is None else default)


def listing(default=None, item=None, expected="a list"):
    return Key(expected, lambda v: isinstance(v, list) and (item is None or all(item(x) for x in v)),
               [] if default is None else default)


def anything(default=None):
    return Key("any value", lambda v: True, default)


def number_or_expr(v) -> bool:
    return is_number(v) or (isinstance(v, str) and v.strip() != "")


def flag(default=False):
    return Key("true or false", lambda v: isinstance(v, bool), default)


def int_range(default, lo, hi, what="an integer"):
    return Key(f"{what} from {lo} to {hi}", lambda v: is_int(v) and lo <= v <= hi, default)


def check_section(section: dict, schema: dict, prefix: str, lines: dict) -> dict:
    out = {}
    for k in section:
        if k not in schema:
            path = f"{prefix}.{k}"
            raise SceneError(path, "one of the keys " + ", ".join(schema), None, lines.get(path),
                             hint=f"; unknown key '{k}'{suggest(k, schema)}")
    for k, spec in schema.items():
        path = f"{prefix}.{k}"
        if k not in section or (section[k] is None and not spec.required):
            if spec.required:
                raise SceneError(path, spec.expected + " (required)", None, lines.get(prefix))
            out[k] = copy.deepcopy(spec.default)
            continue
        v = section[k]
        if not spec.check(v):
            raise SceneError(path, spec.expected, v, lines.get(path))
        out[k] = v
    return out


def _start_simulation_ok(v) -> bool:
    if not isinstance(v, dict) or set(v) - {"transient", "steps_per_period", "run_up"}:
        return False
    t, s, r = v.get("transient"), v.get("steps_per_period"), v.get("run_up")
    return ((t is None or (is_number(t) and t > 0)) and (s is None or (is_int(s) and 4 <= s <= 2**20))
            and (r is None or (isinstance(r, list) and len(r) <= 100 and all(is_number(x) and x > 0 for x in r))))


#: ``start_simulation``: how :func:`contin.bifurcation.start.simulation_start` integrates to its start (the
#: analyses that start from a simulation share the key)
START_SIMULATION = Key("a mapping with keys among transient (revolutions, a number > 0), steps_per_period "
                       "(an integer from 4 to 2**20) and run_up (a list of at most 100 positive parameter values "
                       "integrated first, in turn)", _start_simulation_ok, {})
