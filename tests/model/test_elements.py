"""Force elements: values against closed forms, Jacobians against finite differences."""

import numpy as np
import pytest

from contin.model.elements import GapForce, PolynomialForce, RadialGapForce
from contin.model.base import Monomial


def evaluate(el, x, xd, tau, p):
    N, n = x.shape
    f = np.zeros((N, n))
    dfdx = np.zeros((N, n, n))
    dfdxd = np.zeros((N, n, n))
    el.evaluate(x, xd, tau, p, f, dfdx, dfdxd)
    return f, dfdx, dfdxd


def check_jacobians(el, x, xd, tau, p, eps=1e-7, params=()):
    f, dfdx, dfdxd = evaluate(el, x, xd, tau, p)
    N, n = x.shape
    for i in range(n):
        e = np.zeros((N, n))
        e[:, i] = eps
        fp = evaluate(el, x + e, xd, tau, p)[0]
        fm = evaluate(el, x - e, xd, tau, p)[0]
        np.testing.assert_allclose(dfdx[:, :, i], (fp - fm) / (2 * eps), atol=1e-5 * max(1, np.abs(dfdx).max()))
        fp = evaluate(el, x, xd + e, tau, p)[0]
        fm = evaluate(el, x, xd - e, tau, p)[0]
        np.testing.assert_allclose(dfdxd[:, :, i], (fp - fm) / (2 * eps), atol=1e-5 * max(1, np.abs(dfdxd).max()))
    for k in params:
        dfdp = np.zeros((N, n))
        el.evaluate_dp(x, xd, tau, p, k, dfdp)
        dp = np.zeros_like(p)
        dp[k] = eps
        ref = (evaluate(el, x, xd, tau, p + dp)[0] - evaluate(el, x, xd, tau, p - dp)[0]) / (2 * eps)
        np.testing.assert_allclose(dfdp, ref, atol=1e-5 * max(1, np.abs(ref).max()))
        assert el.depends_on(k)
    return f


def away_from(values, surface, margin):
    return np.abs(values - surface) > margin


def test_polynomial_force_with_parametric_factor(rng):
    el = PolynomialForce(2, [(0, Monomial(2.0, ((0, 1),)), [3, 0], [0, 0]),
                             (1, Monomial(0.5), [1, 1], [0, 2], 2.0, 0.3)])
    x = rng.normal(size=(9, 2))
    xd = rng.normal(size=(9, 2))
    tau = rng.uniform(0, 6, 9)
    p = np.array([1.7])
    f = check_jacobians(el, x, xd, tau, p, params=(0,))
    np.testing.assert_allclose(f[:, 0], 2 * 1.7 * x[:, 0] ** 3)
    np.testing.assert_allclose(f[:, 1], 0.5 * np.cos(2 * tau + 0.3) * x[:, 0] * x[:, 1] * xd[:, 1] ** 2)
    assert el.degree == 4 and el.tau_orders() == (2.0,)


@pytest.mark.parametrize("sides", ["+", "-", "both"])
@pytest.mark.parametrize("clip", [False, True])
def test_gap_force(sides, clip, rng):
    # parameters: g, k, c
    el = GapForce(0, Monomial(1.0, ((0, 1),)), Monomial(1.0, ((1, 1),)), Monomial(1.0, ((2, 1),)), sides, clip)
    p = np.array([0.1, 50.0, 0.7])
    x = rng.uniform(-0.5, 0.5, size=(200, 1))
    xd = rng.normal(size=(200, 1))
    keep = away_from(np.abs(x[:, 0]), 0.1, 1e-3)
    if clip:
        F = 50 * (x[:, 0] - np.sign(x[:, 0]) * 0.1) + 0.7 * xd[:, 0]
        keep &= np.abs(F) > 1e-3
    x, xd = x[keep], xd[keep]
    tau = np.zeros(len(x))
    f = check_jacobians(el, x, xd, tau, p, params=(0, 1, 2))
    up = x[:, 0] > 0.1
    lo = x[:, 0] < -0.1
    ref = np.zeros(len(x))
    if sides in ("+", "both"):
        ref[up] = 50 * (x[up, 0] - 0.1) + 0.7 * xd[up, 0]
    if sides in ("-", "both"):
        ref[lo] = 50 * (x[lo, 0] + 0.1) + 0.7 * xd[lo, 0]
    if clip:
        ref[np.sign(ref) != np.sign(x[:, 0])] = 0.0
    np.testing.assert_allclose(f[:, 0], ref, atol=1e-12)


