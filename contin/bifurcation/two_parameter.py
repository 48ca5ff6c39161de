"""Two-parameter continuation of fold and period-doubling curves.

A fold (multiplier +1, a jump point) or a period doubling (multiplier -1) of
a branch of periodic solutions traced in a parameter ``p1`` moves when a
second parameter ``p2`` changes. Continuing the bifurcation itself traces a
curve in the ``(p1, p2)`` plane: the boundary of the jump (bistability)
region for folds, the boundary of the region where the ``nu``-periodic
solution is unstable by period doubling and the subharmonic of order
``2 nu`` is born, for period doublings.

Minimally augmented systems (Govaerts)
--------------------------------------
With unknowns ``z = (u, p1)`` and ``p2`` as the continuation parameter, the
curve is the solution set of

    R(u, p1, p2) = 0,      g(u, p1, p2) = 0,

where ``g`` is the bordered test function of a matrix ``Mx(u, p)``:

    [ Mx   b ] [ v ]   [ 0 ]          [ Mx^T  c ] [ w ]   [ 0 ]
    [ c^T  0 ] [ g ] = [ 1 ],         [ b^T   0 ] [ g ] = [ 1 ].

``g = 0`` exactly when ``Mx`` is singular (the bordered matrix stays regular
when ``b``, ``c`` are close to the left and right null vectors), and its
derivatives are ``g_z = -w^T Mx_z v`` (Govaerts, *Numerical Methods for
Bifurcations of Dynamical Equilibria*, SIAM 2000, sec. 3.4 and 4.2;
Kuznetsov, *Elements of Applied Bifurcation Theory*, 3rd ed., 2004,
sec. 10.2.2; the same system as MatCont's LP and PD curves). The system has
``m + 1`` unknowns instead of the ``2m + 1`` of the standard augmented system
``(R, Mx v, c.v - 1)``, and ``w``, ``v`` are those of the regular bordered
matrix (one LU). The borders are renewed at every stored point from the
current ``v``, ``w``: this rescales ``g`` by a positive factor and leaves the
curve, its tangent and the signs of the test functions unchanged.

- **Folds** (``kind = fold``): ``Mx = J = dR/du``, the harmonic-balance
  Jacobian of the branch's own order ``nu`` (analytic, from the AFT).
- **Period doubling** (``kind = pd``): ``Mx = B``, the *flip matrix*: the
  odd-harmonic block of the order-``2 nu`` Jacobian at the order-``nu``
  solution (:meth:`contin.hb.derivatives.HBDerivatives.flip_matrix`). This is
  the "nu = 2 branch-point" formulation: a period doubling of the
  ``T``-periodic orbit is a branch point of the same orbit seen as a
  ``2T``-periodic solution, where the order-``2 nu`` Jacobian, block diagonal
  in (even, odd) harmonics, has a singular odd block. It is preferred to
  Hill's method because (i) it is a real, square, analytic matrix of the
  problem's own size (``2nH`` against ``n(2H+1)``), whose determinant
  changes sign transversally at the bifurcation, so ``g`` is a smooth
  regular test function; Hill's condition is a complex quadratic eigenvalue
  problem whose -1 multiplier must first be *selected* among ``2n(2H+1)``
  eigenvalues, a selection that is ambiguous exactly when harmonics are few
  or the contact is stiff (the rotor); (ii) it has derivatives through the
  same AFT machinery as ``J``; (iii) its null vector is the switching
  direction onto the ``2 nu`` branch already used by
  :mod:`contin.bifurcation.switching`. It is exact for the truncated problem: ``B`` is
  singular iff the order-``2 nu`` harmonic balance with ``2H`` harmonics has a
  neutral ``2T``-periodic perturbation.

The second-derivative terms ``w^T Mx_u v`` come from
:meth:`contin.hb.derivatives.HBDerivatives.bilinear` (a central difference of
the analytic sample Jacobians along the sampled null vector, two extra force
evaluations; exact for cubic forces; with contact switches resolved, of the
problem's whole analytic Jacobian along the null vector); the residual
``(R, g)`` itself is analytic, so they affect Newton's rate, not the converged
curve.

Codimension-two points
----------------------
Located on the curves by the engine's event mechanism:

- ``cusp`` (fold curves): the quadratic coefficient of the fold's normal
  form vanishes, ``c = w^T B(v, v) = 0`` with ``B`` the second derivative of
  ``R`` (Kuznetsov 2004, sec. 8.2; MatCont's CP test). Two fold curves merge
  there; in the ``(p1, p2)`` plane the curve has a cusp, and both
  parameters are extremal along it.
- ``fold_flip`` (fold and period-doubling curves): multipliers +1 and -1 at
  once. On a period-doubling curve ``J`` becomes singular (sign change of
  ``det J``); on a fold curve the flip matrix ``B`` does (sign change of
  ``det B``). Located by bisection (Kuznetsov, Meijer & van Veen, Int. J.
  Bifurcation Chaos 14 (2004) 2253, "fold-flip").
- ``extremum``: the curve turns in ``p1`` or ``p2`` (for example the smallest
  static force at which a period-doubling region exists). Not a bifurcation,
  but where a region begins or ends.

Not detected: degenerate (generalised) period doubling and 1:2 resonance on
period-doubling curves, and Bogdanov-Takens-like points of fold curves.
"""

