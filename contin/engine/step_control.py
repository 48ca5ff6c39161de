"""The step-size rule of the continuation as a small protocol, :class:`StepControl`.

:func:`~contin.engine.continuation.continuation` takes it as ``step_control``
(None: :class:`AdaptiveStep`, the rule the options describe). The engine asks
it for the step it wants at three moments:

``first(options) -> float``
    once, as a run begins (a resumed run too, before its state is restored):
    the first step;
``accepted(ds, taken, iterations) -> float``
    after a stored point, reached with the wanted step ``ds`` (the step
    actually taken, ``taken``, is shorter where an event's prediction, a range
    end or a corner cut it) in ``iterations`` Newton updates: the next step;
``rejected(ds, reason) -> float``
    after an attempt of ``ds`` failed (``reason`` says why: no convergence, a
    tangent turning by more than ``max_angle_deg``, a corrector moving
    farther than the step, ...): the step to try instead, shorter than ``ds``.

The engine keeps the rest: a step is shortened to an event predicted within
it, the steps stay within ``[ds_min, ds_max]``, a failure at ``ds_min`` ends
the branch with ``STEP_TOO_SMALL``, and so does a rule that does not shorten
the step after a failure (it would try the same step forever).

A rule with state of its own (a history of steps, a count) also gives
``state()``, plain values and arrays, and ``restore(state)``: the engine's
checkpoints hold that state and a restart gives it back
(:mod:`contin.engine.state`), so a resumed run equals the uninterrupted one.
"""

from __future__ import annotations

from typing import Any, Protocol

__all__ = ["AdaptiveStep", "StepControl", "as_step_control"]

#: the methods a step control must have
REQUIRED = ("first", "accepted", "rejected")


class StepControl(Protocol):
    """What :func:`~contin.engine.continuation.continuation` asks of a step-size rule (see the module)."""

    def first(self, options: Any) -> float:
        """The first step of a run with these :class:`~contin.engine.options.ContinuationOptions`."""

    def accepted(self, ds: float, taken: float, iterations: int) -> float:
        """The step to want after a point stored with the wanted step ``ds`` (``taken``: the step taken)."""

    def rejected(self, ds: float, reason: str) -> float:
        """The step to try after an attempt of ``ds`` failed for ``reason`` (shorter than ``ds``)."""


class AdaptiveStep:
    """The default rule: grow after easy steps, shrink after failures.

    The factors come from the run's options: after a point whose corrector
    converged in at most ``newton_easy`` updates the step grows by ``grow``
    (else it stays), after a failed attempt it shrinks by ``shrink``. It has
    no state of its own: the wanted step, which the engine keeps and saves,
    is all it needs.
    """

    def __init__(self):
        self.opt = None

    def first(self, options) -> float:
        self.opt = options
        return options.ds

    def accepted(self, ds: float, taken: float, iterations: int) -> float:
        opt = self.opt
        return ds * opt.grow if iterations <= opt.newton_easy else ds

    def rejected(self, ds: float, reason: str) -> float:
        return ds * self.opt.shrink

    def __repr__(self) -> str:
        return "AdaptiveStep()"


def as_step_control(step_control) -> StepControl:
    """The rule of a run: :class:`AdaptiveStep` for None, else ``step_control`` once it has the methods.

    Raises
    ------
    TypeError
        A class instead of an instance, or an object without one of
        ``first``, ``accepted``, ``rejected`` (named).
    """
    if step_control is None:
        return AdaptiveStep()
    if isinstance(step_control, type):
        raise TypeError(f"step_control must be an instance, got the class {step_control.__name__}: "
                        f"pass {step_control.__name__}(...)")
    missing = [name for name in REQUIRED if not callable(getattr(step_control, name, None))]
    if missing:
        raise TypeError(f"step_control {type(step_control).__name__} has no method {', '.join(missing)}: "
                        f"a step control needs {', '.join(REQUIRED)} (see contin.engine.step_control)")
    return step_control
