"""The forced van der Pol oscillator of scenes/van_der_pol.yaml as a model, x'' - mu (1 - x^2) x' + x = F cos(w t).

The linear part ``-mu x'`` is a negative damping, ``+ mu x^2 x'`` the nonlinear force; shared by the tests of
its quasi-periodic harmonic balance (tests/hb) and of its invariant circles (tests/timedomain).
"""

from contin.api.system import System

MU, F = 0.1, 0.15


def vdp_model(F=F, w=0.8, mu=MU):
    """The model, with the forcing amplitude ``F``, the frequency parameter's value ``w`` and ``mu`` (``-MU``:
    the same motions run backwards in time, velocities reversed)."""
    return System(dofs=["x"], parameters={"mu": mu, "F": F, "w": w}, mass=[[1]], damping=[["-mu"]],
                  stiffness=[[1]], forces=[{"dof": "x", "expr": "mu*x**2*x_dot"}],
                  excitation=[{"dof": "x", "expr": "F*cos(tau)"}], frequency="w").model


#: the flow's Neimark-Sacker point (1024 RK4 steps a period), where |mu| = 1 +- 1e-6
W_NS = 0.9512494581


def vdp_circle_branch(low: float = 0.9, points: int = 21):
    """The branch of invariant circles (1024 RK4 steps a period) from the flow's Neimark-Sacker point down to
    ``low``: ``(problem, branch)``."""
    import numpy as np

    from contin.bifurcation.circle_branch import follow_circle
    from contin.engine.continuation import ContinuationOptions
    from contin.timedomain.invariant_circle import CircleOptions, circle_start
    from contin.timedomain.shooting import ShootingOptions, periodic_orbit
    from contin.timedomain.simulation import simulate

    run = simulate(vdp_model(), {"w": 0.96}, np.zeros(1), np.zeros(1), periods=300, steps_per_period=1024,
                   record_every=1024)
    opts = ShootingOptions(steps_per_period=1024)
    orbit = periodic_orbit(vdp_model(), {"w": 0.96}, run.section[-1], opts)
    orbit = periodic_orbit(vdp_model(), {"w": W_NS}, orbit.state, opts)
    prob, u0, tangent = circle_start(vdp_model(), "w", orbit.state, W_NS,
                                     options=CircleOptions(points=points, steps_per_period=1024), eps=0.02)
    return prob, follow_circle(prob, u0, W_NS, (low, 0.96), ContinuationOptions(ds=0.05), tangent=tangent)
