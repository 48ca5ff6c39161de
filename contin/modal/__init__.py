"""The static and linear picture of a model: static equilibrium, tangent matrices, natural and damped modes, FRFs, the vibration absorber's closed forms.
"""

from contin.util.lazy import lazy_exports

#: module -> the public names it defines, imported on first use (PEP 562): importing the package stays cheap
_FACE = {
    "equilibrium": ("EquilibriumFailed ModalError solve_equilibrium static_model static_problem "
                    "time_varying_excitations"),
    "modes": "SingularImpedance check_mass damped_modes frf natural_modes principal_coordinates",
    "static_path": "equilibrium_path linear_modes",
    "absorber_design": "design_absorber plot_design",
}
__all__, __getattr__, __dir__ = lazy_exports(__name__, _FACE)
