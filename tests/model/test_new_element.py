"""A contact law defined outside the package runs end to end: scene, harmonic balance, time simulation.

The element is defined here, in the test file, as a user would in a file of
their own: a preloaded stop with contact damping between two dofs (a spring
held compressed by ``F0`` between two bodies, closing once their relative
displacement ``r = x_a - x_b`` passes the clearance ``g``):

    F = F0 + k (r - g) + c r'   while r > g (F on a, -F on b),   0 otherwise.

The force jumps by ``F0 + c r'`` on the surface. Nothing in the package is
changed for it: the registry gives the scene its keys and the time
simulation its compiled form.
"""

import numpy as np
import pytest
from conftest import fd_jacobian

from contin.bifurcation.start import simulation_start
from contin.engine.newton import solve_at_parameter
from contin.hb.crossings import series_at
from contin.hb.harmonics import coefficient_blocks
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.model.base import FORCE_ELEMENTS, ForceElement, Switching, register_force
from contin.model.elements.registry import CompiledForm, SceneKeys, item_label, shorten
from contin.scene.build import build_model
from contin.scene.parse import SceneError, parse_scene
from contin.timedomain.simulation import compile_model, simulate

KIND = "preloaded_coupling_stop"


class PreloadedCouplingStop(ForceElement):
    """``F0 + k (r - g) + c r'`` between dofs ``a`` and ``b`` while ``r = x_a - x_b > g``."""

    degree = None

    def __init__(self, a, b, clearance, stiffness, damping, preload, label=KIND):
        self.a, self.b, self.label = a, b, label
        self.coefficients = (clearance, stiffness, damping, preload)

    def _values(self, p):
        return tuple(c.value(p) for c in self.coefficients)  # g, k, c, F0

    def _relative(self, x, xd):
        return x[:, self.a] - x[:, self.b], xd[:, self.a] - xd[:, self.b]

    def _pair(self, n):
        """``e_a - e_b``, shape (n,): how the force and the relative motion sit on the dofs."""
        e = np.zeros(n)
        e[self.a], e[self.b] = 1.0, -1.0
        return e

    def evaluate(self, x, xd, tau, p, f, dfdx, dfdxd):
        g, k, c, F0 = self._values(p)
        r, v = self._relative(x, xd)
        on = r - g > 0.0
        e = self._pair(x.shape[1])
        f[on] += (F0 + k * (r[on] - g) + c * v[on])[:, None] * e
        dfdx[on] += k * np.outer(e, e)
        dfdxd[on] += c * np.outer(e, e)

    def evaluate_dp(self, x, xd, tau, p, j, dfdp):
        g, k, c, F0 = self._values(p)
        r, v = self._relative(x, xd)
        on = r - g > 0.0
        dg, dk, dc, dF0 = (q.derivative(p, j) for q in self.coefficients)
        dfdp[on] += (-k * dg + (r[on] - g) * dk + v[on] * dc + dF0)[:, None] * self._pair(x.shape[1])

    def depends_on(self, j):
        return any(q.depends_on(j) for q in self.coefficients)

    def active_dofs(self):
        return tuple(sorted((self.a, self.b)))

    def switching_functions(self, x, xd, tau, p):
        g, k, c, F0 = self._values(p)
        N, n = x.shape
        r, v = self._relative(x, xd)
        e = self._pair(n)
        law = F0 + k * (r - g) + c * v
        return Switching(value=(r - g)[:, None], grad_x=np.broadcast_to(e, (N, 1, n)).copy(),
                         grad_xd=np.zeros((N, 1, n)), difference=(law[:, None] * e)[:, None, :],
                         jump=((F0 + c * v)[:, None] * e)[:, None, :],
                         difference_x=np.broadcast_to(k * np.outer(e, e), (N, 1, n, n)).copy(),
                         difference_xd=np.broadcast_to(c * np.outer(e, e), (N, 1, n, n)).copy())

    def switching_dp(self, x, xd, tau, p, j):
        g, k, c, F0 = self._values(p)
        r, v = self._relative(x, xd)
        dg, dk, dc, dF0 = (q.derivative(p, j) for q in self.coefficients)
        dlaw = -k * dg + (r - g) * dk + v * dc + dF0
        return np.full((x.shape[0], 1), -dg), (dlaw[:, None] * self._pair(x.shape[1]))[:, None, :]

    scene_keys = (SceneKeys({"type": True, "dofs": True, "clearance": True, "stiffness": True, "damping": False,
                             "preload": True},
                            example=f"{{type: {KIND}, dofs: [x, y], clearance: 0.4, stiffness: 15, preload: 0.4}}"),)

    @classmethod
    def from_scene(cls, item, key, scene):
        dofs = item["dofs"]
        if not isinstance(dofs, list) or len(dofs) != 2:
            raise scene.error(f"{key}.dofs", "a list of two dof names [A, B]", shorten(dofs))
        a, b = (scene.dof(d, f"{key}.dofs[{i}]") for i, d in enumerate(dofs))
        if a == b:
            raise scene.error(f"{key}.dofs", "two different dofs", dofs)
        coefficients = []
        for name in ("clearance", "stiffness", "damping", "preload"):
            value = item.get(name, 0.0)
            q = scene.coefficient(value, f"{key}.{name}")
            if q.value(scene.p0) < 0:
                raise scene.error(f"{key}.{name}", f"a {name} >= 0 at the default parameters", shorten(value))
            coefficients.append(q)
        return cls(a, b, *coefficients, label=item_label(key))

    def compiled_form(self):
        return PreloadedCouplingStopForm(self)