from __future__ import annotations

import dataclasses
import enum
import math
from typing import Any, Callable

import numpy as np
from scipy.linalg import lu_factor, lu_solve

from contin.engine.branch import Branch, BranchStatus, SpecialKind, SpecialPoint
from contin.engine.continuation import ContinuationOptions, continuation
from contin.engine.events import Event, FunctionEvent, PointInfo
from contin.hb.problem import HarmonicBalance
from contin.hb.derivatives import HBDerivatives, MatrixKind
from contin.engine.newton import NUMERICAL_ERRORS, newton

__all__ = [
    "CurveKind",
    "CurveOptions",
    "CurvePoint",
    "BifurcationCurve",
    "SingularityProblem",
    "continue_curve",
    "curve_from_point",
    "special_point_kind",
    "FlipTestEvent",
]


class CurveKind(str, enum.Enum):
    """Kind of a two-parameter curve."""

    #: folds (limit points, multiplier +1): the boundary of a jump region
    FOLD = "fold"
    #: period doublings (multiplier -1): the boundary of a 2 nu-subharmonic region
    PD = "pd"

    def __str__(self) -> str:
        return self.value


def _curve_kind(kind) -> CurveKind:
    try:
        return CurveKind(kind)
    except ValueError:
        raise ValueError(f"curve kind must be 'fold' or 'pd', got {kind!r}") from None


_MATRIX = {CurveKind.FOLD: MatrixKind.JACOBIAN, CurveKind.PD: MatrixKind.FLIP}
CODIM2_KINDS = ("cusp", "fold_flip", "extremum")


@dataclasses.dataclass(frozen=True)
class CurveOptions:
    """Options of :func:`continue_curve` (the step control is a :class:`ContinuationOptions`).

    Attributes
    ----------
    both_ways : bool
        Continue from the start point in both directions and join the two
        halves into one curve (unless the first half closes a loop).
    detect : tuple of str
        Codimension-two points and turning points to locate, among
        ``"cusp"`` (fold curves), ``"fold_flip"`` and ``"extremum"``.
    fd_step : float
        Relative step of the central differences of the second-derivative
        terms (:class:`contin.hb.derivatives.HBDerivatives`), in (0, 1e-2].
    land_on_bounds : bool
        When the curve leaves the range of ``p1``, solve for the point exactly
        on the bound (otherwise the first point beyond it ends the curve).
    """

    both_ways: bool = True
    detect: tuple = CODIM2_KINDS
    fd_step: float = 1e-6
    land_on_bounds: bool = True

    def __post_init__(self):
        if not isinstance(self.both_ways, (bool, np.bool_)):
            raise ValueError(f"CurveOptions.both_ways must be a bool, got {self.both_ways!r}")
        det = tuple(self.detect) if isinstance(self.detect, (list, tuple)) else None
        if det is None or any(d not in CODIM2_KINDS for d in det):
            raise ValueError(f"CurveOptions.detect must be a list of {list(CODIM2_KINDS)}, got {self.detect!r}")
        object.__setattr__(self, "detect", det)
        f = self.fd_step
        if isinstance(f, bool) or not isinstance(f, (int, float)) or not (0 < f <= 1e-2):
            raise ValueError(f"CurveOptions.fd_step must be a number in (0, 1e-2], got {f!r}")
        object.__setattr__(self, "fd_step", float(f))
        if not isinstance(self.land_on_bounds, (bool, np.bool_)):
            raise ValueError(f"CurveOptions.land_on_bounds must be a bool, got {self.land_on_bounds!r}")


    @classmethod
    def from_dict(cls, d: dict) -> "CurveOptions":
        names = [f.name for f in dataclasses.fields(cls)]
        for key in d:
            if key not in names:
                raise ValueError(f"CurveOptions: unknown option {key!r}; expected one of {names}")
        return cls(**d)


