"""The continuation engine: follows R(u, lambda) = 0 and reports events. Knows nothing of vibrations.

- :mod:`~contin.engine.branch`: the result object (points, special points, status)
- :mod:`~contin.engine.linalg`: row-equilibrated LU factorisations with condition estimates
- :mod:`~contin.engine.newton`: Newton's method
- :mod:`~contin.engine.events`: what an event is: test functions and how their zeros are narrowed
- :mod:`~contin.engine.options`: :class:`~contin.engine.options.ContinuationOptions`
- :mod:`~contin.engine.problem`: the problem protocol, the problem in scaled variables
- :mod:`~contin.engine.predictor`: tangents, their orientation, predictions along the branch
- :mod:`~contin.engine.corrector`: Newton on the bordered system, the checks of a step
- :mod:`~contin.engine.step_control`: the step-size rule, a protocol a caller may replace
- :mod:`~contin.engine.stepsize`: the steps' bookkeeping and the scales of the variables
- :mod:`~contin.engine.corners`: steps across the corners of non-smooth branches
- :mod:`~contin.engine.location`: events in a step: detection and location of special points
- :mod:`~contin.engine.barriers`: events the branch may be unable to pass
- :mod:`~contin.engine.ends`: range ends, turning back, closed loops
- :mod:`~contin.engine.state`: the engine's resumable state (checkpoint and restart)
- :mod:`~contin.engine.connection`: the check that a finished branch is one connected curve
- :mod:`~contin.engine.continuation`: the pseudo-arclength driver, :func:`~contin.engine.continuation.continuation`
"""

from contin.util.lazy import lazy_exports

#: module -> the public names it defines, imported on first use (PEP 562): importing the package stays cheap.
#: ``continuation`` and ``newton`` are left out: the functions share their modules' names, which the
#: package attribute holds once the module is imported
_FACE = {
    "options": "ContinuationOptions",
    "branch": "Branch BranchBuilder BranchStatus SpecialKind SpecialPoint",
    "events": "Event FunctionEvent Location PointInfo OVERSHOOT locate narrow predicted_zero",
    "newton": "solve_at_parameter NewtonResult NUMERICAL_ERRORS",
    "state": "RESTART_KEYS",
}
__all__, __getattr__, __dir__ = lazy_exports(__name__, _FACE)
