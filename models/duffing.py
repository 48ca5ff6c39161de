"""The forced Duffing oscillator.

    m x'' + c x' + k x + g x^3 = F cos(w t)

With ``H = 1`` the harmonic balance gives the classical amplitude equation
``[(k - m w^2 + 3/4 g A^2)^2 + (c w)^2] A^2 = F^2`` (Nayfeh & Mook,
*Nonlinear Oscillations*, 1979, sec. 4.1), which the tests use as the
closed-form reference.
"""

from __future__ import annotations

from contin.model.base import Model
from contin.model.catalog import ModelSpec, register_model
from contin.models.polynomial import polynomial_model

__all__ = ["duffing"]


def _build(params: dict, effects: tuple) -> Model:
    nonlinear = [{"dof": "x", "coef": "g", "x": {"x": 3}}] if "cubic" in effects else []
    forcing = [{"dof": "x", "amplitude": "F", "order": 1}] if "forcing" in effects else []
    terms = ["m*x'' + k*x (frequency domain)"]
    if "damping" in effects:
        terms.append("c*x' (frequency domain)")
    model = polynomial_model(
        ["x"],
        params,
        mass=[["m"]],
        damping=[["c"]] if "damping" in effects else None,
        stiffness=[["k"]],
        nonlinear=nonlinear,
        forcing=forcing,
        name="duffing",
        effects=effects,
        terms=terms,
    )
    model.symbols = {"w": r"\Omega"}  # the excitation frequency, as figures write it
    return model


duffing = register_model(
    ModelSpec(
        name="duffing",
        summary="forced Duffing oscillator m x'' + c x' + k x + g x^3 = F cos(w t)",
        parameters={"m": 1.0, "c": 0.1, "k": 1.0, "g": 1.0, "F": 0.5, "w": 1.0},
        effects={
            "damping": "viscous damping c x'",
            "cubic": "cubic stiffness g x^3",
            "forcing": "harmonic forcing F cos(w t)",
        },
        default_effects=("damping", "cubic", "forcing"),
        builder=_build,
        # k < 0 (a double well) and g < 0 (softening) are meaningful; F's sign is a phase
        constraints={"m": ("positive", "a mass"), "c": ("nonnegative", "a viscous damping"),
                     "w": ("nonnegative", "the excitation frequency")},
    )
)