class SingularityProblem:
    """The minimally augmented system of a fold or period-doubling curve, for the engine.

    Unknowns ``z = (u, p1)``, shape (m+1,); continuation parameter ``p2``.
    ``residual(z, p2) = (R(u, p1, p2), g(u, p1, p2))``.

    Parameters
    ----------
    hb : HarmonicBalance
        The order-``nu`` problem (its parameter values are the fixed ones).
    kind : CurveKind or str
    p1, p2 : str
        Names of the two parameters (``p1`` is an unknown).
    fd_step : float
        See :class:`CurveOptions`.
    detect : tuple of str
        Test functions evaluated by :meth:`monitor` (see :class:`CurveOptions`).
    u_scale, p1_scale : float, optional
        Typical magnitudes of the coefficients and of ``p1`` for the engine's
        scaling (:meth:`unknown_scale`); None leaves the scaling to the engine.
    """

    def __init__(self, hb: HarmonicBalance, kind: CurveKind | str, p1: str, p2: str, fd_step: float = 1e-6,
                 detect: tuple = CODIM2_KINDS, u_scale: float | None = None, p1_scale: float = 1.0):
        self.hb = hb
        self.kind = _curve_kind(kind)
        self.matrix_kind = _MATRIX[self.kind]
        model = hb.model
        if p1 == p2:
            raise ValueError(f"the two parameters of a curve must differ, got {p1!r} twice")
        self.p1, self.p2 = p1, p2
        self.k1, self.k2 = model.parameter_index(p1), model.parameter_index(p2)
        self.der = HBDerivatives(hb, fd_step)
        self.m = hb.size
        self.p_base = hb.p0.copy()
        self.b = self.c = None
        self._cache_key = None
        self._cache: dict = {}
        self.evaluations = 0
        self.detect = tuple(detect)
        self.u_scale = u_scale
        self.p1_scale = float(p1_scale)

    # ------------------------------------------------------------ parameters and borders
    def params(self, p1: float, p2: float) -> np.ndarray:
        """Full parameter vector with ``p1`` and ``p2`` set, shape (P,)."""
        p = self.p_base.copy()
        p[self.k1] = p1
        p[self.k2] = p2
        return p

    def split(self, z: np.ndarray):
        """``(u, p1)`` from ``z``."""
        return z[: self.m], float(z[self.m])

    def _matrix(self, u, p, J):
        return J if self.kind is CurveKind.FOLD else self.der.flip_matrix(u, p)

    def initialize_borders(self, z: np.ndarray, p2: float) -> np.ndarray:
        """Borders from the singular vectors of ``Mx`` at ``(z, p2)``.

        Returns
        -------
        ndarray, shape (2,)
            The two smallest singular values of ``Mx`` relative to the largest
            (a good start has the first much smaller than the second).
        """
        u, p1 = self.split(np.asarray(z, float))
        p = self.params(p1, p2)
        _, J, _ = self.der.linearize_at(u, p)
        Mx = self._matrix(u, p, J)
        U, sv, Vt = np.linalg.svd(Mx)
        self.b = U[:, -1].copy()
        self.c = Vt[-1].copy()
        self._cache_key = None
        return np.array([sv[-1], sv[-2] if sv.size > 1 else np.inf]) / sv[0]

    def update_borders(self, z: np.ndarray, p2: float) -> None:
        """Renew the borders from the null vectors at a point of the curve."""
        d = self._evaluate(np.asarray(z, float), float(p2))
        v, w = d["v"], d["w"]
        nv, nw = np.linalg.norm(v), np.linalg.norm(w)
        if nv > 0 and nw > 0 and np.all(np.isfinite(v)) and np.all(np.isfinite(w)):
            self.b, self.c = w / nw, v / nv
            self._cache_key = None

    def set_borders(self, b: np.ndarray, c: np.ndarray) -> None:
        self.b, self.c = np.array(b, float), np.array(c, float)
        self._cache_key = None

    def _evaluate(self, z: np.ndarray, p2: float) -> dict:
        key = (z.tobytes(), float(p2))
        if key == self._cache_key:
            return self._cache
        if self.b is None:
            self.initialize_borders(z, p2)
        u, p1 = self.split(z)
        p = self.params(p1, p2)
        R, J, dR = self.der.linearize_at(u, p, (self.k1, self.k2))
        Mx = self._matrix(u, p, J)
        k = Mx.shape[0]
        A = np.empty((k + 1, k + 1))
        A[:k, :k] = Mx
        A[:k, k] = self.b
        A[k, :k] = self.c
        A[k, k] = 0.0
        if not np.all(np.isfinite(A)):
            raise np.linalg.LinAlgError("non-finite matrix in the bordered test function")
        lu = lu_factor(A, check_finite=False)
        if np.any(np.diagonal(lu[0]) == 0.0):
            raise np.linalg.LinAlgError("singular bordered matrix of the test function")
        e = np.zeros(k + 1)
        e[k] = 1.0
        vg = lu_solve(lu, e, check_finite=False)
        wg = lu_solve(lu, e, trans=1, check_finite=False)
        v, g, w = vg[:k], float(vg[k]), wg[:k]
        S, S_u, S_p = self.der.bilinear(u, p, v, w, self.matrix_kind, (self.k1, self.k2))
        self.evaluations += 1
        self._cache = {"R": R, "J": J, "dR": dR, "v": v, "w": w, "g": g, "S": S, "S_u": S_u, "S_p": S_p,
                       "u": u, "p": p}
        self._cache_key = key
        return self._cache

    # ------------------------------------------------------------ engine protocol
    def residual(self, z: np.ndarray, p2: float) -> np.ndarray:
        """``(R, g)``, shape (m+1,)."""
        d = self._evaluate(np.asarray(z, float), float(p2))
        return np.concatenate([d["R"], [d["g"]]])

    def linearize(self, z: np.ndarray, p2: float):
        """Residual (m+1,), Jacobian in ``z`` (m+1, m+1) and in ``p2`` (m+1,)."""
        d = self._evaluate(np.asarray(z, float), float(p2))
        m = self.m
        F = np.empty(m + 1)
        F[:m] = d["R"]
        F[m] = d["g"]
        Jz = np.empty((m + 1, m + 1))
        Jz[:m, :m] = d["J"]
        Jz[:m, m] = d["dR"][0]
        Jz[m, :m] = -d["S_u"]
        Jz[m, m] = -d["S_p"][0]
        Jl = np.empty(m + 1)
        Jl[:m] = d["dR"][1]
        Jl[m] = -d["S_p"][1]
        return F, Jz, Jl

    def unknown_scale(self):
        """Scales of ``z = (u, p1)``, shape (m+1,), or None (then the engine scales by ``|z|``)."""
        if self.u_scale is None:
            return None
        return np.concatenate([np.full(self.m, self.u_scale), [self.p1_scale]])

    # ------------------------------------------------------------ test functions
    def cusp_test(self, z: np.ndarray, p2: float) -> float:
        """``w^T B(v, v) / (|w| |v|^2)``: zero at a cusp (fold curves only)."""
        d = self._evaluate(np.asarray(z, float), float(p2))
        v, w = d["v"], d["w"]
        return float(d["S_u"] @ v) / (np.linalg.norm(w) * float(v @ v))

    def fold_flip_test(self, z: np.ndarray, p2: float) -> float:
        """Sign of ``det B`` on fold curves, of ``det J`` on period-doubling curves."""
        d = self._evaluate(np.asarray(z, float), float(p2))
        other = self.der.flip_matrix(d["u"], d["p"]) if self.kind is CurveKind.FOLD else d["J"]
        sign, _ = np.linalg.slogdet(other)
        return float(sign)

    def monitor(self, z, p2, Jz, Jl) -> dict:
        """Engine monitor: the test function values and the smallest singular value estimate."""
        d = self._evaluate(np.asarray(z, float), float(p2))
        out = {"g": d["g"]}
        if "cusp" in self.detect and self.kind is CurveKind.FOLD:
            out["cusp_test"] = self.cusp_test(z, p2)
        if "fold_flip" in self.detect:
            out["fold_flip_test"] = self.fold_flip_test(z, p2)
        return out


