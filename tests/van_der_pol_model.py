"""The forced van der Pol oscillator of scenes/van_der_pol.yaml as a model, x'' - mu (1 - x^2) x' + x = F cos(w t).

The linear part ``-mu x'`` is a negative damping, ``+ mu x^2 x'`` the nonlinear force; shared by the tests of
its quasi-periodic harmonic balance (tests/hb) and of its invariant circles (tests/timedomain).
"""

from contin.api.system import System

MU, F = 0.1, 0.15


def vdp_model(F=F, w=0.8):
    """The model, with the forcing amplitude ``F`` and the frequency parameter's value ``w``."""
    return System(dofs=["x"], parameters={"mu": MU, "F": F, "w": w}, mass=[[1]], damping=[["-mu"]],
                  stiffness=[[1]], forces=[{"dof": "x", "expr": "mu*x**2*x_dot"}],
                  excitation=[{"dof": "x", "expr": "F*cos(tau)"}], frequency="w").model
