"""A rotationally symmetric model seen in a frame turning with the speed ``w``: an autonomous model.

A rotor without side load, gravity or anisotropic supports is symmetric under
rotations of its cross-sections: written with ``z = x + i y`` for each pair of
lateral dofs ``(x, y)``, its equations keep their form when every ``z`` is
turned by one angle. In the frame turning with the unbalance,

    z(t) = exp(i w t) zeta(t),     in real form  x(t) = R(w t) zeta(t),  R(a) = exp(a J),

with ``J = [[0, -1], [1, 0]]`` on every pair, ``x' = R (zeta' + w J zeta)`` and
``x'' = R (zeta'' + 2 w J zeta' - w^2 zeta)``. If ``M``, ``C`` (damping and
gyroscopic terms) and ``K`` commute with ``J``, the equations
``M x'' + C x' + K x + f_nl = f_ext`` become

    M zeta'' + (C + 2 w M J) zeta' + (K + w C J - w^2 M) zeta + f_nl(zeta, zeta') = R(-w t) f_ext,

the Coriolis term ``2 w M J``, the centrifugal ``-w^2 M`` and the turned
damping ``w C J`` added to the linear part. A radial contact
(:class:`~contin.model.elements.radial_gap.RadialGapForce`) depends on the
radius and the radial speed only, and ``J zeta`` is normal to ``zeta``, so
``f_nl`` keeps its form. A forward-whirling unbalance
``A (cos(w t + phi), sin(w t + phi))`` becomes the constant
``A (cos phi, sin phi)``. Nothing in the new model depends on time: the forced
whirl is an equilibrium, a Neimark-Sacker point of the forced whirl is a Hopf
point and a torus born there is a periodic orbit of the rotating frame.

:func:`rotating_frame` builds that model from the fixed-frame one, reusing its
elements (so its compiled time-domain kernels, switches located): the same
parameters plus :data:`PERIOD_FREQUENCY`, the frequency ``2 pi / T_r`` whose
period the integrator's step grid spans (the model's ``frequency``; it sets
the step ``T_r / S`` and nothing else). A term that breaks the symmetry (a
constant or backward-whirling force, an anisotropic matrix, a force element
that is not a radial contact of a pair) is refused with its name.
:func:`to_fixed` and :func:`to_rotating` map states between the frames.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from contin.model.base import Model, Monomial, ParametricMatrix
from contin.model.elements.harmonic import HarmonicExcitation
from contin.model.elements.radial_gap import RadialGapForce

__all__ = ["PERIOD_FREQUENCY", "rotating_frame", "rotation_generator", "to_fixed", "to_rotating"]

#: the rotating-frame model's frequency parameter: ``2 pi / T_r``, the period the integrator's step grid spans
PERIOD_FREQUENCY = "wr"
#: relative size of a commutator ``[A, J]`` taken as zero (the matrices' own rounding)
SYMMETRY_TOL = 1e-12


def rotation_generator(n: int, pairs: Sequence[tuple[int, int]]) -> np.ndarray:
    """``J``: the generator of rotations of the pairs ``(x, y)`` of dofs, shape (n, n).

    ``J x`` turns each pair by a right angle, ``(x, y) -> (-y, x)``.
    """
    J = np.zeros((n, n))
    for ix, iy in pairs:
        J[ix, iy] = -1.0
        J[iy, ix] = 1.0
    return J


def _times(mono: Monomial, k: int, power: int, factor: float = 1.0) -> Monomial:
    """``factor * mono * p[k]**power``, powers of one parameter merged."""
    powers = dict(mono.powers)
    powers[k] = powers.get(k, 0) + power
    return Monomial(factor * mono.const, tuple(sorted((j, e) for j, e in powers.items() if e != 0)))


def _scaled(mat: ParametricMatrix, k: int, power: int, factor: float, right: np.ndarray | None = None):
    """``factor * p[k]**power * mat (@ right)`` as a :class:`ParametricMatrix`."""
    terms = tuple((_times(mono, k, power, factor), A @ right if right is not None else A.copy())
                  for mono, A in mat.terms)
    return ParametricMatrix(mat.n, terms)


def _check_pairs(model: Model, pairs) -> tuple:
    n = model.n_dof
    pairs = tuple((int(a), int(b)) for a, b in pairs)
    seen = [d for pair in pairs for d in pair]
    if not pairs or len(set(seen)) != len(seen) or any(not 0 <= d < n for d in seen):
        raise ValueError(f"rotating_frame: pairs must be disjoint (x, y) dof index pairs of model '{model.name}' "
                         f"({n} dofs), got {pairs}")
    if sorted(seen) != list(range(n)):
        missing = [model.dof_names[d] for d in range(n) if d not in seen]
        raise ValueError(f"rotating_frame: every dof must belong to a rotating pair; dofs {missing} of model "
                         f"'{model.name}' do not (a dof that does not turn with the others breaks the symmetry)")
    return pairs


def _check_matrices(model: Model, J: np.ndarray, p: np.ndarray) -> None:
    """Refuse matrices that do not commute with ``J`` (at ``p`` and at a perturbed parameter vector)."""
    rng = np.random.default_rng(7)
    for q in (p, p * (1.0 + 0.3 * rng.random(p.size)) + 0.1 * rng.random(p.size)):
        for label, A in zip(("mass", "damping", "stiffness"), model.linear(q)):
            comm = A @ J - J @ A
            if np.max(np.abs(comm)) > SYMMETRY_TOL * max(1.0, float(np.max(np.abs(A)))):
                raise ValueError(f"rotating_frame: the {label} matrix of model '{model.name}' is not rotationally "
                                 f"symmetric (it does not commute with the rotation of the dof pairs): no "
                                 f"rotating frame makes the model autonomous")


def _check_forces(model: Model, pairs) -> list:
    for el in model.forces:
        ok = isinstance(el, RadialGapForce) and (el.ix, el.iy) in pairs
        if not ok:
            kind = getattr(el, "kind", "") or type(el).__name__
            raise ValueError(f"rotating_frame: force element '{getattr(el, 'label', kind)}' ({kind}) of model "
                             f"'{model.name}' is not a radial contact of a rotating dof pair, so the rotation "
                             f"may change it; only radial_gap elements on the pairs {list(pairs)} keep their form")
    return list(model.forces)


def _excitations(model: Model, pairs, p: np.ndarray, kw: int):
    """The rotating-frame constants of the forward-whirling excitations; the parameters of vanishing ones."""
    names = model.param_names
    out, frozen, used = [], set(), set()
    by_dof = {}
    for i, el in enumerate(model.excitations):
        if not isinstance(el, HarmonicExcitation):
            kind = getattr(el, "kind", "") or type(el).__name__
            raise ValueError(f"rotating_frame: excitation '{getattr(el, 'label', kind)}' ({kind}) of model "
                             f"'{model.name}' is not a harmonic forcing; its form in the rotating frame is unknown")
        by_dof.setdefault(el.dof, []).append(i)
    for ix, iy in pairs:
        xs = [model.excitations[i] for i in by_dof.get(ix, [])]
        ys = [model.excitations[i] for i in by_dof.get(iy, [])]
        for el in xs + ys:
            if el.order != 0.0:
                continue
            if el.amplitude.value(p) * math.cos(el.phase) != 0.0:
                who = ", ".join(f"{names[j]} = {p[j]:g}" for j, _ in el.amplitude.powers) or "a constant"
                raise ValueError(f"rotating_frame: the constant force '{el.label}' on {model.dof_names[el.dof]} "
                                 f"({who}) breaks the rotational symmetry; the rotating frame needs it zero "
                                 f"(a side load f0 = 0)")
            # zero here, and it must stay zero: its parameters are frozen in the rotating model
            frozen.update(j for j, _ in el.amplitude.powers)
            used.add(id(el))
        for ex in xs:
            if id(ex) in used:
                continue
            mate = [ey for ey in ys if id(ey) not in used and ey.order == ex.order == 1.0
                    and ey.amplitude == ex.amplitude
                    and abs(math.remainder(ey.phase - (ex.phase - math.pi / 2), 2 * math.pi)) < 1e-12]
            if not mate:
                raise ValueError(f"rotating_frame: the forcing '{ex.label}' on {model.dof_names[ex.dof]} has no "
                                 f"forward-whirling partner of the same amplitude at order 1 on "
                                 f"{model.dof_names[iy]} (phase - pi/2): it does not turn with the frame")
            ey = mate[0]
            used.update((id(ex), id(ey)))
            # A cos(w t + phi) on x, A sin(w t + phi) on y: the constant A (cos phi, sin phi)
            for dof, phase in ((ix, ex.phase), (iy, ex.phase - math.pi / 2)):
                if abs(math.cos(phase)) > 1e-15:  # cos(-pi/2) is 6e-17, not zero: such a term is left out
                    out.append(HarmonicExcitation(dof, ex.amplitude, 0.0, phase, ex.label))
        for ey in ys:
            if id(ey) not in used:
                raise ValueError(f"rotating_frame: the forcing '{ey.label}' on {model.dof_names[ey.dof]} has no "
                                 f"forward-whirling partner on {model.dof_names[ix]}: it does not turn with the frame")
    return out, frozen


def rotating_frame(model: Model, pairs: Sequence[tuple[int, int]] | None = None) -> Model:
    """The autonomous model of a rotationally symmetric ``model`` in the frame turning with its speed.

    Parameters
    ----------
    model : Model
        A fixed-frame model whose frequency parameter ``w`` is the rotor speed.
    pairs : sequence of (int, int), optional
        The lateral dof pairs ``(x, y)`` (every dof in one pair); default
        consecutive pairs ``(0, 1), (2, 3), ...``.

    Returns
    -------
    Model
        Dofs ``zeta`` named as the model's with the suffix ``_r``; the same
        parameters and :data:`PERIOD_FREQUENCY` (value 1, the model's
        ``frequency``); ``M``, ``C + 2 w M J``, ``K + w C J - w^2 M`` (module
        docstring); the model's radial contacts; the forward whirl forcing as
        constants. Parameters whose value makes a symmetry-breaking force
        vanish (``f0 = 0``) are ``structural``: a run that sets them otherwise
        is refused (:meth:`Model.check_variable`).

    Raises
    ------
    ValueError
        Naming the term that breaks the symmetry: a constant force (the side
        load ``f0 != 0``), a forcing without a forward-whirling partner, a
        matrix that does not commute with the rotation, a force element that
        is not a radial contact of a pair, an odd dof count or a dof outside
        the pairs.
    """
    n = model.n_dof
    if pairs is None:
        if n % 2:
            raise ValueError(f"rotating_frame: model '{model.name}' has an odd number of dofs ({n}); give the "
                             f"(x, y) pairs")
        pairs = [(2 * k, 2 * k + 1) for k in range(n // 2)]
    pairs = _check_pairs(model, pairs)
    if PERIOD_FREQUENCY in model.parameters:
        raise ValueError(f"rotating_frame: model '{model.name}' already has a parameter '{PERIOD_FREQUENCY}'")
    kw = model.parameter_index(model.frequency)
    p = model.parameter_vector()
    J = rotation_generator(n, pairs)
    _check_matrices(model, J, p)
    forces = _check_forces(model, pairs)
    excitations, frozen = _excitations(model, pairs, p, kw)
    M, C, K = model.mass, model.damping, model.stiffness
    damping = C + _scaled(M, kw, 1, 2.0, J)
    stiffness = K + _scaled(C, kw, 1, 1.0, J) + _scaled(M, kw, 2, -1.0)
    params = dict(model.parameters)
    params[PERIOD_FREQUENCY] = 1.0
    names = model.param_names
    head = (f"rotating frame of '{model.name}' at the speed {model.frequency}: Coriolis 2 {model.frequency} M J, "
            f"centrifugal -{model.frequency}^2 M, turned damping {model.frequency} C J; autonomous")
    terms = [head, *model.terms]
    out = Model(
        name=f"{model.name}_rotating",
        dof_names=tuple(f"{d}_r" for d in model.dof_names),
        parameters=params,
        mass=ParametricMatrix(M.n, tuple((m, A.copy()) for m, A in M.terms)),
        damping=damping,
        stiffness=stiffness,
        forces=forces,
        excitations=excitations,
        frequency=PERIOD_FREQUENCY,
        effects=tuple(model.effects),
        terms=terms,
        structural=tuple(sorted(names[j] for j in frozen)),
        symbols=dict(model.symbols),
    )
    out.rotation = (pairs, model.frequency)  # what to_fixed / to_rotating need
    return out


def _rotation(model: Model):
    info = getattr(model, "rotation", None)
    if info is None:
        raise ValueError(f"model '{model.name}' is no rotating-frame model (built by rotating_frame)")
    return info


def to_fixed(model: Model, states, w: float, t) -> np.ndarray:
    """Fixed-frame states ``(x, x')`` of rotating-frame states ``(zeta, zeta')`` at times ``t``.

    ``x = R(w t) zeta``, ``x' = R(w t) (zeta' + w J zeta)``.

    Parameters
    ----------
    model : Model
        Built by :func:`rotating_frame`.
    states : array_like, shape (K, 2n) or (2n,)
    w : float
        The speed.
    t : array_like, shape (K,) or float

    Returns
    -------
    ndarray, shape like ``states``
    """
    return _turn(model, states, w, t, +1)


def to_rotating(model: Model, states, w: float, t) -> np.ndarray:
    """The inverse of :func:`to_fixed`: ``zeta = R(-w t) x``, ``zeta' = R(-w t) x' - w J zeta``."""
    return _turn(model, states, w, t, -1)


def _turn(model, states, w, t, sign) -> np.ndarray:
    pairs, _ = _rotation(model)
    Y = np.asarray(states, dtype=float)
    single = Y.ndim == 1
    Y = np.atleast_2d(Y)
    n = Y.shape[1] // 2
    tt = np.broadcast_to(np.asarray(t, dtype=float), (Y.shape[0],))
    J = rotation_generator(n, pairs)
    out = np.empty_like(Y)
    c, s = np.cos(w * tt), np.sin(w * tt)
    for i in range(Y.shape[0]):
        R = np.eye(n)
        for ix, iy in pairs:
            R[ix, ix] = R[iy, iy] = c[i]
            R[ix, iy] = -sign * s[i]
            R[iy, ix] = sign * s[i]
        x, v = Y[i, :n], Y[i, n:]
        if sign > 0:
            out[i, :n] = R @ x
            out[i, n:] = R @ (v + w * (J @ x))
        else:
            z = R @ x
            out[i, :n] = z
            out[i, n:] = R @ v - w * (J @ z)
    return out[0] if single else out