@dataclasses.dataclass
class CurvePoint:
    """A special point of a curve (codimension two, turning point, start or end).

    Attributes
    ----------
    kind : SpecialKind
        ``cusp``, ``fold_flip``, ``extremum``, ``start`` or ``end``.
    p1, p2 : float
        Both parameters.
    unknowns : ndarray, shape (m,)
        Harmonic-balance coefficients there.
    index : int
        Row of the curve just before the point.
    located : bool
    message : str
    data : dict
        For ``extremum``: ``{"parameter": name}`` of the parameter that turns.
    """

    kind: SpecialKind
    p1: float
    p2: float
    unknowns: np.ndarray
    index: int
    located: bool = True
    message: str = ""
    data: dict = dataclasses.field(default_factory=dict)


@dataclasses.dataclass(eq=False)
class BifurcationCurve:
    """A fold or period-doubling curve in the plane of two parameters.

    Attributes
    ----------
    kind : CurveKind
    parameters : tuple of str
        ``(p1, p2)``.
    nu, harmonics : int
        Order and harmonic count of the periodic solutions on the curve.
    p1, p2 : ndarray, shape (P,)
        The curve, in order along it.
    unknowns : ndarray, shape (P, m)
        Harmonic-balance coefficients at each point.
    special_points : list of CurvePoint
        In order along the curve.
    ends : list of dict
        ``{"side", "status", "message"}`` for each traced direction.
    start_index : int
        Row of the start point.
    problem : SingularityProblem
        For :meth:`crossings`.
    branches : list of Branch
        The engine's branches (diagnostics).
    tangents : ndarray, shape (P, m+2)
        Unit tangents in the engine's scaled coordinates ``(u/su, p1/s1, p2/s2)``,
        oriented along the curve.
    scales : tuple
        ``(su, s2)``: scales of ``z = (u, p1)`` (shape (m+1,)) and of ``p2``.
    """

    kind: CurveKind
    parameters: tuple
    nu: int
    harmonics: int
    p1: np.ndarray
    p2: np.ndarray
    unknowns: np.ndarray
    special_points: list
    ends: list
    start_index: int
    problem: Any = None
    branches: list = dataclasses.field(default_factory=list)
    tangents: np.ndarray | None = None
    scales: tuple = (None, 1.0)

    def __len__(self) -> int:
        return int(self.p1.size)

    @property
    def closed(self) -> bool:
        return any(e["status"] == BranchStatus.CLOSED_LOOP.value for e in self.ends)

    @property
    def complete(self) -> bool:
        """Every traced direction ended at a range bound (also after turning back) or closed the loop."""
        ok = (BranchStatus.RANGE_END.value, BranchStatus.TURNED_BACK.value, BranchStatus.CLOSED_LOOP.value)
        return bool(self.ends) and all(e["status"] in ok for e in self.ends)

    def points_of_kind(self, kind) -> list:
        kind = SpecialKind(kind)
        return [p for p in self.special_points if p.kind is kind]

    def crossings(self, p2_value: float, options: ContinuationOptions | None = None) -> list[tuple[float, np.ndarray]]:
        """Points of the curve at ``p2 = p2_value``, solved exactly (not interpolated).

        From the first point of every stored segment whose ends bracket
        ``p2_value``, the curve is continued with the engine (same scaling,
        oriented along the curve) until it lands exactly on ``p2_value``.

        Parameters
        ----------
        p2_value : float
        options : ContinuationOptions, optional
            Step control (default: steps of at most the segment's length).

        Returns
        -------
        list of (p1, u)
            ``u`` of shape (m,); segments whose solve fails are left out.
        """
        out = []
        p2 = self.p2
        m = self.problem.m
        su, sl = self.scales
        for i in range(len(self) - 1):
            a, b = p2[i] - p2_value, p2[i + 1] - p2_value
            if a == 0.0:
                out.append((float(self.p1[i]), self.unknowns[i].copy()))
                continue
            if a * b >= 0:
                continue
            z0 = np.concatenate([self.unknowns[i], [self.p1[i]]])
            x0 = np.concatenate([z0 / su, [p2[i] / sl]])
            x1 = np.concatenate([self.unknowns[i + 1] / su[:m], [self.p1[i + 1] / su[m], p2[i + 1] / sl]])
            h = float(np.linalg.norm(x1 - x0))
            opts = options or ContinuationOptions(ds=max(0.25 * h, 1e-6), ds_max=max(0.5 * h, 1e-6), max_points=200)
            opts = opts.replace(detect_folds=False, detect_branch_points=False, parameter_scale=sl,
                                direction=1 if p2_value > p2[i] else -1)
            self.problem.initialize_borders(z0, float(p2[i]))
            br = continuation(self.problem, z0, float(p2[i]), sorted((float(p2[i]), p2_value)), opts,
                              tangent=self.tangents[i], solve_start=False,
                              callback=lambda b, j: self.problem.update_borders(b.unknowns[j], b.parameter[j]))
            if len(br) > 1 and br.parameter[-1] == p2_value:
                out.append((float(br.unknowns[-1][m]), br.unknowns[-1][:m].copy()))
        if len(self) and p2[-1] == p2_value:
            out.append((float(self.p1[-1]), self.unknowns[-1].copy()))
        return out

    def summary(self) -> str:
        a, b = self.parameters
        lines = [f"{self.kind.value} curve in ({a}, {b}): {len(self)} points, nu={self.nu}, H={self.harmonics}"
                 + (", closed" if self.closed else "")]
        if len(self):
            lines.append(f"  {a} in [{self.p1.min():.8g}, {self.p1.max():.8g}], {b} in [{self.p2.min():.8g}, "
                         f"{self.p2.max():.8g}]")
        for e in self.ends:
            lines.append(f"  {e['side']}: {e['status']} ({e['message']})")
        for p in self.special_points:
            flag = "" if p.located else "  [not located]"
            extra = f" in {p.data['parameter']}" if p.kind is SpecialKind.EXTREMUM else ""
            lines.append(f"  {p.kind.value:9s}{extra} {a}={p.p1:.10g} {b}={p.p2:.10g}{flag}")
        return "\n".join(lines)


