"""A fold of a torus turned by size steps (contin.bifurcation.circle_fold, circle_steps, circle_natural).

The model is a forced linear oscillator beside an uncoupled self-excited one,

    x'' + 0.1 x' + x = F cos(w t),      y'' - mu (a + y^2 - y^4) y' + y = 0,

whose tori are the forced orbit times a limit cycle of ``y``: the invariant circle of the map over one
forcing period is that cycle at the forced orbit's state, turned by ``rho = T / T_c`` (``T_c`` the cycle's
period). The large stable cycle and the small unstable one are born together at a fold of cycles in ``a``
(``a = -1/8``, ``y`` amplitude 1 by averaging), and the small one shrinks onto ``y = 0`` at the Hopf point
``a = 0``. The fold, the rotation numbers and the Hopf point come from scipy alone (``solve_ivp`` of the
``y`` equation and root finding on its return map), the circles from contin's integrator.
"""

import copy
import json
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq, minimize_scalar

from contin.api.system import System
from contin.bifurcation import circle_natural, circle_steps
from contin.bifurcation.circle_branch import circle_child_start
from contin.bifurcation.circle_fold import circle_size, fold_vertex, scaled, shape_direction
from contin.bifurcation.circle_natural import follow_circle_steps
from contin.bifurcation.circle_steps import step_circle
from contin.engine.branch import BranchStatus, SpecialKind
from contin.engine.newton import NewtonResult
from contin.engine.options import ContinuationOptions
from contin.output.checkpoint import decode, encode
from contin.timedomain.invariant_circle import CircleOptions, InvariantCircleProblem
from contin.timedomain.shooting import ShootingOptions, ShootingProblem, periodic_orbit

MU, W, F, A0 = 0.2, 1.3, 0.5, -0.1
DOWN = ContinuationOptions(ds=0.01, ds_max=0.01, ds_min=1e-4, direction=-1, newton_tol=1e-10, locate_tol=1e-9)


def _model(a=A0):
    return System(dofs=["x", "y"], parameters={"a": a, "mu": MU, "F": F, "w": W}, mass=[[1, 0], [0, 1]],
                  damping=[[0.1, 0], [0, 0]], stiffness=[[1, 0], [0, 1]],
                  forces=[{"dof": "y", "expr": "-mu*(a + y**2 - y**4)*y_dot"}],
                  excitation=[{"dof": "x", "expr": "F*cos(tau)"}], frequency="w").model


def _cycle_rhs(t, z, a):
    y, v = z
    return [v, -y + MU * (a + y * y - y ** 4) * v]


def _return(A, a):
    """From the maximum ``y = A``: the next maximum's value and the time to it (scipy)."""
    def top(t, z, a):
        return z[1]
    top.direction = -1
    sol = solve_ivp(_cycle_rhs, (0.0, 7.5), [A, 0.0], args=(a,), events=top, rtol=1e-12, atol=1e-13)
    k = int(np.argmax(sol.t_events[0] > 1.0))
    return float(sol.y_events[0][k][0]), float(sol.t_events[0][k])


def _cycle(a, lo, hi):
    """The cycle's amplitude in ``(lo, hi)`` and its period at ``a`` (scipy)."""
    A = brentq(lambda A: _return(A, a)[0] - A, lo, hi, xtol=1e-14)
    return A, _return(A, a)[1]


@pytest.fixture(scope="module")
def fold_a():
    """The fold of cycles: the least ``a`` at which a cycle exists (scipy: the minimum over the amplitude of the
    ``a`` whose cycle has that amplitude)."""
    r = minimize_scalar(lambda A: brentq(lambda a: _return(A, a)[0] - A, -0.3, 0.0, xtol=1e-14),
                        bounds=(0.9, 1.1), method="bounded", options={"xatol": 1e-5})
    return float(r.fun)


