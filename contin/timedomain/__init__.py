"""Time integration of a model: the compiled integrator, shooting and Poincare sections.
Spectral lines (frequency, amplitude, phase) of recorded signals: :mod:`contin.timedomain.spectral_lines`.
"""

from contin.util.lazy import lazy_exports

#: module -> the public names it defines, imported on first use (PEP 562): importing the package stays cheap
_FACE = {
    "simulation": "simulate compile_model RK4_STABILITY SimulationError",
    "shooting": "ShootingOptions periodic_orbit period_doubling_scan",
    "multiple_shooting": "ShootingProblem",
    "shooting_bifurcations": "ShootingStability period_doubling_start",
    "variational": "VariationalFlow",
    "invariant_circle": "InvariantCircleProblem CircleOptions circle_start",
    "poincare": "spectrum steady_state",
    "torus_check": "check_torus",
}
__all__, __getattr__, __dir__ = lazy_exports(__name__, _FACE)