def special_point_kind(point: SpecialPoint) -> SpecialKind:
    """The kind of a one-parameter special point, with stability changes classified."""
    kind = point.kind
    if kind is SpecialKind.STABILITY:
        kind = SpecialKind(point.data.get("classification", "stability"))
    return kind


class FlipTestEvent(Event):
    """Period doubling on a one-parameter branch, from the flip matrix.

    Test value ``sign(det B) sigma_min(B) / sigma_max(B)``: continuous along
    the branch (``det B`` changes sign only where a singular value vanishes)
    and zero exactly where the truncated problem has a multiplier -1. Unlike
    the multiplier-count events of :mod:`contin.stability`, it needs no
    selection among Hill's eigenvalues and no time integration, and it
    locates the same condition that :func:`continue_curve` follows for
    ``kind = pd``. Located by the Illinois method (kind ``pd``).

    Parameters
    ----------
    hb : HarmonicBalance
        The problem of the branch (its ``parameter`` is the branch's).
    """

    kind = SpecialKind.PD
    name = "flip test"

    def __init__(self, hb: HarmonicBalance):
        self.hb = hb
        self.der = HBDerivatives(hb)

    def value(self, u: np.ndarray, lam: float) -> float:
        B = self.der.flip_matrix(np.asarray(u, float), self.hb.params_at(lam))
        sign, _ = np.linalg.slogdet(B)
        sv = np.linalg.svd(B, compute_uv=False)
        return float(sign * sv[-1] / sv[0])

    def test(self, point: PointInfo) -> float:
        return self.value(point.u, point.lam)


class _CurveEvent(FunctionEvent):
    """A continuous test on a curve, located by the Illinois method and then checked.

    A test that only *jumps* through zero (the discretised problem of a
    non-smooth force is discontinuous where a time sample crosses a switching
    surface) narrows its bracket to rounding level without a small value:
    such a location is reported as not located, with the reason, instead of
    as a cusp or a turning point.
    """

    def locate(self, component, point_at, h, a, b, ga, gb, *, tol=1e-10, max_iter=60):
        out = super().locate(component, point_at, h, a, b, ga, gb, tol=tol, max_iter=max_iter)
        for loc in out:
            scale = max(abs(ga), abs(gb))
            if loc.located and abs(loc.value) > 1e-3 * scale:
                loc.located = False
                loc.message = (f"the test jumps through zero here (|test| = {abs(loc.value):.1e} against "
                               f"{scale:.1e} at the bracketing points): a discontinuity of the discretised "
                               f"problem, not a {self.kind.value}")
        return out