@pytest.fixture(scope="module")
def start():
    """The circle of 15 points at a = -0.1 on the large cycle (256 RK4 steps a period), and its problem."""
    N = 15
    A, Tc = _cycle(A0, 1.05, 1.5)
    sol = solve_ivp(_cycle_rhs, (0.0, Tc), [A, 0.0], args=(A0,), rtol=1e-12, atol=1e-13, dense_output=True)
    Y = sol.sol(Tc * np.arange(N) / N).T
    X = F / (1 - W ** 2 + 0.1j * W)  # the forced orbit x = Re(X exp(i w t)) at t = 0
    U0 = np.column_stack([np.full(N, X.real), Y[:, 0], np.full(N, -W * X.imag), Y[:, 1]])
    prob = InvariantCircleProblem(_model(), "a", options=CircleOptions(points=N, steps_per_period=256))
    prob.set_anchor(U0)
    rho = (2 * math.pi / W / Tc) % 1.0
    return prob, prob.solve(prob.unknowns(U0, rho), A0, tol=1e-10, max_iter=8)


@pytest.fixture(scope="module")
def turned(start):
    prob, u = start
    return follow_circle_steps(prob, u, A0, (-0.2, 0.05), DOWN)


def test_the_size_direction_measures_a_circle_scaled_about_its_centre(start):
    prob, u = start
    d = shape_direction(prob, u)
    U = prob.blocks(u)[0]
    assert np.sum(U * d) == pytest.approx(1.0, abs=1e-14) and np.abs(d.sum(axis=0)).max() < 1e-14
    for delta in (-0.3, 0.01, 0.25):
        x = scaled(prob, np.r_[u, A0], delta)
        V = x[:-2].reshape(U.shape)
        assert np.sum(V * d) == pytest.approx(1.0 + delta, abs=1e-13)
        assert circle_size(prob, x[:-1]) == pytest.approx((1.0 + delta) * circle_size(prob, u), rel=1e-13)
        assert x[-2] == u[-1] and x[-1] == A0  # rho and the parameter as they were
    # the vertex of a parabola through three of its points
    assert fold_vertex([0.0, 1.0, 3.0], [(s - 1.3) ** 2 + 5 for s in (0.0, 1.0, 3.0)]) == pytest.approx(1.3)
    assert math.isnan(fold_vertex([0.0, 1.0, 2.0], [1.0, 2.0, 3.0]))


def test_the_steps_turn_at_the_fold_of_cycles_and_end_at_the_hopf_point(turned, fold_a):
    br = turned
    folds = [sp for sp in br.special_points if sp.kind is SpecialKind.FOLD]
    assert len(folds) == 1 and folds[0].located and "fold of the torus" in folds[0].message
    assert folds[0].parameter == pytest.approx(fold_a, abs=1e-8)  # scipy's fold of cycles
    lo, hi = folds[0].interval
    assert lo <= folds[0].parameter <= hi and hi - lo <= 1e-8
    # down to the fold, then up: the parameter turns once, at the stored circle nearest the fold
    i = folds[0].index
    lam = br.parameter
    assert np.all(np.diff(lam[:i + 1]) < 0) and np.all(np.diff(lam[i:]) > 0)
    assert abs(lam[i] - fold_a) < 1e-4
    # the circle's size falls all along: the large cycle, the fold, the small cycle shrinking to the Hopf point
    assert np.all(np.diff(br.point_data["circle_spread"]) < 0)
    assert br.status is BranchStatus.BOUNDARY and "collapses onto a periodic orbit" in br.message
    assert br.info["end"] == "collapse"  # where the torus is born: an end as asked, no shortfall
    ns = [sp for sp in br.special_points if sp.kind is SpecialKind.NS]
    assert len(ns) == 1 and abs(ns[0].parameter) < 2e-4  # the y oscillator's Hopf point, a = 0


def test_every_circle_solves_and_turns_as_scipys_cycle_does(start, turned):
    prob, _ = start
    br = turned
    i_fold = next(sp.index for sp in br.special_points if sp.kind is SpecialKind.FOLD)
    for k in range(len(br)):
        assert np.abs(prob.residual(br.unknowns[k], br.parameter[k])).max() < 1e-9
    # rho = T / T_c on both halves: the large cycle before the fold, the small one after it
    for k in (1, i_fold + 4, len(br) - 4):
        a = float(br.parameter[k])
        _, Tc = _cycle(a, 0.05, 0.99) if k > i_fold else _cycle(a, 1.0, 1.6)
        assert br.unknowns[k][-1] % 1.0 == pytest.approx((2 * math.pi / W / Tc) % 1.0, abs=1e-6)