class PreloadedCouplingStopForm(CompiledForm):
    n_switch = 1

    def constants(self, p):
        return list(self.element._values(p))

    def force_lines(self, tag, c, m):
        a, b = self.element.a, self.element.b
        return [f"if mode[{m}] != 0:",
                f"    {tag}F = cst[{c + 3}] + cst[{c + 1}] * (X[0, {a}] - X[0, {b}] - cst[{c}]) "
                f"+ cst[{c + 2}] * (V[0, {a}] - V[0, {b}])",
                f"    F[0, {a}] += {tag}F",
                f"    F[0, {b}] -= {tag}F"]

    def switch_lines(self, tag, c, m):
        a, b = self.element.a, self.element.b
        return [f"S[{m}] = X[0, {a}] - X[0, {b}] - cst[{c}]"]

    def contact_matrices(self, p, n):
        g, k, c, _ = self.element._values(p)
        e = self.element._pair(n)
        return k * np.outer(e, e), c * np.outer(e, e)


SCENE = f"""
model:
  dofs: [x, y]
  parameters: {{c: 0.05, F: 0.5, w: 1.2, g: 0.3, k: 10.0, cs: 0.2, F0: 0.3}}
  mass: [[1, 0], [0, 2]]
  damping: [[c, 0], [0, c]]
  stiffness: [[2, -1], [-1, 2]]
  forces:
    - {{dof: x, expr: "0.1*x**3"}}
    - {{type: {KIND}, dofs: [x, y], clearance: g, stiffness: k, damping: cs, preload: F0}}
  excitation: [{{dof: x, amplitude: F}}]
analysis: {{type: frequency_response, parameter: w, range: [1.0, 1.4], harmonics: 12}}
"""
W0 = 1.2


@pytest.fixture(scope="module")
def model():
    """The scene's model, with the element registered for this module only."""
    register_force(KIND)(PreloadedCouplingStop)
    try:
        yield build_model(parse_scene(SCENE))
    finally:
        FORCE_ELEMENTS.pop(KIND)


@pytest.fixture(scope="module")
def orbit(model):
    """``(hb, u)``: the harmonic-balance solution at ``w = W0``, started from a time simulation."""
    hb = HarmonicBalance(model, "w", HBOptions(harmonics=12))
    return hb, simulation_start(hb, W0, transient=150, steps_per_period=512)


def test_a_scene_builds_the_element_through_the_registry(model):
    el = model.forces[-1]
    assert isinstance(el, PreloadedCouplingStop) and el.kind == KIND
    assert (el.a, el.b) == (0, 1) and el.label == "forces[1]"
    assert model.effects == ("mass", "damping", "stiffness", "expr", KIND, "excitation")
    p = model.parameter_vector()
    assert [q.value(p) for q in el.coefficients] == [0.3, 10.0, 0.2, 0.3]


@pytest.mark.parametrize("change,key,message", [
    ("preload: F0}", "}", r"model\.forces\[1\]\.preload.*a value for 'preload'"),
    ("preload: F0}", "preload: F0, sides: both}", r"model\.forces\[1\]\.sides.*unknown key 'sides'"),
    ("preload: F0}", "preload: -F0}", r"model\.forces\[1\]\.preload.*a preload >= 0"),
    ("dofs: [x, y], clearance", "dofs: [x, x], clearance", r"model\.forces\[1\]\.dofs\b.*two different dofs"),
    ("dofs: [x, y], clearance", "dofs: [x, z], clearance", r"model\.forces\[1\]\.dofs\[1\].*one of x, y"),
    (f"type: {KIND}", "type: preloaded_coupling_stp", rf"model\.forces\[1\]\.type.*did you mean '{KIND}'"),
])
def test_its_scene_keys_are_checked(model, change, key, message):
    with pytest.raises(SceneError, match=message):
        build_model(parse_scene(SCENE.replace(change, key)))