def _events(problem: SingularityProblem, detect) -> list:
    m = problem.m
    names = problem.p1, problem.p2
    evs = []
    if "extremum" in detect:
        evs.append(_CurveEvent(lambda pt: float(pt.tangent[-1]), name=f"extremum in {names[1]}",
                               kind=SpecialKind.EXTREMUM, describe=lambda pt: {"parameter": names[1]}))
        evs.append(_CurveEvent(lambda pt: float(pt.tangent[m]), name=f"extremum in {names[0]}",
                               kind=SpecialKind.EXTREMUM, describe=lambda pt: {"parameter": names[0]}))
    if "cusp" in detect and problem.kind is CurveKind.FOLD:
        evs.append(_CurveEvent(lambda pt: float(pt.data["cusp_test"]), name="cusp", kind=SpecialKind.CUSP))
    if "fold_flip" in detect:
        evs.append(FunctionEvent(lambda pt: float(pt.data["fold_flip_test"]), name="fold-flip",
                                 kind=SpecialKind.FOLD_FLIP, integer_valued=True))
    return evs


def continue_curve(hb: HarmonicBalance, kind: CurveKind | str, p1: str, p2: str, u0, p1_0: float, p2_0: float,
                   p2_range, p1_range=(-math.inf, math.inf), options: ContinuationOptions | dict | None = None,
                   curve_options: CurveOptions | dict | None = None, *,
                   callback: Callable[[Branch, int], Any] | None = None) -> BifurcationCurve:
    """Continue a fold or a period doubling of ``hb``'s solutions in two parameters.

    Parameters
    ----------
    hb : HarmonicBalance
        Problem of order ``nu`` whose solutions fold or double their period;
        its parameter values are kept fixed except ``p1`` and ``p2``.
    kind : CurveKind or str
        ``"fold"`` or ``"pd"``.
    p1, p2 : str
        Parameter names; ``p1`` is solved for, ``p2`` is the continuation
        parameter.
    u0 : ndarray, shape (hb.size,)
        Harmonic-balance coefficients at (or near) the bifurcation.
    p1_0, p2_0 : float
        The bifurcation's parameters (``p2_0`` inside ``p2_range``).
    p2_range, p1_range : (float, float)
        The curve ends exactly on a bound of ``p2_range``; when it leaves
        ``p1_range`` it ends on that bound (``CurveOptions.land_on_bounds``).
    options : ContinuationOptions or dict, optional
        Step control (``detect_folds`` and ``detect_branch_points`` are
        switched off: the curve's own events replace them).
    curve_options : CurveOptions or dict, optional
    callback : callable, optional
        ``callback(branch, index)`` after each stored point, as for the engine
        (the branch's unknowns are ``z = (u, p1)``); returning False stops.

    Returns
    -------
    BifurcationCurve
        Never raises for numerical reasons: a failure ends a direction with
        its status and message (``ends``); a failed start gives an empty curve.
    """
    if options is None:
        options = ContinuationOptions()
    elif isinstance(options, dict):
        options = ContinuationOptions.from_dict(options)
    if curve_options is None:
        curve_options = CurveOptions()
    elif isinstance(curve_options, dict):
        curve_options = CurveOptions.from_dict(curve_options)
    kind = _curve_kind(kind)
    lo2, hi2 = (float(v) for v in p2_range)
    lo1, hi1 = (float(v) for v in p1_range)
    if not lo1 < hi1:
        raise ValueError(f"p1_range must satisfy lo < hi, got ({lo1}, {hi1})")
    if not lo1 <= p1_0 <= hi1:
        raise ValueError(f"the start {p1}={p1_0} is outside its range ({lo1}, {hi1})")
    u0 = np.asarray(u0, dtype=float)
    if u0.shape != (hb.size,):
        raise ValueError(f"u0 must have shape ({hb.size},), got {u0.shape}")
    umax = float(np.max(np.abs(u0))) if u0.size else 0.0
    problem = SingularityProblem(hb, kind, p1, p2, curve_options.fd_step, curve_options.detect, u_scale=umax,
                                 p1_scale=(hi1 - lo1) if math.isfinite(hi1 - lo1) else max(abs(p1_0), 1.0))
    z0 = np.concatenate([u0, [float(p1_0)]])
    problem.initialize_borders(z0, p2_0)
    b0, c0 = problem.b.copy(), problem.c.copy()
    opts = options.replace(detect_folds=False, detect_branch_points=False)
    events = _events(problem, curve_options.detect)
    left: dict = {}

    def make_callback(side: int):
        def cb(branch: Branch, i: int):
            z = branch.unknowns[i]
            problem.update_borders(z, float(branch.parameter[i]))
            q = float(z[-1])
            if i > 0 and not lo1 <= q <= hi1:
                left[side] = hi1 if q > hi1 else lo1
                return False
            return True if callback is None else callback(branch, i)

        return cb

    def run(d, z, lam, **kw):
        return continuation(problem, z, lam, (lo2, hi2), opts.replace(direction=d), parameter_name=p2,
                            events=events, monitors=[problem.monitor], callback=make_callback(d), **kw)

    runs = []  # (direction, branch)
    ends = []
    directions = (1, -1) if curve_options.both_ways else (options.direction,)
    start_solved = None
    for d in directions:
        problem.set_borders(b0, c0)
        if start_solved is None:
            br = run(d, z0, p2_0)
            if len(br):
                start_solved = (br.unknowns[0].copy(), float(br.parameter[0]), br.tangents[0].copy())
        else:
            # the other way: the reversed start tangent (the sign of dp2 alone is ambiguous where the curve
            # is tangent to p2 = const at the start)
            br = run(d, start_solved[0], start_solved[1], solve_start=False, tangent=-start_solved[2])
        status, message = br.status.value, br.message
        if br.status in (BranchStatus.STEP_TOO_SMALL, BranchStatus.NEWTON_FAILED) and len(br):
            jump = _jump_ahead(problem, br)
            if jump is not None:
                message += (f"; the residual jumps by {jump[0]:.1e} within a step of {jump[1]:g} along the curve: the "
                            f"discretised equations are discontinuous there (a time sample at a switching "
                            f"surface of a non-smooth force, e.g. contact onset), and the curve of the "
                            f"truncated problem does not continue across it")
        if d in left:
            status = BranchStatus.RANGE_END.value
            message = f"reached the end of the {p1} range at {p1}={left[d]:.10g}"
        runs.append((d, br))
        ends.append({"side": "forward" if d > 0 else "backward", "status": status, "message": message})
        if not len(br) or br.status is BranchStatus.CLOSED_LOOP or (
                br.status is BranchStatus.INTERRUPTED and d not in left):
            break
    return _assemble(problem, hb, kind, (p1, p2), runs, ends, left, curve_options)


