"""Stability of periodic solutions: Floquet multipliers and bifurcation events.

- :mod:`contin.stability.hill`: Hill's method on the harmonic-balance matrices;
- :mod:`contin.stability.monodromy`: monodromy matrix by time integration,
  built on :mod:`contin.stability.rk4` (the compiled fixed-step variational
  kernels), :mod:`contin.stability.rk4_step_limit` (RK4's stability limit
  along the orbit) and :mod:`contin.stability.saltation` (switches of contact
  laws and their saltation matrices); :mod:`contin.stability.monodromy_reference`
  holds the adaptive ``solve_ivp`` references;
- :mod:`contin.stability.options`: the method and its options;
- :mod:`contin.stability.verdict`: the multipliers of one solution, their
  counts and the verdict;
- :mod:`contin.stability.floquet`: the multipliers of one solution by the
  chosen method, with the cross-checks of Hill against the monodromy;
- :mod:`contin.stability.multiplier_pairing`: two sets of multipliers
  compared, and the step limit that predicts the next crossing;
- :mod:`contin.stability.monitor`: the monitor of the continuation engine;
- :mod:`contin.stability.point_verdicts` and :mod:`contin.stability.events`:
  the stability events (fold, bp, pd, ns), located and classified.
"""

from contin.stability.events import MultiplierCrossingEvent, StabilityChangeEvent, describe_crossing, stability_events
from contin.stability.floquet import floquet_multipliers
from contin.stability.hill import HillSpectrum, hill_spectrum
from contin.stability.monodromy import (
    Monodromy,
    RK4StepError,
    SwitchEvent,
    monodromy_orbit_ivp,
    monodromy_reference,
    monodromy_rk4,
    orbit_state,
    switching_events,
)
from contin.stability.monitor import StabilityMonitor, describe_ranges, replaced_ranges
from contin.stability.multiplier_pairing import multiplier_distance, multiplier_step_limit
from contin.stability.options import StabilityMethod, StabilityOptions
from contin.stability.verdict import FloquetResult, classify_multipliers, monodromy_result, unevaluated_data

__all__ = [
    "FloquetResult",
    "HillSpectrum",
    "Monodromy",
    "RK4StepError",
    "MultiplierCrossingEvent",
    "StabilityChangeEvent",
    "StabilityMethod",
    "StabilityMonitor",
    "monodromy_result",
    "StabilityOptions",
    "SwitchEvent",
    "classify_multipliers",
    "describe_crossing",
    "describe_ranges",
    "floquet_multipliers",
    "hill_spectrum",
    "monodromy_orbit_ivp",
    "monodromy_reference",
    "monodromy_rk4",
    "multiplier_distance",
    "multiplier_step_limit",
    "orbit_state",
    "replaced_ranges",
    "stability_events",
    "switching_events",
    "unevaluated_data",
]
