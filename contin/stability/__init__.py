"""Stability of periodic solutions: Floquet multipliers and bifurcation events.

- :mod:`contin.stability.hill`: Hill's method on the harmonic-balance matrices;
- :mod:`contin.stability.monodromy`: monodromy matrix by time integration,
  built on :mod:`contin.stability.rk4` (the compiled fixed-step variational
  kernels) and :mod:`contin.stability.saltation` (switches of contact laws and
  their saltation matrices); :mod:`contin.stability.monodromy_reference`
  holds the adaptive ``solve_ivp`` references;
- :mod:`contin.stability.floquet`: options, results, the verdict, and the
  monitor and events used by the continuation engine.
"""

from contin.stability.floquet import (
    FloquetResult,
    MultiplierCrossingEvent,
    StabilityChangeEvent,
    StabilityMethod,
    StabilityMonitor,
    StabilityOptions,
    classify_multipliers,
    describe_crossing,
    floquet_multipliers,
    monodromy_result,
    multiplier_distance,
    multiplier_step_limit,
    stability_events,
    unevaluated_data,
)
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
    "floquet_multipliers",
    "hill_spectrum",
    "monodromy_orbit_ivp",
    "monodromy_reference",
    "monodromy_rk4",
    "multiplier_distance",
    "multiplier_step_limit",
    "orbit_state",
    "stability_events",
    "switching_events",
    "unevaluated_data",
]
