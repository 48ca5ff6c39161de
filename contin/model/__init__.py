"""Mechanical models: linear matrices plus force and excitation elements, expressions and their compiled kernels, the catalogue of built-in models; the protocol every periodic problem offers.
"""

from contin.util.lazy import lazy_exports

#: module -> the public names it defines, imported on first use (PEP 562): importing the package stays cheap
_FACE = {
    "base": "Model Monomial ParametricMatrix ForceElement ExcitationElement",
    "catalog": "MODELS build_model get_spec rule_violation load_builtin_models",
    "periodic": "PeriodicProblem",
    "elements.registry": "CompiledForm Joined SceneContext kinds_with_compiled_form scene_forms shorten",
    "elements.expression": "ExpressionCoefficient state_names",
    "elements.gap": "GapForce",
    "elements.radial_gap": "RadialGapForce",
    "elements.harmonic": "HarmonicExcitation",
    "fem.builder": "Contact Reduction SideLoad Unbalance Units fe_rotor_model",
    "fem.matrices": "load_matrices",
    "fem.ross_bridge": "load_rotor",
}
__all__, __getattr__, __dir__ = lazy_exports(__name__, _FACE)
