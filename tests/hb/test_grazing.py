"""Grazing of harmonic-balance orbits: the contact count, the extremum, and the located point.

Truth from outside the code: the linear frequency response below the clearance
(closed form) reaches the stop exactly where |X(w)| = clearance, and dense
sampling of the orbit's series gives its extremum independently of the
refinement.
"""

import numpy as np
import pytest
from scipy.optimize import brentq

from contin.engine.continuation import ContinuationOptions, continuation
from contin.model.elements import GapForce
from contin.hb.grazing import GrazingEvent, grazing_events, orbit_contacts
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.hb.harmonics import coefficient_blocks
from contin.model.base import Monomial
from contin.models.polynomial import polynomial_model

C, F, G = 0.05, 0.2, 1.0


def gap_oscillator(sides="+", crossings="interval", harmonics=15):
    model = polynomial_model(["x"], {"c": C, "F": F, "w": 0.5}, mass=[[1.0]], damping=[["c"]], stiffness=[[1.0]],
                             forcing=[{"dof": "x", "amplitude": "F"}])
    model.forces.append(GapForce(0, Monomial(G), Monomial(20.0), sides=sides))
    return HarmonicBalance(model, "w", HBOptions(harmonics=harmonics, samples=256, crossings=crossings))


def linear_grazing_speed():
    """Where the linear response amplitude F/|1 - w^2 + i c w| reaches the clearance (below resonance)."""
    return brentq(lambda w: F / np.hypot(1 - w * w, C * w) - G, 0.5, 0.99)


def single_harmonic_max(u):
    """max over theta of a0 + a1 cos + b1 sin (a linear orbit has harmonic 1 only)."""
    U = coefficient_blocks(u, 1)
    assert np.abs(U[3:]).max() < 1e-14
    return U[0, 0] + np.hypot(U[1, 0], U[2, 0])


def test_contacts_of_a_linear_orbit_match_its_closed_form_maximum():
    hb = gap_oscillator()
    for w in (0.7, 0.85):
        u = hb.linear_solution(w)
        c = orbit_contacts(hb, u, w)
        assert c.switches == 0
        assert c.extremum == pytest.approx(single_harmonic_max(u) - G, abs=1e-13)  # h = x - g at the maximum


@pytest.mark.parametrize("crossings", ["interval", "exact"])
def test_grazing_of_the_linear_response_is_located_where_it_reaches_the_stop(crossings):
    hb = gap_oscillator(crossings=crossings)
    (ev,) = grazing_events(hb)
    assert isinstance(ev, GrazingEvent) and ev.barrier
    br = continuation(hb, hb.linear_solution(0.5), 0.5, (0.5, 1.2), ContinuationOptions(ds=0.05, ds_max=0.2),
                      parameter_name="w", events=[ev])
    found = br.points_of_kind("grazing")
    assert found, br.message
    first = found[0]
    assert first.located
    assert first.parameter == pytest.approx(linear_grazing_speed(), abs=1e-9)
    assert first.data["switches"] in (0, 2)
    assert abs(first.data["extremum"]) < 1e-9


def test_models_without_contact_laws_get_no_grazing_event():
    model = polynomial_model(["x"], {"c": C, "F": F, "w": 0.5}, mass=[[1.0]], damping=[["c"]], stiffness=[[1.0]],
                             forcing=[{"dof": "x", "amplitude": "F"}])
    assert grazing_events(HarmonicBalance(model, "w", HBOptions(harmonics=3))) == []
