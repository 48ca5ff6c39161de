"""The contract every analysis fulfils: :class:`Analysis`, and what a run hands it (:class:`RunContext`).

An analysis is what ``analysis.type`` names in a scene. Each is one module of
this package holding one subclass of :class:`Analysis`, listed by one line
in :data:`contin.scene.registry.ANALYSES`; the scene schemas, ``contin check``,
``contin run``, the Python API (``contin.frequency_response(...)``) and the
generated scene reference all read that table, so nothing else changes when
one is added (docs/howto/new-analysis.md adds one end to end).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Callable, ClassVar, Protocol

if TYPE_CHECKING:  # annotations only: the command line imports RunError from here before any run
    from contin.analyses.branch_recorder import BranchRecorder
    from contin.engine.options import ContinuationOptions
    from contin.model.base import Model
    from contin.output.outcome import Outcome, Sink
    from contin.scene.parse import Scene

__all__ = ["Analysis", "Progress", "RunContext", "RunError", "ScaleCheck"]


class Progress(Protocol):
    """What a run reports its progress to (:class:`contin.app.progress.Progress` on the command line)."""

    enabled: bool

    def update(self, text: str, **where) -> None:
        """The current state in one line (``where``: the parameter, its bounds, the task, for the bar)."""

    def close(self) -> None:
        """The run is over: the last line stays."""


class RunError(RuntimeError):
    """A run that could not proceed for numerical reasons (for example no starting solution)."""


@dataclass(frozen=True)
class ScaleCheck:
    """One problem whose ``unknown_scale`` option must have its number of unknowns (checked before a run).

    Attributes
    ----------
    key : str
        The scene key of the options (``analysis.continuation.unknown_scale``).
    options : object
        The options holding ``unknown_scale`` (a :class:`contin.engine.options.ContinuationOptions`).
    size : int
        The problem's number of unknowns.
    what : str
        What those unknowns are, for the message.
    note : str
        Why the scale also serves another problem (e.g. the switched branches), or "".
    """

    key: str
    options: ContinuationOptions
    size: int
    what: str
    note: str = ""


@dataclass
class RunContext:
    """What a run hands an analysis while it runs.

    Attributes
    ----------
    scene : Scene
    model : Model
    sink : Sink
        Where the tables and figures go: the result directory, or memory only.
    progress : Progress
        The progress line (:class:`contin.app.progress.Progress`).
    timings : dict
        Seconds by stage; the analysis adds its own.
    resume : bool
        Continue an interrupted run from its checkpoint.
    run_scene : callable or None
        ``run_scene(scene, outdir_or_None) -> Outcome``, for analyses made of whole runs (a convergence study).
    stop_requested, interrupted : bool
        Set by the runner on Ctrl-C, SIGTERM, SIGHUP; the analysis stops at its next point.
    recorder : object
        The analysis' recorder of branch points, when it has one (its stored solutions' expansion).
    summary : dict
        What ``summary.json`` holds before the analysis runs (the scene, the model with its dofs,
        parameters and frequency, versions).
    """

    scene: Scene
    model: Model
    sink: Sink
    progress: Progress
    timings: dict = field(default_factory=dict)
    resume: bool = False
    run_scene: Callable | None = None
    stop_requested: bool = False
    interrupted: bool = False
    recorder: BranchRecorder | None = None
    summary: dict = field(default_factory=dict)

    @property
    def outdir(self) -> Path | None:
        """The result directory (None for a run held in memory)."""
        return self.sink.outdir


class Analysis:
    """An analysis a scene can run: subclass it to add one.

    To add an analysis ``my_study`` (docs/howto/new-analysis.md does it end to end):

    1. Write ``contin/analyses/my_study.py`` with a subclass setting
       :attr:`name` (its ``analysis.type``), :attr:`summary` (one line, shown
       by the Python API and the scene reference), :attr:`required` (its
       required keys, in words) and :attr:`schema` (the keys of its
       ``analysis`` section, built from :mod:`contin.scene.schema`).
    2. :meth:`plan`: every check that needs the built model, made before
       anything is written, returning a frozen dataclass of every checked
       choice (parameter, range, problems, options; an analysis that follows
       a branch takes its sweep from :func:`contin.scene.sweep_plan.sweep_plan`).
       Refuse what the run could not do with ``scene.error(key, expected, found)``.
    3. :meth:`run`: compute from the plan; write tables through ``ctx.sink``
       (``ctx.sink.table("my_study.csv", columns)``); return an
       :class:`~contin.output.outcome.Outcome` with its shortfalls
       (:meth:`outcome` makes it from ``ctx``).
    4. :meth:`describe`: the lines ``contin check`` prints for the plan.
    5. Optionally :meth:`validate` (checks of the whole scene before the
       model is built), :meth:`demands` (its memory and work, refused
       beyond the machine's before the plan), :meth:`scale_checks` (the
       problems whose ``unknown_scale`` is checked against their size) and
       :meth:`compile_ahead` (time-domain problems whose kernels a second
       process compiles while the run begins).
    6. Add one line to :data:`contin.scene.registry.ANALYSES` and a test in
       ``tests/analyses/``.
    """

    #: the ``analysis.type`` that names it
    name: ClassVar[str] = ""
    #: one line on what it computes
    summary: ClassVar[str] = ""
    #: its required keys, in words (the Python API's docstring)
    required: ClassVar[str] = "none required"
    #: the keys of its ``analysis`` section (:mod:`contin.scene.schema`)
    schema: ClassVar[dict] = {}

    def validate(self, data: dict, model: dict, analysis: dict, lines: dict) -> None:
        """Checks of the whole scene beyond the section schema, before the model is built.

        ``data`` is the scene as loaded, ``model`` and ``analysis`` its checked
        sections, ``lines`` the source lines of its keys; raises ``SceneError``.
        """

    def plan(self, scene, model: Model):
        """Every check that needs the built ``model``; returns the checked choices (raises ``SceneError``)."""
        raise NotImplementedError(f"{type(self).__name__}.plan")

    def run(self, plan, ctx: RunContext) -> Outcome:
        """Compute what the scene asks, from ``plan``; returns the outcome, held in memory."""
        raise NotImplementedError(f"{type(self).__name__}.run")

    def describe(self, plan, scene, model: Model) -> list[str]:
        """What ``contin check`` prints of the plan below the model (lines, indented by two spaces)."""
        return []

    def demands(self, scene, model) -> list:
        """The memory and work the scene asks, in groups of :class:`contin.scene.budget.Demand` held at once,
        estimated before :meth:`plan` builds anything (refused beyond the machine's limits); none by default."""
        return []

    def scale_checks(self, plan) -> list[ScaleCheck]:
        """The problems whose ``unknown_scale`` must match their size (checked after :meth:`plan`)."""
        return []

    def compile_ahead(self, plan) -> list:
        """``(problem, parameter value)`` of the time-domain problems the run may integrate after its first part:
        their kernels, when not yet cached, are compiled meanwhile in a second process (:mod:`contin.app.compile_ahead`;
        a problem has ``kernels()``, ``residual`` and ``linearize``); none by default."""
        return []

    @staticmethod
    def outcome(ctx: RunContext, analysis: dict, *, shortfalls=(), data=None, draw=None) -> Outcome:
        """The outcome of a run: ``analysis`` (its part of ``summary.json``) with the tables of ``ctx.sink``."""
        from contin.output.outcome import Outcome  # deferred: it loads the engine (0.8 s); see TYPE_CHECKING

        return Outcome(analysis=analysis, tables=ctx.sink.tables(), data=data, shortfalls=list(shortfalls),
                       outdir=ctx.outdir, draw=draw, cells=ctx.sink.cells())
