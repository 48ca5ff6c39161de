"""Damped Mathieu-Duffing oscillator (parametric excitation).

    x'' + c x' + (delta + eps cos(w t)) x + g x^3 = 0

With ``c = g = 0`` the trivial solution's stability boundaries in ``delta``
are the Mathieu characteristic curves ``delta = a_r(q)/4`` (and ``b_r(q)/4``)
with ``q = 2 eps`` for ``w = 1`` (Abramowitz & Stegun 20.1; scipy.special.mathieu_a/b).
"""

from __future__ import annotations

from contin.model.catalog import ModelSpec, register_model
from contin.models.polynomial import polynomial_model

__all__ = ["mathieu"]


def _build(params: dict, effects: tuple):
    nonlinear = []
    terms = ["x'' + delta*x (frequency domain)"]
    if "parametric" in effects:
        nonlinear.append({"dof": "x", "coef": "eps", "x": {"x": 1}, "order": 1})
    if "cubic" in effects:
        nonlinear.append({"dof": "x", "coef": "g", "x": {"x": 3}})
    if "damping" in effects:
        terms.append("c*x' (frequency domain)")
    return polynomial_model(
        ["x"],
        params,
        mass=[[1.0]],
        damping=[["c"]] if "damping" in effects else None,
        stiffness=[["delta"]],
        nonlinear=nonlinear,
        name="mathieu",
        effects=effects,
        terms=terms,
    )


mathieu = register_model(
    ModelSpec(
        name="mathieu",
        summary="damped Mathieu-Duffing oscillator x'' + c x' + (delta + eps cos(w t)) x + g x^3 = 0",
        parameters={"delta": 0.25, "eps": 0.2, "c": 0.0, "g": 0.0, "w": 1.0},
        effects={
            "damping": "viscous damping c x'",
            "parametric": "parametric stiffness eps cos(w t) x",
            "cubic": "cubic stiffness g x^3",
        },
        default_effects=("damping", "parametric", "cubic"),
        builder=_build,
        # delta < 0 (the inverted pendulum) and g < 0 are meaningful; eps's sign is a phase
        constraints={"c": ("nonnegative", "a viscous damping"), "w": ("nonnegative", "the excitation frequency")},
    )
)
