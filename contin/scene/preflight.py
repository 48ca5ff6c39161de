"""Checks of a scene with its built model beyond each analysis's own, made by ``contin check`` and before a run.

- :func:`check_texts`: every text a figure draws from the scene
  (``output.title``, ``output.labels``, ``output.units``, ``model.symbols``,
  a custom model's ``name``, a convergence scene's ``analysis.labels``) is
  parsed as matplotlib's mathtext parser would parse it, so that a typo in a
  label is refused before the computation rather than after it.
- :func:`check_unknown_scale`: ``continuation.unknown_scale`` given as a list
  has one value per unknown of the problem it scales (and a list cannot scale
  the branches a period doubling or a torus switches to, which have others).
"""

from __future__ import annotations

import numpy as np

from contin.output.labels import axis_label, math, mathtext_error, model_symbols

__all__ = ["check_texts", "check_unknown_scale"]


def _texts(scene, model):
    """``(key, text as drawn)`` of every text a figure of the scene draws from what the scene says."""
    out, m = scene.output, scene.model
    symbols = model_symbols(model)
    if isinstance(out.get("title"), str):
        yield "output.title", out["title"]
    labels = out.get("labels") if isinstance(out.get("labels"), dict) else {}
    units = out.get("units") if isinstance(out.get("units"), dict) else {}
    for name, text in labels.items():
        yield f"output.labels.{name}", str(text)
    for name in list(labels) + [k for k in units if k not in labels]:
        if name in units:
            yield f"output.units.{name}", axis_label(str(name), units, labels, symbols)
    for name in m.get("symbols") or {}:
        yield f"model.symbols.{name}", math(str(name), symbols)
    if isinstance(m.get("name"), str) and "builtin" not in m:
        yield "model.name", m["name"]  # a figure's title when output.title is not given
    if scene.analysis.get("type") == "convergence" and isinstance(scene.analysis.get("labels"), dict):
        for k, text in scene.analysis["labels"].items():
            if isinstance(text, str):
                yield f"analysis.labels.{k}", text


def check_texts(scene, model) -> None:
    """Refuse a text of the scene that matplotlib's mathtext parser cannot read (see :func:`_texts`).

    Raises
    ------
    contin.scene.schema.SceneError
        Naming the key, the text and the parser's words.
    """
    for key, text in _texts(scene, model):
        why = mathtext_error(text)
        if why:
            raise scene.error(key, "text matplotlib can draw (mathtext between $ signs: \\alpha, x_{1}, "
                              "\\frac{a}{b}, ...; \\$ for a dollar sign)", text, hint=f"; matplotlib says: {why}")


def dofs_text(n: int) -> str:
    """``1 dof`` or ``n dofs`` (the messages of :func:`check_unknown_scale`)."""
    return "1 dof" if n == 1 else f"{n} dofs"


def scale_key(scene, index: int) -> str:
    """The key that sets the continuation options of start ``index`` (0: the scene's own)."""
    if index > 0:
        extra = scene.analysis["starts"][index - 1]
        if isinstance(extra, dict) and "continuation" in extra:
            return f"analysis.starts[{index - 1}].continuation.unknown_scale"
    return "analysis.continuation.unknown_scale"


def _check_length(scene, key: str, options, m: int, what: str, switched: str = "") -> None:
    scale = getattr(options, "unknown_scale", None)
    if scale is None or np.ndim(scale) == 0:
        return
    if switched:
        raise scene.error(key, f"a single positive number (the branches {switched} switches to have other "
                          f"unknowns than the {m} of {what})", f"a list of {len(scale)} numbers")
    if len(scale) != m:
        raise scene.error(key, f"a single positive number or a list of {m} (one per unknown: {what})",
                          f"a list of {len(scale)} numbers")


def check_unknown_scale(scene, checks) -> None:
    """``continuation.unknown_scale`` (and ``curve_continuation.unknown_scale``) of the length of its problem.

    Parameters
    ----------
    scene : Scene
    checks : sequence of ScaleCheck
        The analysis's problems with their options
        (:meth:`contin.analyses.base.Analysis.scale_checks`): ``key``,
        ``options``, ``size``, ``what``, ``note``.

    Raises
    ------
    contin.scene.schema.SceneError
        Naming the key, the number of unknowns and the length found.
    """
    for c in checks:
        _check_length(scene, c.key, c.options, c.size, c.what, c.note)
