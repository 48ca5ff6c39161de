"""Harmonic balance: the residual R(u, lambda) of a model, its derivatives, AFT, contact crossings, condensation and per-point measures.
"""

from contin.util.lazy import lazy_exports

#: module -> the public names it defines, imported on first use (PEP 562): importing the package stays cheap
_FACE = {
    "factory": "harmonic_balance",
    "problem": "HarmonicBalance HBOptions",
    "condensation": "CondensedHarmonicBalance condense condensation_dofs nonlinear_dofs",
    "derivatives": "HBDerivatives MatrixKind",
    "torus": "QuasiPeriodicBalance TorusOptions torus_measure_names torus_measures",
    "qp_basis": "QPBasis",
    "harmonics": "coefficient_blocks default_samples embed harmonic_amplitudes",
    "measures": "extremum_angle measure_names point_measures",
    "grazing": "grazing_events orbit_contacts",
    "crossings": "series_at",
}
__all__, __getattr__, __dir__ = lazy_exports(__name__, _FACE)