def _jump_ahead(problem: SingularityProblem, br: Branch):
    """``(jump, step)``: a residual jump within a tiny step along the tangent past the last point, or None.

    Along the tangent a smooth residual grows only quadratically (below the
    Newton tolerance for steps up to 1e-7 in scaled arclength); a jump above
    ``1e3 * newton_tol`` there is a discontinuity of the equations.
    """
    m1 = problem.m + 1
    su = np.broadcast_to(np.asarray(br.info.get("unknown_scale", 1.0), float), (m1,))
    sl = float(br.info.get("parameter_scale", 1.0))
    z, lam, t = br.unknowns[-1], float(br.parameter[-1]), br.tangents[-1]
    tol = float(br.info.get("options", {}).get("newton_tol", 1e-10))
    try:
        F0 = problem.residual(z, lam)
        for step in (1e-9, 1e-8, 1e-7):
            F1 = problem.residual(z + step * t[:m1] * su, lam + step * t[m1] * sl)
            jump = float(np.max(np.abs(F1 - F0)))
            if jump > 1e3 * tol:
                return jump, step
    except NUMERICAL_ERRORS:
        return None
    return None


def _land(problem: SingularityProblem, za, la, zb, lb, bound: float, tol: float):
    """Solve ``(R, g) = 0`` with ``p1 = bound`` fixed and ``(u, p2)`` free, from the chord."""
    m = problem.m
    t = (bound - za[m]) / (zb[m] - za[m])
    y0 = np.concatenate([(1 - t) * za[:m] + t * zb[:m], [(1 - t) * la + t * lb]])

    def fun(y):
        z = np.concatenate([y[:m], [bound]])
        F, Jz, Jl = problem.linearize(z, y[m])
        A = np.empty((m + 1, m + 1))
        A[:, :m] = Jz[:, :m]
        A[:, m] = Jl
        return F, A

    res = newton(fun, y0, tol, 20)
    if not res.converged:
        return None
    return np.concatenate([res.x[:m], [bound]]), float(res.x[m])


def _halves(problem, runs, ends, left, curve_options):
    """Per traced direction: its points (landed on a p1 bound if asked) and special points."""
    out = []
    m1 = problem.m + 1
    for j, (d, br) in enumerate(runs):
        P = len(br)
        Z = np.array(br.unknowns).reshape(P, m1)
        L = np.array(br.parameter, dtype=float)
        T = np.array(br.tangents).reshape(P, m1 + 1) * (1.0 if d > 0 else -1.0)  # along the curve's order
        sps = [sp for sp in br.special_points if sp.kind is not SpecialKind.START]
        if d in left and P >= 2:
            landed = None
            if curve_options.land_on_bounds:
                problem.initialize_borders(Z[-1], L[-1])
                landed = _land(problem, Z[-2], L[-2], Z[-1], L[-1], left[d], 1e-10)
            if landed is not None:
                Z[-1], L[-1] = landed
                ends[j]["message"] += " (landed on the bound)"
            else:
                ends[j]["message"] += " (first point beyond the bound)"
            sps.append(SpecialPoint(SpecialKind.END, float(L[-1]), Z[-1].copy(), (L[-1], L[-1]), P - 1, 0.0,
                                    message=ends[j]["message"], event="end"))
        elif P and not any(sp.kind is SpecialKind.END for sp in sps):
            # a direction that stopped early: its last point, with the reason
            sps.append(SpecialPoint(SpecialKind.END, float(L[-1]), Z[-1].copy(), (L[-1], L[-1]), P - 1, 0.0,
                                    located=False, message=f"{ends[j]['status']}: {ends[j]['message']}",
                                    event="end"))
        out.append((Z, L, T, sps))
    return out


