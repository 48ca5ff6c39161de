"""What a branch-following analysis sweeps, decided once: :class:`SweepPlan`.

Every analysis that follows a branch in a parameter (``frequency_response``,
``bifurcation_curve``, ``static``, and ``convergence`` through them) takes
from :func:`sweep_plan`: the excitation frequency (``tau = w t``), the
continuation parameter (the frequency unless ``analysis.parameter`` names
another), the range, the start, the direction and whether the branch is
followed both ways from its start. Nothing else decides them.
"""

from __future__ import annotations

from dataclasses import dataclass

from contin.scene.parse import model_frequency
from contin.util.naming import suggest

__all__ = ["SweepPlan", "parameter_name", "runs_from_start", "sweep_names", "sweep_plan"]


@dataclass(frozen=True)
class SweepPlan:
    """The checked sweep of a branch-following analysis.

    Attributes
    ----------
    parameter : str
        The continuation parameter.
    frequency : str or None
        The excitation frequency's parameter (None: a model without one, e.g. a static analysis of one that has
        no excitation frequency).
    range : (float, float)
        ``analysis.range`` as written: ``(first, second)``.
    start : float
        Where the first branch starts (``analysis.start``, else the first end of the range).
    both_ways : bool
        The branch is followed from ``start`` towards both ends.
    """

    parameter: str
    frequency: str | None
    range: tuple
    start: float
    both_ways: bool = False

    @property
    def lo(self) -> float:
        return min(self.range)

    @property
    def hi(self) -> float:
        return max(self.range)

    @property
    def end(self) -> float:
        """The end of the range the first branch goes towards (the other end when it starts at one)."""
        a, b = self.range
        return b if self.start != b else a

    @property
    def direction(self) -> int:
        """+1 when the first branch goes towards larger values, else -1."""
        return 1 if self.end > self.start else -1

    def runs(self, options) -> list:
        """The continuation options of each run from the start (:func:`runs_from_start`)."""
        return runs_from_start(options, self.both_ways, self.start, (self.lo, self.hi))


def runs_from_start(options, both_ways: bool, start: float, bounds) -> list:
    """The runs from a start: ``options`` (towards the range's other end), then, when the branch is followed
    both ways and starts strictly inside the range, the same options in the opposite direction.

    Parameters
    ----------
    options : ContinuationOptions
        With ``direction`` and ``replace(direction=...)``.
    both_ways : bool
    start : float
    bounds : (float, float)
        The range, increasing.
    """
    back = both_ways and bounds[0] < start < bounds[1]
    return [options] + ([options.replace(direction=-options.direction)] if back else [])


def sweep_names(scene, model, analysis: dict | None = None, *, need_frequency: bool = True) -> tuple:
    """``(parameter, frequency)`` of the sweep (:func:`sweep_plan`'s first two choices, for a problem
    built without a range: a stored solution's).

    Raises
    ------
    SceneError
        ``analysis.frequency`` (when ``need_frequency``) or ``analysis.parameter`` not a parameter of the model.
    """
    a = scene.analysis if analysis is None else analysis
    names = list(model.parameters)
    freq = model_frequency(scene.model, a)
    if freq not in model.parameters:
        if need_frequency:
            raise scene.error("analysis.frequency", f"a parameter of the model {names}", freq)
        freq = None
    param = a.get("parameter") or freq
    if param not in model.parameters:
        raise scene.error("analysis.parameter", f"a parameter of the model {names}", param,
                          hint=suggest(param, names) if isinstance(param, str) else "")
    return param, freq


def parameter_name(model: dict, analysis: dict) -> str | None:
    """The parameter a checked scene sweeps, before its model is built (for the checks of its values):
    ``analysis.parameter``, else the scene's frequency (:func:`contin.scene.parse.model_frequency`)."""
    return analysis.get("parameter") or model_frequency(model, analysis)


def sweep_plan(scene, model, analysis: dict | None = None, key: str = "analysis", *,
               need_frequency: bool = True) -> SweepPlan:
    """The sweep of ``scene`` (or of ``analysis``, a further start's merged section) on its built ``model``.

    Parameters
    ----------
    scene : Scene
    model : Model
    analysis : dict, optional
        The analysis section to read (default: the scene's).
    key : str
        Its scene key, for messages (``analysis.starts[0]`` for a further start).
    need_frequency : bool
        Refuse a frequency that is not a parameter of the model (an analysis whose problems are periodic);
        otherwise such a frequency is None.

    Raises
    ------
    SceneError
        ``analysis.frequency`` or ``analysis.parameter`` not a parameter of the model, ``analysis.start``
        outside the range.
    """
    a = scene.analysis if analysis is None else analysis
    param, freq = sweep_names(scene, model, a, need_frequency=need_frequency)
    first, second = float(a["range"][0]), float(a["range"][1])
    start = float(a["start"]) if a.get("start") is not None else first
    lo, hi = min(first, second), max(first, second)
    if not lo <= start <= hi:
        raise scene.error(f"{key}.start", f"a value inside range [{lo:g}, {hi:g}]", start)
    return SweepPlan(parameter=param, frequency=freq, range=(first, second), start=start,
                     both_ways=bool(a.get("both_ways", False)))
