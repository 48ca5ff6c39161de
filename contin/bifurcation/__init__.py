"""Bifurcation diagrams built on the engine: starting points, branch switching, backbones and two-parameter curves.
"""

from contin.util.lazy import lazy_exports

#: module -> the public names it defines, imported on first use (PEP 562): importing the package stays cheap
_FACE = {
    "start": ("HomotopyFailed START_LOW_HARMONICS contact_start contact_parameters harmonic_start homotopy_start "
              "integrated_model simulation_start"),
    "backbone": "BackboneError BackboneProblem frequency_extremum_event",
    "two_parameter": "CurveOptions curve_from_point special_point_kind",
    "curve_system": "FlipTestEvent",
    "torus_branch": "TorusSettings",
    "end_check": "branch_end_checks",
    "diagram": "follow",
}
__all__, __getattr__, __dir__ = lazy_exports(__name__, _FACE)
