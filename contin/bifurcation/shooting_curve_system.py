"""Fold, period-doubling and Neimark-Sacker curves of periodic orbits by shooting: the extended systems.

The same minimally augmented systems as :mod:`contin.bifurcation.curve_system`
(Govaerts 2000, sec. 3.4 and 4.2), posed on the monodromy matrix ``M`` of the
integrated flow (single shooting, the contact switches located;
:class:`contin.timedomain.multiple_shooting.ShootingProblem`) instead of on
the harmonic-balance Jacobian. With ``x`` the state at ``t = 0`` and
``phi`` the flow over the orbit's period,

    R(x, p1, p2) = phi(x) - x = 0,      g = 0,

where ``g`` is the bordered test function of ``A``::

    [ A    b ] [ v ]   [ 0 ]          [ A^H  c ] [ w ]   [ 0 ]
    [ c^H  0 ] [ g ] = [ 1 ],         [ b^H  0 ] [ h ] = [ 1 ].

=========  ===========================  ========================  =====================
kind       ``A``                        unknowns ``z``            test ``g``
=========  ===========================  ========================  =====================
fold       ``M - I``                    ``(x, p1)``               real, one equation
pd         ``M + I``                    ``(x, p1)``               real, one equation
ns         ``M - exp(i theta) I``       ``(x, theta, p1)``        complex, two equations
=========  ===========================  ========================  =====================

The Neimark-Sacker system is MatCont's complex bordering of ``M - mu I``
with the multiplier's angle ``theta`` an unknown (Kuznetsov, *Elements of
Applied Bifurcation Theory*, 3rd ed., 2004, sec. 10.3.3): square, ``2n + 2``
equations in ``2n + 2`` unknowns with ``p2`` the continuation parameter.
``theta`` stays in ``(0, pi)`` along a curve (the multiplier with positive
imaginary part); where it reaches ``pi`` the pair meets at -1 (a 1:2
resonance, where the curve meets a period-doubling curve) and the solution
set folds back onto itself in ``(p1, p2)`` (the conjugate multiplier), so a
curve ends there, as at ``theta = 0`` (1:1, on a fold curve).

Derivatives
-----------
``g_z = -w^H A_z v``. The second derivatives of the flow enter only
contracted with ``v``: by the symmetry of the Hessian,
``(dM/dx_j) v = (D_v M)_{:, j}``, the derivative of the whole monodromy along
``v``, which is a central difference of two variational flows at
``x +- eps v`` (the real and imaginary parts of a complex ``v`` separately).
The parameters' columns are central differences of the variational flow in
each parameter. ``R``, ``dR/dx = M - I`` and ``dR/dp1`` are the shooting
problem's own (analytic). A linearisation costs 7 variational flows (9 for
``ns``), a residual one; the residual ``(R, g)`` is exact, so the
differences affect Newton's rate, not the converged curve.
"""

from __future__ import annotations

import math

import numpy as np

from contin.bifurcation.curve_system import CurveKind, bordered_test
from contin.engine.branch import SpecialKind
from contin.engine.events import FunctionEvent
from contin.timedomain.multiple_shooting import ShootingProblem

__all__ = ["ShootingCurveProblem", "RESONANCES"]

#: strong resonances on a Neimark-Sacker curve: the angle theta of the critical multiplier, the kind's name
RESONANCES = ((0.0, "r1"), (math.pi / 2, "r4"), (2 * math.pi / 3, "r3"), (math.pi, "r2"))
RESONANCE_TEXT = {"r1": "1:1", "r2": "1:2", "r3": "1:3", "r4": "1:4"}
#: relative step of the differences of the monodromy in the state and the parameters (central: truncation
#: O(step^2), rounding O(eps / step), both below 1e-9 relative)
FD_STEP = 1e-5
#: a curve that stops with its orbit's switching function this close to zero (relative to the state) grazes there
GRAZE_NOTE = 1e-3
#: problems kept by value of the second parameter
_KEEP = 4