@pytest.mark.parametrize("clip", [False, True])
def test_radial_gap_force_and_jacobian(clip, rng):
    el = RadialGapForce((1, 2), Monomial(1.0, ((0, 1),)), Monomial(1.0, ((1, 1),)), Monomial(1.0, ((2, 1),)), clip)
    p = np.array([0.1, 1000.0, 0.5])
    x = rng.uniform(-0.2, 0.2, size=(300, 3))
    xd = rng.normal(size=(300, 3))
    r = np.hypot(x[:, 1], x[:, 2])
    th = np.arctan2(x[:, 2], x[:, 1])
    Fn = 1000 * (r - 0.1) + 0.5 * (xd[:, 1] * np.cos(th) + xd[:, 2] * np.sin(th))
    keep = away_from(r, 0.1, 1e-3) & (~clip | (np.abs(Fn) > 1e-2))
    x, xd, r, th, Fn = x[keep], xd[keep], r[keep], th[keep], Fn[keep]
    f = check_jacobians(el, x, xd, np.zeros(len(x)), p, params=(0, 1, 2))
    on = (r >= 0.1) & ((Fn >= 0) if clip else True)
    np.testing.assert_allclose(f[:, 1], np.where(on, Fn * np.cos(th), 0.0), atol=1e-10)
    np.testing.assert_allclose(f[:, 2], np.where(on, Fn * np.sin(th), 0.0), atol=1e-10)
    assert not f[:, 0].any()


@pytest.mark.parametrize("text,const,powers", [
    ("g/2", 0.5, ((0, 1),)),
    ("-0.5*k*w**2", -0.5, ((1, 1), (2, 2))),
    ("k/w", 1.0, ((1, 1), (2, -1))),
    ("2*pi*k", 2 * np.pi, ((1, 1),)),
    (3, 3.0, ()),
])
def test_monomials_are_read_by_the_expression_parser(text, const, powers):
    """Coefficients are written as in a scene: quotients and pi too."""
    mono = Monomial.parse(text, ["g", "k", "w"])
    assert mono.powers == powers and mono.const == pytest.approx(const, rel=1e-15)


@pytest.mark.parametrize("text,message", [
    ("kk", r"unknown parameter 'kk'.*did you mean 'k'"),
    ("k + w", "found a sum"),
    ("k^2", r"'\^' is not allowed"),
])
def test_monomial_parse_names_what_is_wrong(text, message):
    with pytest.raises(ValueError, match=rf"^where: .*{message}"):
        Monomial.parse(text, ["g", "k", "w"], "where")


def test_every_built_in_element_has_a_compiled_form_and_its_scene_forms():
    """The core finds all of an element through the registry: its compiled form and its scene keys."""
    import contin.model.elements as elements
    from contin.model.base import ExcitationElement, ForceElement
    from contin.model.elements.registry import kinds_with_compiled_form, scene_forms

    classes = [getattr(elements, name) for name in elements.__all__]
    assert {cls.kind for cls in classes} <= set(kinds_with_compiled_form())
    forces = [k for k, (cls, _) in scene_forms("forces").items() if cls in classes]
    assert forces == ["expr", "gap", "radial_gap"]
    assert [k for k, (cls, _) in scene_forms("excitation").items() if cls in classes] == ["expr", "amplitude",
                                                                                            "constant"]
    assert [k for k, (_, keys) in scene_forms("forces").items() if keys.default] == ["expr"]
    for cls in classes:
        base = ForceElement if issubclass(cls, ForceElement) else ExcitationElement
        assert (cls.from_scene.__func__ is not base.from_scene.__func__) == bool(cls.scene_keys), cls
