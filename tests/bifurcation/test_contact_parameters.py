"""Which parameters a contact start softens and where it puts the stop: declared by the contact, not by name.

The generic start (:func:`contin.bifurcation.start.contact_start`) names no
model family's parameters: the contact element says which of the model's
parameters are its stiffness and clearance
(:meth:`contin.model.base.ForceElement.contact_parameters`), or the caller
does. Truth from the models' definitions: the names written into them.
"""

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from contin.bifurcation.start import contact_parameters, contact_start
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.model.base import Model, Monomial, ParametricMatrix
from contin.model.elements.expression import ExpressionCoefficient
from contin.model.elements.gap import GapForce
from contin.model.elements.harmonic import HarmonicExcitation
from contin.model.elements.polynomial import PolynomialForce
from contin.model.elements.radial_gap import RadialGapForce

NAMES = ("w", "F", "k_stop", "g0", "c_stop", "k2")


def _p(name, const=1.0, power=1):
    return Monomial(const, ((NAMES.index(name), power),))


def chain(*forces):
    """Two masses on springs, forced on the first; ``forces`` act on the second."""
    eye = np.eye(2)
    return Model(name="chain with a stop", dof_names=("x1", "x2"),
                 parameters=dict(zip(NAMES, (1.0, 0.1, 50.0, 0.2, 0.01, 2.0))),
                 mass=ParametricMatrix(2, ((Monomial(1.0), eye),)),
                 damping=ParametricMatrix(2, ((Monomial(0.02), eye),)),
                 stiffness=ParametricMatrix(2, ((Monomial(1.0), np.array([[2.0, -1.0], [-1.0, 1.0]])),)),
                 forces=list(forces), excitations=[HarmonicExcitation(0, _p("F"))])


def test_a_contact_declares_the_parameters_of_its_stiffness_and_clearance():
    gap = GapForce(1, _p("g0"), _p("k_stop"), _p("c_stop"))
    assert gap.contact_parameters(NAMES) == ("k_stop", "g0")
    assert contact_parameters(chain(gap)) == ("k_stop", "g0")
    radial = RadialGapForce((0, 1), ExpressionCoefficient("g0", NAMES), ExpressionCoefficient("k_stop", NAMES))
    assert radial.contact_parameters(NAMES) == ("k_stop", "g0")
    # a coefficient that is not one parameter alone names none
    assert GapForce(1, _p("g0", 2.0), _p("k_stop", power=2)).contact_parameters(NAMES) == (None, None)
    assert GapForce(1, Monomial(0.2), ExpressionCoefficient("k_stop*k2", NAMES)).contact_parameters(NAMES) == \
        (None, None)
    cubic = PolynomialForce(2, [(1, _p("k2"), np.array([0, 3]), np.zeros(2, dtype=int))])
    assert cubic.contact_parameters(NAMES) is None  # no contact


def test_given_names_are_taken_and_checked():
    model = chain(GapForce(1, _p("g0"), _p("k_stop")))
    assert contact_parameters(model, stiffness="k2") == ("k2", "g0")
    assert contact_parameters(model, "k2", "F") == ("k2", "F")
    with pytest.raises(ValueError, match=r"contact_start: stiffness must be a parameter of the model .* got 'kbn'"):
        contact_parameters(model, stiffness="kbn")
    with pytest.raises(ValueError, match=r"contact_start: clearance must be a parameter of the model .* got 'delta'"):
        contact_parameters(model, clearance="delta")


@pytest.mark.parametrize("forces, match", [
    ((), r"stiffness not given and model 'chain with a stop' has no contact element to tell it"),
    ((GapForce(1, _p("g0"), _p("k_stop", 3.0)),), r"stiffness not given .* do not name one parameter for it \(they "
                                                  r"give \['None'\]\); pass stiffness="),
    ((GapForce(1, Monomial(0.2), _p("k_stop")),), r"clearance not given .* \(they give \['None'\]\); pass clearance="),
    ((GapForce(1, _p("g0"), _p("k_stop")), GapForce(0, _p("g0"), _p("k2"))),
     r"stiffness not given .* \(they give \['k2', 'k_stop'\]\)"),
])
def test_a_contact_that_cannot_tell_is_refused_by_name(forces, match):
    model = chain(*forces)
    with pytest.raises(ValueError, match=match):
        contact_parameters(model)
    hb = HarmonicBalance(model, "w", HBOptions(harmonics=1))
    with pytest.raises(ValueError, match=match):  # before any solve
        contact_start(hb, 1.0, direction=(1.0,), simulation=0)


def test_two_contacts_on_the_same_parameters_agree():
    model = chain(GapForce(1, _p("g0"), _p("k_stop"), sides="+"), GapForce(0, _p("g0"), _p("k_stop"), sides="-"))
    assert contact_parameters(model) == ("k_stop", "g0")


# the solve costs a compilation of the gap's kernels (10 s on a cold cache)
@pytest.mark.slow
def test_a_rotor_whose_contact_parameters_have_other_names_starts_alike():
    from contin.model.fem.builder import Contact, SideLoad, Unbalance, Units, fe_rotor_model
    from contin.model.fem.matrices import load_matrices

    rotor = load_matrices(Path(__file__).resolve().parents[1] / "model" / "data" / "spline_rotor.npz")
    base = fe_rotor_model(rotor, contact=Contact(3, 2e-5, 1e7, 50.0, type="gap", direction="y", sides="+"),
                          unbalance=[Unbalance(3, 2e-4)], side_load=SideLoad(3, (0.0, 20.0)), units=Units(1e-5))
    renamed = {"delta": "gap", "kbn": "k_contact"}
    model = dataclasses.replace(base, parameters={renamed.get(k, k): v for k, v in base.parameters.items()})
    assert contact_parameters(model) == ("k_contact", "gap")
    hb = HarmonicBalance(model, "w", HBOptions(harmonics=12, crossings="interval", samples=256), {"w": 1.0})
    u = contact_start(hb, 1.0, direction=(1.0,))
    assert np.abs(hb.residual(u, 1.0)).max() < 1e-8
    U = u.reshape(-1, model.n_dof)
    assert U[0, 13] + np.hypot(U[1, 13], U[2, 13]) > model.parameters["gap"]  # it reaches the stop