def _assemble(problem, hb, kind, names, runs, ends, left, curve_options) -> BifurcationCurve:
    """Join the backward half (reversed) and the forward half into one curve."""
    m = problem.m
    halves = _halves(problem, runs, ends, left, curve_options)
    Zf, Lf, Tf, spf = halves[0]
    Zb, Lb, Tb, spb = (halves[1] if len(halves) > 1 and len(halves[1][1])
                       else (np.zeros((1, m + 1)), np.zeros(1), np.zeros((1, m + 2)), []))
    n_back = len(Lb) - 1
    Z = np.concatenate([Zb[:0:-1], Zf]) if len(Lf) else np.zeros((0, m + 1))
    L = np.concatenate([Lb[:0:-1], Lf]) if len(Lf) else np.zeros(0)
    T = np.concatenate([Tb[:0:-1], Tf]) if len(Lf) else np.zeros((0, m + 2))
    info = runs[0][1].info if runs else {}
    su = np.broadcast_to(np.asarray(info.get("unknown_scale", 1.0), float), (m + 1,)).copy()
    scales = (su, float(info.get("parameter_scale", 1.0)))
    specials: list[CurvePoint] = []
    for sps, forward in ((spf, True), (spb, False)):
        P = len(Lf) if forward else len(Lb)
        for sp in sps:
            at_end = sp.kind is SpecialKind.END
            if forward:
                index = n_back + (P - 1 if at_end else sp.index)
            else:
                index = 0 if at_end else max(n_back - sp.index - 1, 0)
            specials.append(CurvePoint(
                kind=sp.kind, p1=float(sp.unknowns[m]), p2=float(sp.parameter), unknowns=sp.unknowns[:m].copy(),
                index=int(index), located=bool(sp.located), message=sp.message,
                data={k: v for k, v in (sp.data or {}).items() if k == "parameter"},
            ))
    specials = _dedupe(specials, problem)
    if len(L):
        specials.append(CurvePoint(SpecialKind.START, float(Z[n_back, m]), float(L[n_back]), Z[n_back, :m].copy(),
                                   n_back, message="start point"))
    # start and end points sit on their row, the others between their row and the next
    rank = {SpecialKind.START: 0.0, SpecialKind.END: 0.1}
    specials.sort(key=lambda p: p.index + rank.get(p.kind, 0.5))
    return BifurcationCurve(
        kind=kind, parameters=tuple(names), nu=hb.nu, harmonics=hb.H, p1=Z[:, m].copy(), p2=L,
        unknowns=Z[:, :m].copy(), special_points=specials, ends=ends, start_index=n_back, problem=problem,
        branches=[br for _, br in runs], tangents=T, scales=scales,
    )


def _dedupe(points: list, problem) -> list:
    """A cusp is also an extremum of both parameters: keep the cusp only."""
    cusps = [p for p in points if p.kind is SpecialKind.CUSP]
    scale1 = max(problem.p1_scale, 1e-300)
    out = []
    for p in points:
        if p.kind is SpecialKind.EXTREMUM and any(abs(p.p1 - c.p1) <= 1e-6 * scale1 and
                                                  abs(p.p2 - c.p2) <= 1e-6 * max(1.0, abs(c.p2)) for c in cusps):
            continue
        out.append(p)
    return out


def curve_from_point(hb: HarmonicBalance, point: SpecialPoint, p2: str, p2_range, p1_range=(-math.inf, math.inf),
                     options=None, curve_options=None, *, kind: CurveKind | str | None = None,
                     callback=None) -> BifurcationCurve:
    """Continue a located fold or period doubling of a one-parameter branch of ``hb``.

    Parameters
    ----------
    hb : HarmonicBalance
        The problem of the branch (its ``parameter`` is ``p1``).
    point : SpecialPoint
        Of kind ``fold`` or ``pd`` (or ``stability`` classified so).
    p2 : str
        The second parameter; its current value is ``hb``'s.
    kind : CurveKind, optional
        Default: from the point.

    Other parameters are those of :func:`continue_curve`.
    """
    if kind is None:
        pk = special_point_kind(point)
        if pk.value not in ("fold", "pd"):
            raise ValueError(f"a curve starts at a 'fold' or 'pd' point, not at {pk.value!r}")
        kind = CurveKind(pk.value)
    p2_0 = float(hb.p0[hb.model.parameter_index(p2)])
    return continue_curve(hb, kind, hb.parameter, p2, point.unknowns, float(point.parameter), p2_0, p2_range,
                          p1_range, options, curve_options, callback=callback)