class ShootingCurveProblem:
    """The extended system of a fold, period-doubling or Neimark-Sacker curve by single shooting.

    Unknowns ``z = (x, p1)`` (fold, pd; shape (2n+1,)) or ``z = (x, theta, p1)``
    (ns; shape (2n+2,)); continuation parameter ``p2``. Follows the engine's
    problem protocol (``residual``, ``linearize``, ``monitor``) and the
    curve driver's (``m``, ``split``, borders) as
    :class:`contin.bifurcation.curve_system.SingularityProblem` does.

    Parameters
    ----------
    shooting : ShootingProblem
        Single shooting (one segment) in ``p1``, its fixed parameters those of
        the curve (``p2`` among them or the model's value).
    kind : CurveKind or str
        ``fold``, ``pd`` or ``ns``.
    p2 : str
        The continuation parameter.
    detect : tuple of str
        Among ``cusp`` (fold curves), ``fold_flip`` (fold and pd curves: the other of
        multipliers +1 and -1; ns curves: a real multiplier at -1 or +1 as well) and
        ``resonance`` (ns and pd curves).
    u_scale, p1_scale : float, optional
        Typical magnitudes of the state and ``p1`` (the engine's scaling).
    fd_step : float
        Relative step of the differences (:data:`FD_STEP`).
    """

    def __init__(self, shooting: ShootingProblem, kind: CurveKind | str, p2: str,
                 detect: tuple = ("cusp", "fold_flip", "resonance"), u_scale: float | None = None, p1_scale: float = 1.0,
                 fd_step: float = FD_STEP):
        self.kind = CurveKind(kind)
        if shooting.segments != 1:
            raise ValueError(f"a curve by shooting uses one segment, got {shooting.segments}")
        self.p1, self.p2 = shooting.parameter, p2
        if self.p1 == p2:
            raise ValueError(f"the two parameters of a curve must differ, got {p2!r} twice")
        model = shooting.model
        model.parameter_index(p2)  # an unknown name raises here
        self.model = model
        self.p2_value = float(shooting.base.get(p2, model.parameters[p2]))
        self.shooting = shooting.with_params({p2: self.p2_value})
        self._problems = {self.p2_value: self.shooting}
        self.n_state = 2 * model.n_dof
        self.m = self.n_state + (1 if self.kind is CurveKind.NS else 0)
        self.fd_step = float(fd_step)
        self.detect = tuple(detect)
        self.u_scale, self.p1_scale = u_scale, float(p1_scale)
        self.b = self.c = None
        self._key = None
        self._cache: dict = {}

    # ------------------------------------------------------------ pieces
    def problem_at(self, p2: float) -> ShootingProblem:
        """The shooting problem at ``p2`` (the last few kept)."""
        p2 = float(p2)
        sp = self._problems.get(p2)
        if sp is None:
            sp = self._problems[p2] = self.shooting.with_params({self.p2: p2})
            if len(self._problems) > _KEEP:
                self._problems.pop(next(iter(self._problems)))
        return sp

    def split(self, z: np.ndarray):
        """``(x, theta, p1)`` from ``z`` (``theta`` None for fold and pd)."""
        x = z[: self.n_state]
        theta = float(z[self.n_state]) if self.kind is CurveKind.NS else None
        return x, theta, float(z[self.m])

    def shift(self, theta):
        """The multiplier of ``A = M - shift I``: +1, -1 or ``exp(i theta)``."""
        if self.kind is CurveKind.FOLD:
            return 1.0
        if self.kind is CurveKind.PD:
            return -1.0
        return complex(math.cos(theta), math.sin(theta))

    def _monodromy(self, x, p1, p2):
        return self.problem_at(p2).flow_jacobian(x, p1)

    # ------------------------------------------------------------ borders
    def initialize_borders(self, z: np.ndarray, p2: float) -> np.ndarray:
        """Borders from the singular vectors of ``A`` at ``(z, p2)``; returns its two smallest singular values
        relative to the largest."""
        x, theta, p1 = self.split(np.asarray(z, float))
        _, M = self._monodromy(x, p1, p2)
        A = M - self.shift(theta) * np.eye(self.n_state)
        U, sv, Vh = np.linalg.svd(A)
        self.b, self.c = U[:, -1].copy(), Vh[-1].copy()
        self._key = None
        return np.array([sv[-1], sv[-2]]) / sv[0]

    def update_borders(self, z: np.ndarray, p2: float) -> None:
        """Renew the borders from the null vectors at a point of the curve."""
        d = self._evaluate(np.asarray(z, float), float(p2), False)
        v, w = d["v"], d["w"]
        nv, nw = np.linalg.norm(v), np.linalg.norm(w)
        if nv > 0 and nw > 0 and np.all(np.isfinite(v)) and np.all(np.isfinite(w)):
            self.b, self.c = w / nw, np.conj(v) / nv
            self._key = None

    def set_borders(self, b: np.ndarray, c: np.ndarray) -> None:
        self.b, self.c = np.array(b), np.array(c)
        self._key = None

    # ------------------------------------------------------------ evaluation
    def _evaluate(self, z: np.ndarray, p2: float, derivatives: bool) -> dict:
        key = (z.tobytes(), float(p2))
        if key == self._key and (self._cache.get("gz") is not None or not derivatives):
            return self._cache
        if self.b is None:
            self.initialize_borders(z, p2)
        x, theta, p1 = self.split(z)
        sp = self.problem_at(p2)
        I = np.eye(self.n_state)
        if derivatives:
            R, Ju, Jl = sp.linearize(x, p1)
            M = Ju + I
        else:
            end, M = self._monodromy(x, p1, p2)
            R, Jl = end - x, None
        mu = self.shift(theta)
        v, g, w = bordered_test(M - mu * I, self.b, self.c)
        out = {"R": R, "M": M, "Jl": Jl, "v": v, "g": g, "w": w, "x": x, "p1": p1, "theta": theta, "gz": None}
        if derivatives:
            out.update(self._derivatives(x, theta, p1, float(p2), v, w, mu))
        self._cache, self._key = out, key
        return out

    def _along(self, x, p1, p2, q):
        """``D_q M``: the monodromy's derivative along the real direction ``q`` (2n,)."""
        nq = float(np.linalg.norm(q))
        if nq == 0.0:
            return np.zeros((self.n_state, self.n_state))
        eps = self.fd_step * max(1.0, float(np.max(np.abs(x))))
        _, Mp = self._monodromy(x + eps * q / nq, p1, p2)
        _, Mm = self._monodromy(x - eps * q / nq, p1, p2)
        return (Mp - Mm) * (nq / (2.0 * eps))

    def _derivatives(self, x, theta, p1, p2, v, w, mu) -> dict:
        wh = np.conj(w)
        Dv = self._along(x, p1, p2, np.real(v))
        if np.iscomplexobj(v):
            Dv = Dv + 1j * self._along(x, p1, p2, np.imag(v))
        gz = -(wh @ Dv)
        h1 = self.fd_step * max(1.0, abs(p1))
        _, M1p = self._monodromy(x, p1 + h1, p2)
        _, M1m = self._monodromy(x, p1 - h1, p2)
        h2 = self.fd_step * max(1.0, abs(p2))
        e2p, M2p = self._monodromy(x, p1, p2 + h2)
        e2m, M2m = self._monodromy(x, p1, p2 - h2)
        g1 = -(wh @ ((M1p - M1m) @ v)) / (2.0 * h1)
        g2 = -(wh @ ((M2p - M2m) @ v)) / (2.0 * h2)
        gt = 1j * mu * (wh @ v) if self.kind is CurveKind.NS else None
        return {"gz": gz, "g1": g1, "g2": g2, "gt": gt, "R2": (e2p - e2m) / (2.0 * h2)}

    # ------------------------------------------------------------ engine protocol
    def _g_rows(self, g):
        return [float(np.real(g)), float(np.imag(g))] if self.kind is CurveKind.NS else [float(np.real(g))]

    def residual(self, z: np.ndarray, p2: float) -> np.ndarray:
        """``(R, g)``: shape (2n+1,), or (2n+2,) with ``(Re g, Im g)`` for ns."""
        d = self._evaluate(np.asarray(z, float), float(p2), False)
        return np.concatenate([d["R"], self._g_rows(d["g"])])

    def linearize(self, z: np.ndarray, p2: float):
        """Residual, Jacobian in ``z`` (square) and in ``p2`` (module docstring)."""
        d = self._evaluate(np.asarray(z, float), float(p2), True)
        k, m = self.n_state, self.m
        F = np.concatenate([d["R"], self._g_rows(d["g"])])
        Jz = np.zeros((m + 1, m + 1))
        Jz[:k, :k] = d["M"] - np.eye(k)
        Jz[:k, m] = d["Jl"]
        Jl = np.empty(m + 1)
        Jl[:k] = d["R2"]
        parts = [np.real] if self.kind is CurveKind.FOLD or self.kind is CurveKind.PD else [np.real, np.imag]
        for r, part in enumerate(parts, start=k):
            Jz[r, :k] = part(d["gz"])
            Jz[r, m] = part(d["g1"])
            Jl[r] = part(d["g2"])
            if self.kind is CurveKind.NS:
                Jz[r, k] = part(d["gt"])
        return F, Jz, Jl

    def unknown_scale(self):
        """Scales of ``z``, or None (the engine scales by ``|z|``)."""
        if self.u_scale is None:
            return None
        s = [np.full(self.n_state, self.u_scale)] + ([[1.0]] if self.kind is CurveKind.NS else []) + [[self.p1_scale]]
        return np.concatenate(s)

    # ------------------------------------------------------------ test functions
    def monitor(self, z, p2, Jz=None, Jl=None) -> dict:
        """The test values: ``g``, the signs of ``det(M - I)`` and ``det(M + I)`` without the critical
        multipliers, and on ns curves the angle ``theta``."""
        z = np.asarray(z, float)
        d = self._evaluate(z, float(p2), False)
        out = {"g": float(abs(d["g"]))}
        mu = np.linalg.eigvals(d["M"])
        crit = self.shift(d["theta"])
        # leave out the critical multiplier(s): the nearest to the shift (and its conjugate)
        order = np.argsort(np.abs(mu - crit))
        rest = np.delete(mu, order[:1] if self.kind is not CurveKind.NS else
                         np.concatenate([order[:1], np.argsort(np.abs(mu - np.conj(crit)))[:1]]))
        if "fold_flip" in self.detect:
            out["minus_test"] = float(np.sign(np.real(np.prod(rest + 1.0))))
            out["plus_test"] = float(np.sign(np.real(np.prod(rest - 1.0))))
        if self.kind is CurveKind.NS:
            out["theta"] = float(d["theta"])
        if self.kind is CurveKind.FOLD and "cusp" in self.detect:
            out["cusp_test"] = self.cusp_test(z, p2)
        if self.kind is CurveKind.PD and "resonance" in self.detect:
            # at a 1:2 resonance the multiplier -1 is double with one eigenvector: its left and right null
            # vectors turn orthogonal (a Jordan block)
            v, w = d["v"], d["w"]
            out["r2_test"] = float(np.real(np.vdot(w, v)) / (np.linalg.norm(w) * np.linalg.norm(v)))
        return out

    def end_note(self, z, p2: float) -> str:
        """Why a curve may stop at ``z``: the orbit grazes a switching surface there (its multipliers jump where
        a contact force does), or nothing ("")."""
        x, _, p1 = self.split(np.asarray(z, float))
        try:
            graze = self.problem_at(p2).graze(x, p1)
        except ArithmeticError:
            return ""
        near = float(np.min(np.abs(graze))) if graze.size else math.inf
        if near > GRAZE_NOTE * max(1.0, float(np.max(np.abs(x)))):
            return ""
        return (f"; the orbit grazes there (a switching function's extremum {near:.1e} from zero): where a contact "
                f"arc opens or closes the multipliers jump with the contact force, and the curve does not continue "
                f"across it")

    def cusp_test(self, z, p2: float) -> float:
        """``w^T phi_xx(v, v) / (|w| |v|^2)``, the quadratic coefficient of the fold's normal form: zero at a cusp
        (Kuznetsov 2004, sec. 9.2; ``phi_xx(v, v) = (D_v M) v``, the derivative already in the Jacobian)."""
        d = self._evaluate(np.asarray(z, float), float(p2), True)
        v, w = d["v"], d["w"]
        return float(np.real(-(d["gz"] @ v))) / (float(np.linalg.norm(w)) * float(v @ v))

    # ------------------------------------------------------------ the curve's events
    @property
    def end_kinds(self) -> tuple:
        """Where a curve ends: a Neimark-Sacker curve at 1:1 and 1:2 resonance (module docstring)."""
        return (SpecialKind.R1, SpecialKind.R2) if self.kind is CurveKind.NS else ()

    def curve_events(self, detect) -> list:
        """The codimension-two points of this kind of curve, as engine events."""
        evs = []
        pairs = {CurveKind.FOLD: (("minus_test", SpecialKind.FOLD_FLIP, "fold-flip"),),
                 CurveKind.PD: (("plus_test", SpecialKind.FOLD_FLIP, "fold-flip"),),
                 CurveKind.NS: (("minus_test", SpecialKind.FLIP_NS, "flip-Neimark-Sacker"),
                                ("plus_test", SpecialKind.FOLD_NS, "fold-Neimark-Sacker"))}
        if "fold_flip" in detect:
            for key, kind, name in pairs[self.kind]:
                evs.append(FunctionEvent(lambda pt, key=key: float(pt.data[key]), name=name, kind=kind,
                                         integer_valued=True))
        if "cusp" in detect and self.kind is CurveKind.FOLD:
            evs.append(FunctionEvent(lambda pt: float(pt.data["cusp_test"]), name="cusp", kind=SpecialKind.CUSP))
        if "resonance" in detect and self.kind is CurveKind.NS:
            for angle, name in RESONANCES:
                evs.append(FunctionEvent(lambda pt, a=angle: float(pt.data["theta"]) - a,
                                         name=f"{RESONANCE_TEXT[name]} resonance", kind=SpecialKind(name)))
        if "resonance" in detect and self.kind is CurveKind.PD:
            evs.append(FunctionEvent(lambda pt: float(pt.data["r2_test"]), name="1:2 resonance", kind=SpecialKind.R2))
        return evs

    def end_message(self, point) -> str:
        """Why a curve ends at ``point`` (of one of :attr:`end_kinds`)."""
        where = "a period-doubling" if point.kind is SpecialKind.R2 else "a fold"
        return (f"{RESONANCE_TEXT[point.kind.value]} resonance: the Neimark-Sacker multipliers meet at "
                f"{'-1' if point.kind is SpecialKind.R2 else '+1'} and the curve ends on {where} curve (the "
                f"curve's {point.kind.value} point)")
