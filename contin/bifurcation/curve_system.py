"""The extended systems of fold and period-doubling curves: minimally augmented, with their test functions.

A fold or a period doubling of periodic solutions, followed in two
parameters ``(p1, p2)``, traces a curve: the solution set of an extended
system.

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

:class:`SingularityProblem` is that system for the engine (its monitor
evaluates the test functions of the codimension-two points,
:mod:`contin.bifurcation.two_parameter`); :class:`FlipTestEvent` is the
flip matrix's test function on a one-parameter branch.
"""

from __future__ import annotations

import enum

import numpy as np
from scipy.linalg import lu_factor, lu_solve

from contin.engine.branch import SpecialKind
from contin.engine.events import Event, PointInfo
from contin.hb.derivatives import HBDerivatives, MatrixKind
from contin.hb.problem import HarmonicBalance

__all__ = ["CODIM2_KINDS", "CurveKind", "FlipTestEvent", "SingularityProblem", "as_curve_kind", "bordered_test"]


class CurveKind(str, enum.Enum):
    """Kind of a two-parameter curve."""

    #: folds (limit points, multiplier +1): the boundary of a jump region
    FOLD = "fold"
    #: period doublings (multiplier -1): the boundary of a 2 nu-subharmonic region
    PD = "pd"
    #: Neimark-Sacker (a pair of multipliers exp(+-i theta)): the boundary of a torus' region (shooting only)
    NS = "ns"

    def __str__(self) -> str:
        return self.value


def as_curve_kind(kind) -> CurveKind:
    try:
        return CurveKind(kind)
    except ValueError:
        raise ValueError(f"curve kind must be 'fold', 'pd' or 'ns', got {kind!r}") from None


_MATRIX = {CurveKind.FOLD: MatrixKind.JACOBIAN, CurveKind.PD: MatrixKind.FLIP}
CODIM2_KINDS = ("cusp", "fold_flip", "extremum", "resonance")


def bordered_test(A: np.ndarray, b: np.ndarray, c: np.ndarray):
    """``(v, g, w)`` of the bordered systems of the module docstring for the matrix ``A`` (k, k).

    ``[[A, b], [c, 0]] [v; g] = [0; 1]`` and its conjugate transpose for ``w``; ``c`` is the bordering row
    itself. Real or complex (``g`` complex then); one LU. Raises ``LinAlgError`` for a non-finite or exactly
    singular bordered matrix.
    """
    k = A.shape[0]
    dtype = complex if np.iscomplexobj(A) or np.iscomplexobj(b) or np.iscomplexobj(c) else float
    B = np.zeros((k + 1, k + 1), dtype=dtype)
    B[:k, :k] = A
    B[:k, k] = b
    B[k, :k] = c
    if not np.all(np.isfinite(B)):
        raise np.linalg.LinAlgError("non-finite matrix in the bordered test function")
    lu = lu_factor(B, check_finite=False)
    if np.any(np.diagonal(lu[0]) == 0.0):
        raise np.linalg.LinAlgError("singular bordered matrix of the test function")
    e = np.zeros(k + 1, dtype=dtype)
    e[k] = 1.0
    vg = lu_solve(lu, e, check_finite=False)
    wh = lu_solve(lu, e, trans=2 if dtype is complex else 1, check_finite=False)
    return vg[:k], vg[k], wh[:k]


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
        self.kind = as_curve_kind(kind)
        if self.kind not in _MATRIX:
            raise ValueError(f"the {self.kind.value} curve by harmonic balance is not built: follow it by shooting "
                             f"(contin.bifurcation.shooting_curve_system)")
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
        v, g, w = bordered_test(self._matrix(u, p, J), self.b, self.c)
        g = float(g)
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