def test_its_switching_data_is_its_law(model, rng):
    el = model.forces[-1]
    p = model.parameter_vector()
    x, xd = rng.normal(scale=0.6, size=(50, 2)), rng.normal(size=(50, 2))
    tau = np.zeros(50)
    f, dfdx, dfdxd = np.zeros((50, 2)), np.zeros((50, 2, 2)), np.zeros((50, 2, 2))
    el.evaluate(x, xd, tau, p, f, dfdx, dfdxd)
    sw = el.switching_functions(x, xd, tau, p)
    on = sw.value[:, 0] > 0
    assert 10 < on.sum() < 40
    np.testing.assert_array_equal(f[on], sw.difference[on, 0])
    np.testing.assert_array_equal(f[~on], 0.0)
    np.testing.assert_array_equal(dfdx[on], sw.difference_x[on, 0])
    np.testing.assert_array_equal(dfdxd[on], sw.difference_xd[on, 0])
    j = model.parameter_index("F0")
    dfdp = np.zeros((50, 2))
    el.evaluate_dp(x, xd, tau, p, j, dfdp)
    np.testing.assert_array_equal(dfdp[on], el.switching_dp(x, xd, tau, p, j)[1][on, 0])


def test_harmonic_balance_jacobians_equal_finite_differences(orbit):
    hb, u = orbit
    R, J, Jw = hb.linearize(u, W0)
    assert np.abs(R).max() < 1e-9
    laws = [law for _, _, law in hb._laws]
    assert laws and sum(law.quad.starts.size for law in laws) >= 1  # the orbit opens and closes the stop
    Jfd = fd_jacobian(lambda v: hb.residual(v, W0), u)
    Jwfd = fd_jacobian(lambda v: hb.residual(u, v[0]), np.array([W0]))[:, 0]
    assert np.abs(J - Jfd).max() < 1e-7 * np.abs(J).max()
    assert np.abs(Jw - Jwfd).max() < 1e-7 * np.abs(Jw).max()
    # in a parameter of the law (through its switching_dp)
    hb_F0 = HarmonicBalance(hb.model, "F0", HBOptions(harmonics=12))  # at the model's w = W0
    F0 = hb_F0.p0[hb_F0.k]
    _, _, Jp = hb_F0.linearize(u, F0)
    Jpfd = fd_jacobian(lambda v: hb_F0.residual(u, v[0]), np.array([F0]))[:, 0]
    assert np.abs(Jp - Jpfd).max() < 1e-7 * np.abs(Jp).max()


def test_the_compiled_right_hand_side_is_the_law(model, rng):
    cm = compile_model(model)
    assert cm.n_switch == 1
    p = model.parameter_vector()
    M, C, K = model.linear(p)
    for _ in range(20):
        x, v, tau = rng.normal(scale=0.6, size=2), rng.normal(size=2), rng.uniform(0, 2 * np.pi)
        f, fe = np.zeros((1, 2)), np.zeros((1, 2))
        for el in model.forces:
            el.evaluate(x[None], v[None], np.array([tau]), p, f, np.zeros((1, 2, 2)), np.zeros((1, 2, 2)))
        for el in model.excitations:
            el.evaluate(np.array([tau]), p, fe)
        want = np.concatenate([v, np.linalg.solve(M, fe[0] - C @ v - K @ x - f[0])])
        np.testing.assert_allclose(cm.rhs(np.concatenate([x, v]), tau, p), want, rtol=1e-12, atol=1e-12)


def test_time_simulation_agrees_with_the_harmonic_balance_orbit(model, orbit):
    hb, u = orbit
    U = coefficient_blocks(u, model.n_dof)
    z, dz, _ = series_at(U, np.array([0.0]))
    run = simulate(model, {"w": W0}, z[0], W0 * dz[0], periods=40, steps_per_period=2048, record_from=39)
    assert run.events >= 2 * 40 and run.unresolved_events == 0
    x_hb, _, _ = series_at(U, W0 * run.t)
    # the truncation of the series (12 harmonics of a law that jumps) bounds the agreement ...
    scale = np.abs(x_hb).max()
    error = np.abs(run.x - x_hb).max()
    assert error < 2e-3 * scale
    # ... and twice as many harmonics bring the orbit closer to the simulation
    hb24 = hb.with_options(harmonics=24)
    u24 = np.zeros(hb24.size)
    u24[:u.size] = u
    res = solve_at_parameter(hb24, u24, W0)
    assert res.converged
    x24, _, _ = series_at(coefficient_blocks(res.x, model.n_dof), W0 * run.t)
    assert np.abs(run.x - x24).max() < error / 4