def test_without_the_ranges_other_end_the_steps_end_at_the_fold(start, fold_a):
    prob, u = start
    plain = step_circle(prob, u, A0, -0.01, -0.2, min_step=1e-4)
    assert not plain.reached and plain.folds == [] and "failed at every step" in plain.message
    assert "fixed size" not in plain.message and fold_a < plain.parameter[-1] < fold_a + 1e-3
    both = step_circle(prob, u, A0, -0.01, -0.2, min_step=1e-4, turn_to=0.05,
                       options=ContinuationOptions(newton_tol=1e-10, newton_max_iter=20, locate_tol=1e-9))
    assert len(both.folds) == 1 and both.folds[0]["lam"] == pytest.approx(fold_a, abs=1e-8)
    assert both.parameter[both.folds[0]["index"]] == pytest.approx(fold_a, abs=1e-4)


def test_a_pass_that_finds_nothing_ends_the_steps_and_says_so(start, monkeypatch):
    prob, u = start

    def no_circle(problem, x_from, delta, guess, options, **kw):
        return NewtonResult(x=np.array(guess, dtype=float), converged=False, iterations=1, residual_norm=1.0,
                            message="residual 1.0e+00 after 1 iterations")

    monkeypatch.setattr(circle_steps, "size_step", no_circle)
    br = follow_circle_steps(prob, u, A0, (-0.2, 0.05), DOWN)
    assert br.status is BranchStatus.STEP_TOO_SMALL
    assert "and steps at a fixed size of the circle from there found neither a fold nor a way past" in br.message
    assert not [sp for sp in br.special_points if sp.kind is SpecialKind.FOLD]
    # the branch ends where the steps in a failed, above the fold: nothing of the pass is kept
    assert br.parameter[-1] > -0.125 and np.all(np.diff(br.parameter) < 0)


class _Killed(Exception):
    pass


def test_a_branch_interrupted_during_the_size_steps_goes_on_to_the_same_circles(start, turned):
    """The circles of a pass of size steps are stored together once it has turned the fold, and the checkpoint
    follows the last: a run killed among them resumes from before the pass, and takes it again whole."""
    prob, u = start
    held = {}

    def checkpoint(branch, state):
        held.update(branch=copy.deepcopy(branch), state=decode(json.loads(json.dumps(encode(state)))))

    def callback(branch, i):  # killed at the second circle of a pass (stored with no checkpoint between)
        if "branch" in held and len(branch) >= len(held["branch"]) + 2:
            raise _Killed

    with pytest.raises(_Killed):
        follow_circle_steps(prob, u, A0, (-0.2, 0.05), DOWN, checkpoint=checkpoint, callback=callback)
    previous = held["branch"]
    assert not [sp for sp in previous.special_points if sp.kind is SpecialKind.FOLD]  # from before the pass
    previous.status = BranchStatus.INTERRUPTED
    previous.info["restart"] = held["state"]
    resumed = follow_circle_steps(prob, u, A0, (-0.2, 0.05), DOWN, previous=previous)
    assert len(resumed) == len(turned) and resumed.status is turned.status
    np.testing.assert_array_equal(resumed.parameter, turned.parameter)
    np.testing.assert_array_equal(resumed.unknowns, turned.unknowns)
    assert [(sp.kind, sp.parameter) for sp in resumed.special_points] == \
        [(sp.kind, sp.parameter) for sp in turned.special_points]


@pytest.fixture(scope="module")
def born():
    """The first guess of the torus born at the forced orbit's Neimark-Sacker point ``a = 0`` (the ``y``
    oscillator's Hopf point; the orbit by shooting, 256 RK4 steps a period)."""
    opts = ShootingOptions(steps_per_period=256)
    X = F / (1 - W ** 2 + 0.1j * W)
    orbit = periodic_orbit(_model(0.0), {"a": 0.0}, np.array([X.real, 0.0, -W * X.imag, 0.0]), opts)
    assert orbit.converged
    return circle_child_start(ShootingProblem(_model(0.0), "a", options=opts), 0.0, orbit.state, 15)


#: the way a grown torus goes is found by its growth, whatever the options' direction says
GROWN = DOWN.replace(direction=1)


