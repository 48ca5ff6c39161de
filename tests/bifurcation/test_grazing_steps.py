"""The step limits of a shooting branch through grazing corners (contin.bifurcation.grazing_steps)."""

from contin.bifurcation.grazing_steps import GRAZING_STALL, GRAZING_TURN, through_grazing
from contin.engine.options import ContinuationOptions


def test_the_limits_are_raised_to_the_grazing_ones_and_larger_ones_kept():
    low = through_grazing(ContinuationOptions(ds=0.01, max_angle_deg=20.0, stall_points=50))
    assert (low.max_angle_deg, low.stall_points, low.ds) == (GRAZING_TURN, GRAZING_STALL, 0.01)
    high = through_grazing(ContinuationOptions(max_angle_deg=89.0, stall_points=500))
    assert (high.max_angle_deg, high.stall_points) == (89.0, 500)


def test_a_locked_toruss_orbit_branch_takes_the_engines_ds_min_and_with_contacts_the_grazing_limits():
    from contin.bifurcation.diagram import _orbit_options

    class Smooth:
        n_switch = 0

    class Contact:
        n_switch = 1

    torus = ContinuationOptions(ds=0.02, ds_max=0.02, ds_min=1e-3, newton_tol=1e-8)
    smooth, contact = _orbit_options(torus, Smooth()), _orbit_options(torus, Contact())
    assert smooth.ds_min == ContinuationOptions().ds_min and smooth.max_angle_deg == torus.max_angle_deg
    assert contact.ds_min == ContinuationOptions().ds_min and contact.max_angle_deg == GRAZING_TURN
    assert contact.ds_max == 0.02 and contact.newton_tol == 1e-8  # the rest as the torus start set them
