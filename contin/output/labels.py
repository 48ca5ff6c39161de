"""Axis labels from names: symbols for parameters and dofs, words for measures, units in brackets.

A label is chosen, first found first, from the scene's ``output.labels``, then
from the symbols a model declares (``Model.symbols``: name -> mathtext without
dollars, for example ``{"w": r"\\Omega"}``), then from the name itself: a Greek
letter's name becomes the letter, ``x1`` becomes :math:`x_1`, ``x_dot`` becomes
:math:`\\dot x`, and a measure column (``amp_x``, ``rms_x``, ``h1_x``,
``max_multiplier``, ...) becomes words around its dof's symbol. Raw column
names never reach an axis.

Two refinements of ``symbols``: a value holding ``$`` is a phrase, used as it
stands (``{"w": r"$w$ at $\\xi = 0.6$"}`` gives "RMS of :math:`w` at
:math:`\\xi = 0.6`" for ``rms_w``, and a model's own column can be named in
words the same way); a key ``parameter:NAME`` names the parameter ``NAME``
where a dof or observable has the same name (the belt's frequency ``w``
beside its displacement ``w``), looked up for the ``parameter`` role.
"""

from __future__ import annotations

import re
from typing import Mapping

__all__ = ["symbol", "math", "quantity", "axis_label", "model_symbols", "mathtext_error"]

_GREEK = {"alpha", "beta", "gamma", "delta", "epsilon", "zeta", "eta", "theta", "iota", "kappa", "lambda",
          "mu", "nu", "xi", "pi", "rho", "sigma", "tau", "upsilon", "phi", "chi", "psi", "omega",
          "Gamma", "Delta", "Theta", "Lambda", "Xi", "Pi", "Sigma", "Phi", "Psi", "Omega"}
_SHORT_GREEK = {"eps": "varepsilon", "lam": "lambda", "om": "omega"}

#: measure prefixes of branches.csv (SPEC 4.3) and the words that name them
_MEASURES = (("amp_", "amplitude of {}"), ("max_", "maximum of {}"), ("min_", "minimum of {}"),
             ("rms_", "RMS of {}"), ("mean_", "mean of {}"))
_FIXED = {"max_multiplier": r"largest multiplier $|\mu|_{\max}$", "n_unstable": "multipliers outside the unit circle",
          "frequency": r"response frequency $\omega$", "newton_iterations": "Newton iterations",
          "residual_norm": "residual norm", "period": "period $T$", "lowest_eigenvalue": r"lowest $\omega^2$"}
#: a model's own columns named with the measure last (the belt's ``w_rms``)
_SUFFIX_MEASURES = (("_rms", "RMS of {}"), ("_amp", "amplitude of {}"))


def _declared(name: str, symbols: Mapping[str, str] | None, role: str | None) -> str | None:
    """The symbol (or phrase) ``symbols`` declares for ``name`` in ``role``, else None."""
    if not symbols:
        return None
    if role and f"{role}:{name}" in symbols:
        return symbols[f"{role}:{name}"]
    return symbols.get(name)


def symbol(name: str, symbols: Mapping[str, str] | None = None, role: str | None = None) -> str:
    """Mathtext (without dollars) for a parameter or dof ``name``: ``eps`` -> ``\\varepsilon``,
    ``x1`` -> ``x_{1}``, ``x_dot`` -> ``\\dot{x}``, ``p_d`` -> ``p_{d}``, a declared symbol as declared.

    ``role`` (``"parameter"``) also finds a key ``parameter:NAME`` of ``symbols``.
    A declared phrase (a value holding ``$``) is no symbol: its name is spelled by the rules.
    """
    declared = _declared(name, symbols, role)
    if declared is not None and "$" not in declared:
        return declared
    if name.endswith("_dot") and len(name) > 4:
        return r"\dot{" + symbol(name[:-4], symbols, role) + "}"
    if name in _GREEK:
        return "\\" + name
    if name in _SHORT_GREEK:
        return "\\" + _SHORT_GREEK[name]
    m = re.fullmatch(r"([A-Za-z]+?)_?(\d+)", name)
    if m and (len(m.group(1)) <= 3 or m.group(1) in _GREEK):  # x1, k12, xi2, gamma0: a letter with an index
        return symbol(m.group(1), symbols) + "_{" + m.group(2) + "}"
    head, sep, tail = name.partition("_")
    if sep and head and tail and "_" not in tail and len(tail) <= 4:  # p_d, x_obs: a subscript
        return symbol(head, symbols) + r"_{\mathrm{" + tail + "}}" if len(tail) > 1 else \
            symbol(head, symbols) + "_{" + tail + "}"
    if len(name) == 1:
        return name
    return r"\mathrm{" + name.replace("_", r"\_") + "}"