def test_a_torus_grown_from_its_neimark_sacker_point_turns_at_the_fold(fold_a, born):
    """The torus born at ``a = 0`` is the small cycle, on the side ``a < 0`` (a subcritical birth). Grown by size
    steps from the point's first guess, it goes down in ``a``, turns at scipy's fold of cycles and goes up on the
    large cycle to the range's end."""
    st = born
    br = follow_circle_steps(st.problem, st.u, st.lam, (-0.2, 0.05), GROWN, grow=True)
    assert br.status is BranchStatus.RANGE_END and br.parameter[-1] == pytest.approx(0.05, abs=1e-14)
    i = int(np.argmin(br.parameter))
    assert -1e-3 < br.parameter[0] < 0.0 and np.all(np.diff(br.parameter[:i + 1]) < 0)
    assert np.all(np.diff(br.parameter[i:]) > 0) and np.all(np.diff(br.point_data["circle_spread"]) > 0)
    folds = [sp for sp in br.special_points if sp.kind is SpecialKind.FOLD]
    assert len(folds) == 1 and folds[0].parameter == pytest.approx(fold_a, abs=1e-8)
    for k in range(len(br)):
        assert np.abs(st.problem.residual(br.unknowns[k], br.parameter[k])).max() < 1e-9
    # the large cycle at the range's end, against scipy: its period sets rho (the circle born at the point runs
    # round it the other way: -T / T_c)
    _, Tc = _cycle(0.05, 1.0, 1.8)
    assert (-br.unknowns[-1][-1]) % 1.0 == pytest.approx((2 * math.pi / W / Tc) % 1.0, abs=1e-6)


def test_a_grown_torus_interrupted_while_it_grows_goes_on_to_the_same_circles(born):
    st = born
    ref = follow_circle_steps(st.problem, st.u, st.lam, (-0.2, 0.05), GROWN, grow=True)
    held = {}

    def checkpoint(branch, state):
        if state.get("natural", {}).get("mode") == "grow" and len(branch) == 3:
            held.update(branch=branch, state=decode(json.loads(json.dumps(encode(state)))))
            raise _Killed

    with pytest.raises(_Killed):
        follow_circle_steps(st.problem, st.u, st.lam, (-0.2, 0.05), GROWN, grow=True, checkpoint=checkpoint)
    previous = held["branch"]
    previous.status = BranchStatus.INTERRUPTED
    previous.info["restart"] = held["state"]
    again = follow_circle_steps(st.problem, st.u, st.lam, (-0.2, 0.05), GROWN, grow=True, previous=previous)
    assert again.status is ref.status and len(again) == len(ref)
    np.testing.assert_array_equal(again.parameter, ref.parameter)
    np.testing.assert_array_equal(again.unknowns, ref.unknowns)


def test_a_step_in_the_parameter_whose_stability_flips_is_refused_and_taken_shorter(start, turned):
    """Near a fold both halves of the torus exist on one side, and a step in the parameter may land on the other
    half: its circle's verdict differs from the last one's. Such a circle is not stored; the step is retried
    shorter (here a monitor says unstable once, for the first circle below a = -0.115)."""
    prob, u = start
    flipped = []

    def verdict(u, lam, Ju=None, Jlam=None):
        flip = lam < -0.115 and not flipped
        if flip:
            flipped.append(lam)
        return {"evaluated": True, "stable": not flip}

    br = follow_circle_steps(prob, u, A0, (-0.2, 0.05), DOWN, monitors=[verdict])
    assert len(flipped) == 1 and flipped[0] not in list(br.parameter)
    assert all(br.point_data["stable"]) and br.status is turned.status
    assert br.info["n_rejected_steps"] > turned.info["n_rejected_steps"]
    assert not [sp for sp in br.special_points if sp.kind is SpecialKind.STABILITY]


