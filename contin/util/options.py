"""One way to read an option class from a mapping: :func:`from_mapping`.

Every option class of contin is a frozen dataclass that validates its values
in its own ``__post_init__``. Reading one from a configuration mapping (a
scene's section, a saved ``to_dict``) is the same for all of them:

1. refuse a key that is not a field, naming the key, the class and the
   nearest field (:func:`check_keys`);
2. convert the values a mapping cannot hold as the class wants them (a nested
   option object from a mapping, an array from a list), as the class declares
   once in ``converters``;
3. construct, so that the class's own checks judge the values.

Each option class's ``from_dict`` is this function applied to itself.
"""

from __future__ import annotations

import dataclasses
import os
from typing import Any, Callable, Iterable, Mapping

from contin.util.naming import suggest

__all__ = ["check_keys", "environment_count", "field_names", "from_mapping"]


def field_names(cls) -> list[str]:
    """The fields of the dataclass ``cls``, in declaration order."""
    if not (isinstance(cls, type) and dataclasses.is_dataclass(cls)):
        raise TypeError(f"an option class must be a dataclass, got {cls!r}")
    return [f.name for f in dataclasses.fields(cls) if f.init]


def check_keys(cls, keys: Iterable, valid: Iterable[str] | None = None) -> None:
    """Raise ``ValueError`` for the first of ``keys`` that is not among ``valid`` (default: the fields of ``cls``).

    The message names the key, the class, the nearest valid key (if one is
    close) and all of them.
    """
    names = field_names(cls) if valid is None else list(valid)
    for key in keys:
        if key not in names:
            raise ValueError(f"unknown option {key!r} of {cls.__name__}{suggest(str(key), names)}; "
                             f"expected one of {names}")


def from_mapping(cls, d: Mapping[str, Any], *, converters: Mapping[str, Callable[[Any], Any]] | None = None):
    """An instance of the dataclass ``cls`` built from the mapping ``d`` of option names to values.

    Parameters
    ----------
    cls : type
        A dataclass (an option class, validated by its ``__post_init__``).
    d : Mapping
        Option names to values; names absent keep their defaults.
    converters : mapping of str to callable, optional
        ``{field: convert}``: ``convert(value)`` gives what the field holds
        for a value read from a mapping (e.g. a nested option object from its
        own mapping). A None value is passed on as it is (it means "unset" to
        the optional fields, and the class's checks say what a required one
        needs).

    Raises
    ------
    TypeError
        ``d`` is not a mapping.
    ValueError
        An unknown key (named with the class and the nearest field), a value
        a converter refuses (named ``Class.field``), or one the class's own
        checks refuse.
    """
    if not isinstance(d, Mapping):
        raise TypeError(f"{cls.__name__}.from_dict: expected a mapping of option names to values, "
                        f"got {type(d).__name__}")
    check_keys(cls, d)
    values = dict(d)
    for name, convert in (converters or {}).items():
        v = values.get(name)
        if v is None:
            continue
        try:
            values[name] = convert(v)
        except (TypeError, ValueError) as exc:
            # the field's name first: a nested object's message alone would not say where it came from
            raise ValueError(f"{cls.__name__}.{name}: {exc}") from None
    return cls(**values)


def environment_count(name: str, default: int) -> int:
    """The positive integer in the environment variable ``name``, ``default`` where it is unset or empty.

    Raises
    ------
    ValueError
        If it is set to anything else (naming it and the value).
    """
    text = os.environ.get(name, "").strip()
    if not text:
        return default
    try:
        n = int(text)
    except ValueError:
        n = 0
    if n < 1:
        raise ValueError(f"{name} must be a positive integer, got {text!r}")
    return n