def math(name: str, symbols: Mapping[str, str] | None = None, role: str | None = None) -> str:
    """``symbol`` between dollars, ready for a matplotlib text; a declared phrase as it stands."""
    declared = _declared(name, symbols, role)
    if declared is not None and "$" in declared:
        return declared
    return f"${symbol(name, symbols, role)}$"


def quantity(name: str, symbols: Mapping[str, str] | None = None, role: str | None = None) -> str:
    """Words and symbols for a parameter, dof or measure column (no unit).

    ``role`` is ``"parameter"`` when ``name`` is a parameter (see :func:`symbol`).
    """
    declared = _declared(name, symbols, role)
    if declared is not None:
        return declared if "$" in declared else f"${declared}$"
    if name in _FIXED:
        return _FIXED[name]
    if role != "parameter":
        for prefix, words in _MEASURES:
            if name.startswith(prefix) and len(name) > len(prefix):
                return words.format(math(name[len(prefix):], symbols))
        m = re.fullmatch(r"h(\d+)_(.+)", name)
        if m:
            k = int(m.group(1))
            return f"mean of {math(m.group(2), symbols)}" if k == 0 else \
                f"harmonic {k} of {math(m.group(2), symbols)}"
        for suffix, words in _SUFFIX_MEASURES:  # a model's own column: w_rms
            if name.endswith(suffix) and len(name) > len(suffix):
                return words.format(math(name[:-len(suffix)], symbols))
    return math(name, symbols, role)


def axis_label(name: str, units: Mapping[str, str] | None = None, labels: Mapping[str, str] | None = None,
               symbols: Mapping[str, str] | None = None, role: str | None = None) -> str:
    """``label [unit]`` for a parameter or measure: ``output.labels``, else :func:`quantity`; ``output.units``."""
    text = (labels or {}).get(name) or quantity(name, symbols, role)
    unit = (units or {}).get(name)
    return f"{text} [{unit}]" if unit else text


def model_symbols(model) -> dict:
    """The symbols a figure of ``model`` uses: the model's own (``Model.symbols``), and
    :math:`\\Omega` for its excitation-frequency parameter unless the model names that itself."""
    own = dict(getattr(model, "symbols", None) or {})
    freq = getattr(model, "frequency", None)
    if freq and freq not in own and f"parameter:{freq}" not in own:
        own[f"parameter:{freq}"] = r"\Omega"
    return own


def mathtext_error(text) -> str | None:
    """Why matplotlib could not draw ``text``, or None when it can (or ``text`` holds no mathtext).

    Text with an even number of unescaped ``$`` is mathtext; it is parsed as
    a figure would parse it (:class:`matplotlib.mathtext.MathTextParser`),
    without drawing anything, so that a scene's labels and title are refused
    when the scene is checked rather than after the whole computation.

    Returns
    -------
    str or None
        The parser's own words (``Unknown symbol: \\foo``), on one line.
    """
    if not isinstance(text, str) or "$" not in text:
        return None  # no mathtext (and no need to load matplotlib to say so)
    from matplotlib import cbook
    from matplotlib.mathtext import MathTextParser

    if not cbook.is_math_text(text):
        return None
    try:
        MathTextParser("path").parse(text)
    except ValueError as exc:
        last = str(exc).strip().splitlines()[-1] if str(exc).strip() else type(exc).__name__
        last = re.sub(r"^\w*Exception: ", "", last)
        return last if len(last) <= 160 else last[:157] + "..."
    return None
