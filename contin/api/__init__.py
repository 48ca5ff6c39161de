"""The Python interface: :class:`System` (a model in the scene's vocabulary), one call per
analysis of :data:`contin.scene.registry.ANALYSES` returning a :class:`Result`, and :func:`load`
for a result directory."""

from contin.api.calls import ANALYSIS_CALLS, run
from contin.api.result import BranchResult, LocatedPoint, Result, load
from contin.api.system import System
from contin.scene.registry import ANALYSES

globals().update(ANALYSIS_CALLS)  # contin.api.frequency_response, ...

__all__ = ["System", "Result", "BranchResult", "LocatedPoint", "load", "run", *ANALYSES]
