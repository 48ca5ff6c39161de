"""The Python interface: :class:`System` (a model in the scene's vocabulary), one call per
analysis returning a :class:`Result`, and :func:`load` for a result directory."""

from contin.api.calls import (backbone, bifurcation_curve, convergence, frequency_response, frf, modes, run, simulate,
                              static)
from contin.api.result import BranchResult, LocatedPoint, Result, load
from contin.api.system import System

__all__ = ["System", "Result", "BranchResult", "LocatedPoint", "load", "run", "frequency_response", "backbone",
           "static", "modes", "frf", "simulate", "bifurcation_curve", "convergence"]