def test_an_undecided_step_that_leaps_onto_the_other_half_is_refused(born, monkeypatch):
    """Near a fold neither half's exponent is decisive, so a step landing on the other half is told by where it
    lands: far off its predictor's line, its exponent across zero from the last decisive verdict. Here the
    first step below a = -0.1 is sent to the large cycle (its guess scaled about the centre); refused, the
    steps go down the small cycle to the fold and up the large one. Without the refusal the branch jumps
    there, turns at the fold and walks back down the small cycle to the Hopf point."""
    st = born

    def amplitude(u):
        return float(st.problem.blocks(u)[0][:, 1].max())

    def verdict(u, lam, Ju=None, Jlam=None):
        e = 0.05 * (1.0 - amplitude(u))  # unstable inside, stable outside; decisive only far from the fold
        return {"evaluated": True, "stable": bool(e < 0), "normal_exponent": e,
                "normal_exponent_error": 1e-3 if amplitude(u) < 0.8 else 1.0}

    solve, sent = circle_steps.solve_at_parameter, []

    def leaping(problem, guess, lam, *args, **kwargs):
        if lam < -0.1 and not sent:
            U = st.problem.blocks(guess)[0].copy()
            c = U.mean(axis=0)
            U[:, [1, 3]] = c[[1, 3]] + 1.35 * (U[:, [1, 3]] - c[[1, 3]])
            guess = st.problem.unknowns(U, guess[-1])
            sent.append(lam)
        return solve(problem, guess, lam, *args, **kwargs)

    monkeypatch.setattr(circle_steps, "solve_at_parameter", leaping)
    opts = GROWN.replace(ds=0.02, ds_max=0.02, ds_min=1e-3)
    br = follow_circle_steps(st.problem, st.u, st.lam, (-0.2, 0.05), opts, grow=True, monitors=[verdict])
    assert len(sent) == 1 and br.status is BranchStatus.RANGE_END
    A = np.array([amplitude(u) for u in br.unknowns])
    i = int(np.argmin(br.parameter))
    assert np.all(np.diff(br.parameter[:i + 1]) < 0) and np.all(np.diff(br.parameter[i:]) > 0)
    assert np.all(np.diff(A) > 0)  # the small cycle down to the fold, the large one up from it

    sent.clear()
    monkeypatch.setattr(circle_natural, "LEAP", math.inf)
    jumped = follow_circle_steps(st.problem, st.u, st.lam, (-0.2, 0.05), opts, grow=True, monitors=[verdict])
    A = np.array([amplitude(u) for u in jumped.unknowns])
    assert len(sent) == 1 and np.any(np.diff(A) < 0) and jumped.parameter[-1] > -0.01


@pytest.mark.parametrize("step, reset", [(-0.005, True), (-0.002, False)])
def test_a_step_as_long_as_the_largest_allows_passes_again(start, step, reset):
    """The passes that went on the same way are counted (at a tongue's edge they would creep along it) until a
    step in the parameter as long as ``max_step`` shows the steps clear of the place."""
    prob, u = start
    stepper = circle_steps.CircleStepper(prob, u, A0, step, -0.2, min_step=1e-3, max_step=0.005,
                                         options=DOWN, turn_to=0.05)
    stepper.forward = circle_steps.FORWARD_PASSES
    assert stepper.attempt()
    assert stepper.forward == (0 if reset else circle_steps.FORWARD_PASSES)



class _Verdicts:
    """What :func:`contin.bifurcation.circle_natural._flips` reads of a branch: its length, the verdicts stored
    and the special points."""

    def __init__(self, special_points, stable, evaluated):
        n = len(stable)
        self.special_points = special_points
        self.point_data = {"stable": np.asarray(stable), "evaluated": np.asarray(evaluated),
                           "normal_exponent": np.where(stable, -0.1, 0.1), "normal_exponent_error": np.full(n, 1e-3)}

    def __len__(self):
        return len(self.point_data["stable"])


def test_verdicts_are_compared_since_the_last_fold_turned(turned):
    """Across a fold turned by size steps the stability changes as it should: a circle's verdict is compared
    with those stored since, not with the other half's."""
    from contin.bifurcation.circle_natural import _flips

    fold = next(sp.index for sp in turned.special_points if sp.event == "circle fold")
    before = np.arange(len(turned)) <= fold
    unstable = {"evaluated": True, "stable": False, "normal_exponent": 0.1, "normal_exponent_error": 1e-3}
    stable = {"evaluated": True, "stable": True, "normal_exponent": -0.1, "normal_exponent_error": 1e-3}
    br = _Verdicts(turned.special_points, before, np.ones(len(turned), bool))
    assert not _flips(br, unstable) and _flips(br, stable)  # the new half's verdicts are the reference
    only_old = _Verdicts(turned.special_points, before, before)
    assert not _flips(only_old, unstable) and not _flips(only_old, stable)  # none since the fold: no reference
    no_fold = _Verdicts([], before, before)
    assert _flips(no_fold, unstable)  # without a fold turned, the old half's verdicts are the reference
