"""One call per analysis, with the scene's keys as keyword arguments.

``frequency_response(system, parameter="w", range=(0.5, 3), harmonics=9, stability="hill")``
runs exactly what the scene

.. code-block:: yaml

    model: ...            # the system's model section
    analysis: {type: frequency_response, parameter: w, range: [0.5, 3], harmonics: 9, stability: hill}
    output: {plots: false}

runs, with the same checks, and returns a :class:`contin.api.result.Result`. A keyword
that is no key of the analysis raises ``TypeError`` naming it, as a Python call does
(with the key it was likely meant to be); a value the scene would refuse raises
:class:`contin.scene.parse.SceneError` naming ``analysis.<key>``.
Nothing global changes: no matplotlib backend is selected, no rcParams outlive the
call, BLAS threads are left as they are, and the interrupt handler in place before the
call is back after it.
"""

from __future__ import annotations

from pathlib import Path
from typing import Mapping

from contin.api.result import Result
from contin.api.system import System, plain
from contin.app.runner import execute
from contin.scene.parse import Scene, SceneError, load_scene, parse_scene, scene_from_data
from contin.scene.registry import ANALYSES, analysis
from contin.util.naming import suggest

__all__ = ["run", "ANALYSIS_CALLS", *ANALYSES]

#: what a call writes unless ``output=`` says otherwise: no figure files (``Result.plot`` draws on demand)
DEFAULT_OUTPUT = {"plots": False}


def _system(system) -> System:
    if isinstance(system, System):
        return system
    if isinstance(system, str) and "\n" not in system and not system.endswith((".yaml", ".yml")):
        return System.builtin(system)
    return System.from_scene(system)


def _execute(scene: Scene, outdir, progress: bool) -> Result:
    """Run ``scene``: in memory (nothing written, no figure files) without ``outdir``, else into it as
    ``contin run`` does."""
    return Result(execute(scene, outdir, progress=progress))


def _check_keywords(kind: str, keys: dict) -> None:
    """``TypeError`` for a keyword that is no key of ``kind``'s analysis section, as Python's own calls say it."""
    schema = analysis(kind).schema
    for key in keys:
        if key not in schema:
            raise TypeError(f"{kind}() got an unexpected keyword argument {key!r}{suggest(key, schema)}; "
                            f"its keywords are outdir, output, progress and the keys of a {kind} scene's "
                            f"analysis section: {', '.join(k for k in schema if k != 'type')}")


def _analysis_call(kind: str, system, outdir, output, progress, keys: dict) -> Result:
    _check_keywords(kind, keys)  # before the system is built: a misspelt call fails at once
    system = _system(system)
    if "type" in keys:
        raise SceneError("analysis.type", f"no type keyword: this call runs a {kind} analysis", keys["type"])
    if outdir is None and (output or {}).get("plots"):
        raise SceneError("output.plots", "false without outdir (figures are files: give outdir=..., or draw with "
                         "Result.plot)", True)
    data = {"model": system.section, "analysis": {"type": kind, **plain(keys, "analysis")},
            "output": {**DEFAULT_OUTPUT, **plain(dict(output or {}), "output")}}
    return _execute(scene_from_data(data, "<python>"), outdir, progress)


def run(scene, outdir: str | Path | None = None, *, overrides=(), progress: bool = False) -> Result:
    """Run a whole scene: a path to a scene file, its YAML text, or a dict with ``model``,
    ``analysis`` and ``output``.

    Parameters
    ----------
    scene : path, str or mapping
    outdir : path, optional
        Where the result files go, as ``contin run -o`` writes them; without it nothing is written (the
        result is held in memory, its figures drawn on demand by ``Result.plot``).
    overrides : sequence of str
        ``"dotted.key=value"`` as ``--set`` takes them.
    progress : bool
        Show progress on stderr.
    """
    if isinstance(scene, Mapping):
        data = plain(scene, "scene")
        if overrides:
            import yaml

            parsed = parse_scene(yaml.safe_dump(data), "<python>", overrides)
        else:
            parsed = scene_from_data(data, "<python>")
    elif isinstance(scene, str) and "\n" in scene:
        parsed = parse_scene(scene, "<string>", overrides)
    else:
        parsed = load_scene(scene, overrides)
    return _execute(parsed, outdir, progress)


def _make(kind: str, summary: str, required: str):
    def call(system, *, outdir: str | Path | None = None, output: Mapping | None = None, progress: bool = False,
             **keys) -> Result:
        return _analysis_call(kind, system, outdir, output, progress, keys)

    call.__name__ = call.__qualname__ = kind
    call.__doc__ = f"""{summary}

    Parameters
    ----------
    system : System, str or mapping
        A :class:`contin.api.system.System`, a built-in model's name, or a scene (path, dict).
    outdir : path, optional
        Where the result files go, as ``contin run -o`` writes them; without it nothing is written (the
        result is held in memory).
    output : mapping, optional
        Keys of the scene's ``output`` section (``{{"plots": True, "formats": ["pdf"]}}``, with ``outdir``);
        figures are not written by default.
    progress : bool
        Show progress on stderr.
    **keys
        The keys of the ``analysis`` section of a ``{kind}`` scene ({required}; every key:
        ``docs/reference/scenes.md``).

    Returns
    -------
    Result
    """
    return call


#: one call per analysis of the table :data:`contin.scene.registry.ANALYSES`, made from its summary and keys
ANALYSIS_CALLS = {kind: _make(kind, analysis(kind).summary, analysis(kind).required) for kind in ANALYSES}
globals().update(ANALYSIS_CALLS)  # contin.api.calls.frequency_response, ...
