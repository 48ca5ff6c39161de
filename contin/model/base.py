"""Models: linear matrices plus registered, compiled time-domain elements.

A model describes

    M(p) x'' + C(p) x' + K(p) x + f_nl(x, x', tau; p) = f_ext(tau; p),

with ``tau = w t`` the excitation phase and ``p`` the parameter vector. The
linear part is applied exactly in the frequency domain; ``f_nl`` is a sum of
*force elements* and ``f_ext`` a sum of *excitation elements*, each evaluated
on time samples by a numba kernel. Elements are looked up by name in a
registry (:func:`register_force`, :func:`register_excitation`), so a new force
law is a new class, never a branch in the core: the class also says how a
scene item builds it and how the time simulation compiles it
(:mod:`contin.model.elements.registry`; ``docs/howto/contact-element.md``).

A model is built from the *effects* a scene enables: only the elements and
matrix terms of those effects exist in the model, so a disabled effect costs
nothing and cannot leak into results.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar, Mapping, Sequence

import numpy as np

from contin.model import expressions as ex
from contin.util.naming import suggest

__all__ = [
    "Monomial",
    "ParametricMatrix",
    "ForceElement",
    "Switching",
    "ExcitationElement",
    "Model",
    "register_force",
    "register_excitation",
    "FORCE_ELEMENTS",
    "EXCITATION_ELEMENTS",
    "suggest",
]


@dataclass(frozen=True)
class Monomial:
    """``const * prod_j p[j]**powers[j]``: a coefficient that depends on parameters.

    Parameters
    ----------
    const : float
    powers : tuple of (int, int)
        Pairs ``(parameter index, integer power)``.
    """

    const: float = 1.0
    powers: tuple[tuple[int, int], ...] = ()

    @classmethod
    def parse(cls, text, names: Sequence[str], where: str = "coefficient") -> "Monomial":
        """Parse a number, or a product of parameter powers such as ``"-0.5*k*w**2"`` or ``"g/2"``.

        The text is read by the expression parser, as in a scene
        (:func:`contin.model.expressions.parse_monomial`).

        Raises
        ------
        ValueError
            Naming ``where`` and what is wrong (an unknown name, or an
            expression that is no product of parameter powers).
        """
        return cls(*ex.parse_monomial(text, names, where))

    def value(self, p: np.ndarray) -> float:
        v = self.const
        for j, e in self.powers:
            v *= p[j] ** e
        return float(v)  # a Python float: numba's dispatch types numpy scalars far more slowly

    def derivative(self, p: np.ndarray, k: int) -> float:
        """``d value / d p[k]``."""
        v = self.const
        hit = False
        for j, e in self.powers:
            if j == k:
                hit = True
                v *= e * p[j] ** (e - 1) if e != 1 else 1.0
            else:
                v *= p[j] ** e
        return v if hit else 0.0

    def depends_on(self, k: int) -> bool:
        return any(j == k for j, _ in self.powers)

    def text(self, names: Sequence[str]) -> str:
        """As written in descriptions, e.g. ``-0.5*k*w**2``."""
        return f"{self.const:g}" + "".join(f"*{names[j]}" + (f"**{e}" if e != 1 else "") for j, e in self.powers)


@dataclass(frozen=True)
class ParametricMatrix:
    """``sum_t coef_t(p) * A_t``: a matrix that depends on parameters.

    Parameters
    ----------
    n : int
        Size of the (square) matrix.
    terms : tuple of (Monomial, ndarray (n, n))
    """

    n: int
    terms: tuple = ()

    @classmethod
    def from_entries(cls, entries, names: Sequence[str], where: str) -> "ParametricMatrix":
        """Build from a nested list of numbers or parameter products."""
        arr = list(entries)
        n = len(arr)
        terms = []
        for i, row in enumerate(arr):
            if not isinstance(row, (list, tuple)) or len(row) != n:
                raise ValueError(f"{where}: expected a {n}x{n} matrix, row {i} is {row!r}")
            for j, e in enumerate(row):
                mono = Monomial.parse(e, names, f"{where}[{i}][{j}]")
                if mono.const == 0.0:
                    continue
                A = np.zeros((n, n))
                A[i, j] = 1.0
                terms.append((mono, A))
        return cls(n, tuple(terms))

    def value(self, p: np.ndarray) -> np.ndarray:
        out = np.zeros((self.n, self.n))
        for mono, A in self.terms:
            out += mono.value(p) * A
        return out

    def derivative(self, p: np.ndarray, k: int) -> np.ndarray:
        out = np.zeros((self.n, self.n))
        for mono, A in self.terms:
            if mono.depends_on(k):
                out += mono.derivative(p, k) * A
        return out

    def __add__(self, other: "ParametricMatrix") -> "ParametricMatrix":
        return ParametricMatrix(self.n, self.terms + other.terms)


@dataclass(frozen=True, eq=False)
class Switching:
    """Switching functions of a non-smooth force element at ``N`` states.

    Function ``i`` is positive where law ``i`` of the element is active (in
    contact) and non-positive where it is not; its zero set is a switching
    surface ``h_i(x, x') = 0`` of the state space. The element's
    :meth:`ForceElement.evaluate` must apply law ``i`` exactly where
    ``h_i > 0`` (with the same floating-point arithmetic), so that the
    monodromy can tell which law was evaluated at a state on the surface.
    Surfaces are autonomous (no explicit dependence on ``tau``).

    Attributes
    ----------
    value : ndarray, shape (N, m)
        ``h_i`` at each state.
    grad_x, grad_xd : ndarray, shape (N, m, n)
        ``dh_i/dx`` and ``dh_i/dx'`` (of the branch of ``h_i`` that is
        attained where ``h_i`` is a minimum of several expressions).
    difference : ndarray, shape (N, m, n)
        The element's force with law ``i`` active minus the force with it
        inactive, both at the given state (used to evaluate a law beyond its
        surface).
    jump : ndarray, shape (N, m, n)
        The same difference taken on the surface: the part of the active law
        that vanishes there (proportional to ``h_i``) is left out, so that the
        jump of ``f_nl`` is exact at a located crossing and exactly zero where
        the law is continuous across the surface (a clipped force reaching
        zero).
    difference_x, difference_xd : ndarray, shape (N, m, n, n), optional
        Derivatives of ``difference`` with respect to ``x`` and ``x'``; an
        element that gives them has its crossings resolved inside the sample
        intervals by the harmonic balance (:mod:`contin.hb.crossings`).
    """

    value: np.ndarray
    grad_x: np.ndarray
    grad_xd: np.ndarray
    difference: np.ndarray
    jump: np.ndarray
    difference_x: np.ndarray | None = None
    difference_xd: np.ndarray | None = None


class ForceElement:
    """A time-domain internal force (left-hand side), evaluated on samples.

    Subclasses implement :meth:`evaluate` and :meth:`evaluate_dp` by calling a
    numba kernel; they accumulate into the output arrays. Non-smooth laws also
    implement :meth:`switching_functions`, through which the monodromy locates
    the switches and builds saltation matrices
    (:mod:`contin.stability.saltation`).
    """

    kind: ClassVar[str] = ""
    #: polynomial degree in (x, x'), or None for non-polynomial (non-smooth) laws
    degree: int | None = None

    def evaluate(self, x, xd, tau, p, f, dfdx, dfdxd) -> None:
        """Accumulate the force and its derivatives.

        Parameters
        ----------
        x, xd : ndarray, shape (N, n)
            Displacements and velocities at the samples.
        tau : ndarray, shape (N,)
            Excitation phase ``w t`` at the samples.
        p : ndarray, shape (P,)
        f : ndarray, shape (N, n)
        dfdx, dfdxd : ndarray, shape (N, n, n)
        """
        raise NotImplementedError

    def evaluate_dp(self, x, xd, tau, p, k, dfdp) -> None:
        """Accumulate ``df/dp[k]`` into ``dfdp`` (shape (N, n))."""
        raise NotImplementedError

    def depends_on(self, k: int) -> bool:
        """Whether the force depends explicitly on parameter ``k``."""
        raise NotImplementedError

    def tau_orders(self) -> tuple:
        """Multiples of ``tau`` at which the force varies explicitly in time."""
        return ()

    def active_dofs(self) -> tuple | None:
        """The dofs the force acts on or depends on (through ``x`` or ``x'``), or None if unknown.

        The dofs outside every element's set carry linear terms only, and the
        harmonic balance eliminates them exactly (:mod:`contin.hb.condensation`).
        An element that leaves a dof out wrongly makes that elimination wrong,
        so the default is None: all dofs kept.

        Returns
        -------
        tuple of int, sorted, or None
        """
        return None

    def remapped(self, kept: tuple) -> "ForceElement | None":
        """A copy acting on the model of the dofs ``kept`` alone, or None if the element cannot be moved.

        Dof ``kept[j]`` becomes dof ``j``; ``kept`` holds every dof of
        :meth:`active_dofs`. The condensed harmonic balance evaluates its
        forces on that small model, so that no sampled array has the full
        model's size (:mod:`contin.hb.condensation`).

        Parameters
        ----------
        kept : tuple of int, sorted
        """
        return None

    def contact_parameters(self, param_names: Sequence[str]) -> "tuple[str | None, str | None] | None":
        """The model parameters that are this element's contact stiffness and clearance; None if it is no contact.

        A start procedure that softens a contact and stiffens it again by
        continuation (:func:`contin.bifurcation.start.contact_start`) asks the
        element which parameters to move, so the generic code names none.

        Parameters
        ----------
        param_names : sequence of str
            The model's parameters, in the order of the parameter vector.

        Returns
        -------
        (stiffness, clearance) or None
            Each a parameter name, or None where that coefficient is not one
            parameter alone (a number, or an expression such as ``2*k``).
        """
        return None

    def switching_functions(self, x, xd, tau, p) -> "Switching | None":
        """Switching surfaces of a piecewise-defined law, or None for a smooth one.

        Parameters
        ----------
        x, xd : ndarray, shape (N, n)
        tau : ndarray, shape (N,)
        p : ndarray, shape (P,)

        Returns
        -------
        Switching or None
        """
        return None

    def switching_dp(self, x, xd, tau, p, k):
        """Derivatives of the switching data with respect to parameter ``k``.

        Returns
        -------
        value_p : ndarray, shape (N, m)
            ``dh_i/dp_k``.
        difference_p : ndarray, shape (N, m, n)
            ``d(difference)/dp_k``.
        """
        raise NotImplementedError(f"force element '{self.kind}' gives no parameter derivative of its switching data")

    def describe(self, dof_names: Sequence[str], param_names: Sequence[str]) -> str:
        return self.kind

    # -- what the scene and the time simulation need (contin.model.elements.registry) ---------
    #: forms of a custom model's ``forces`` item that build this element
    #: (:class:`contin.model.elements.registry.SceneKeys`); none: not available in scenes
    scene_keys: ClassVar[tuple] = ()

    @classmethod
    def from_scene(cls, item: Mapping, key: str, scene):
        """The element of a checked ``forces`` item (or a :class:`~contin.model.elements.registry.Joined` part).

        Parameters
        ----------
        item : mapping
            The item, its keys checked against :attr:`scene_keys`.
        key : str
            Its dotted key, ``model.forces[i]``.
        scene : contin.model.elements.registry.SceneContext
            Parses and checks values, naming their keys in errors.
        """
        raise NotImplementedError(f"force element '{cls.kind}' cannot be built from a scene")

    @classmethod
    def join(cls, parts: list, key: str, scene) -> "ForceElement":
        """One element of the :class:`~contin.model.elements.registry.Joined` parts of several items."""
        raise NotImplementedError(f"force element '{cls.kind}' joins no parts")

    def compiled_form(self):
        """Its :class:`contin.model.elements.registry.CompiledForm` for time simulation, or None if it has none."""
        return None


class ExcitationElement:
    """A time-domain external force (right-hand side) that does not depend on x."""

    kind: ClassVar[str] = ""

    def evaluate(self, tau, p, f) -> None:
        """Accumulate ``f_ext`` at the phases ``tau`` (shape (N,)) into ``f`` (N, n)."""
        raise NotImplementedError

    def evaluate_dp(self, tau, p, k, dfdp) -> None:
        raise NotImplementedError

    def depends_on(self, k: int) -> bool:
        raise NotImplementedError

    def max_order(self) -> float:
        """Highest harmonic of ``tau`` present (to check the sample count)."""
        return 0.0

    def describe(self, dof_names: Sequence[str], param_names: Sequence[str]) -> str:
        return self.kind

    #: forms of a custom model's ``excitation`` item that build this element, each selected by its
    #: ``marker`` key (:class:`contin.model.elements.registry.SceneKeys`)
    scene_keys: ClassVar[tuple] = ()

    @classmethod
    def from_scene(cls, item: Mapping, key: str, scene):
        """The element of a checked ``excitation`` item; see :meth:`ForceElement.from_scene`."""
        raise NotImplementedError(f"excitation element '{cls.kind}' cannot be built from a scene")

    @classmethod
    def join(cls, parts: list, key: str, scene) -> "ExcitationElement":
        """One element of the :class:`~contin.model.elements.registry.Joined` parts of several items."""
        raise NotImplementedError(f"excitation element '{cls.kind}' joins no parts")

    def compiled_form(self):
        """Its :class:`contin.model.elements.registry.CompiledForm` for time simulation, or None if it has none."""
        return None


FORCE_ELEMENTS: dict[str, type] = {}
EXCITATION_ELEMENTS: dict[str, type] = {}


def _registrar(registry: dict, base: type, kind: str):
    def deco(cls):
        if not issubclass(cls, base):
            raise TypeError(f"{cls.__name__} must derive from {base.__name__} to be registered as '{kind}'")
        cls.kind = kind
        registry[kind] = cls
        return cls

    return deco


def register_force(kind: str):
    """Class decorator: register a :class:`ForceElement` under ``kind``."""
    return _registrar(FORCE_ELEMENTS, ForceElement, kind)


def register_excitation(kind: str):
    """Class decorator: register an :class:`ExcitationElement` under ``kind``."""
    return _registrar(EXCITATION_ELEMENTS, ExcitationElement, kind)


@dataclass
class Model:
    """A mechanical model assembled from the enabled effects.

    Parameters
    ----------
    name : str
    dof_names : tuple of str, length n
    parameters : dict
        Parameter names to values, in a fixed order (the parameter vector).
    mass, damping, stiffness : ParametricMatrix
        Linear matrices; ``damping`` includes gyroscopic terms.
    forces : list of ForceElement
    excitations : list of ExcitationElement
    frequency : str
        Name of the excitation-frequency parameter ``w``.
    effects : tuple of str
        The effects this instance was built with (for reports).
    terms : list of str
        Human-readable list of the terms in the residual.
    symbols : dict
        Symbols of names in figures (see the attribute's comment).
    """

    name: str
    dof_names: tuple
    parameters: dict
    mass: ParametricMatrix
    damping: ParametricMatrix
    stiffness: ParametricMatrix
    forces: list = field(default_factory=list)
    excitations: list = field(default_factory=list)
    frequency: str = "w"
    effects: tuple = ()
    terms: list = field(default_factory=list)
    #: minimum AFT sample count requested by the model (e.g. for contact)
    min_samples: int = 0
    #: optional ``observables(u, n_dof, nu) -> dict`` of model-specific columns for
    #: ``branches.csv`` (named in ``observable_names``), e.g. whirl radii
    observables: object = None
    observable_names: tuple = ()
    #: node pairs ``(x, y)`` (dof indices) by part name whose whirl radii the rows of a rotor carry
    #: (:mod:`contin.model.whirl`; a torus' own whirls too)
    whirl_parts: dict = field(default_factory=dict)
    #: optional ``start(hb, lam0) -> u0`` for models whose linear solution is no
    #: usable start (stiff contact); raises :class:`contin.bifurcation.start.HomotopyFailed`
    start: object = None
    #: linear observables ``y = c . x`` by name, each ``c`` of shape (n,) (e.g. a
    #: structure's displacement at a point, from its shape functions); a backbone
    #: can be traced in the amplitude of one
    linear_observables: dict = field(default_factory=dict)
    #: parameters built into the model's structure (a number of terms, a position
    #: that sets the matrices); they are neither continued nor overridden: a new
    #: value needs a new model
    structural: tuple = ()
    #: how figures write names (:mod:`contin.output.labels`): parameter, dof or observable name ->
    #: mathtext without dollars (``{"w": r"\Omega"}``), or a phrase holding ``$``; a key
    #: ``parameter:NAME`` for a parameter that shares its name with an observable
    symbols: dict = field(default_factory=dict)

    registry_kind: ClassVar[str] = "model"

    def __post_init__(self):
        self.dof_names = tuple(self.dof_names)
        n = len(self.dof_names)
        for label, mat in (("mass", self.mass), ("damping", self.damping), ("stiffness", self.stiffness)):
            if mat.n != n:
                raise ValueError(f"model.{label}: expected a {n}x{n} matrix for dofs {list(self.dof_names)}, found {mat.n}x{mat.n}")
        if self.frequency not in self.parameters:
            raise ValueError(
                f"model: the excitation frequency parameter '{self.frequency}' is not among the parameters "
                f"{list(self.parameters)}"
            )
        for name, c in self.linear_observables.items():
            if np.shape(c) != (n,):
                raise ValueError(f"model: linear observable '{name}' needs {n} coefficients, found shape {np.shape(c)}")
        for name in self.structural:
            if name not in self.parameters:
                raise ValueError(f"model: structural parameter '{name}' is not among the parameters")

    def check_variable(self, name: str | None, overrides: Mapping[str, float] | None = None) -> None:
        """Refuse to vary a structural parameter (as ``name`` or through ``overrides``).

        Raises
        ------
        ValueError
            Naming the parameter and saying that the model must be rebuilt.
        """
        if name in self.structural:
            raise ValueError(
                f"parameter '{name}' of model '{self.name}' is built into its structure and cannot be continued; "
                f"build one model per value (structural parameters: {list(self.structural)})"
            )
        for k, v in (overrides or {}).items():
            if k in self.structural and float(v) != float(self.parameters[k]):
                raise ValueError(
                    f"parameter '{k}' of model '{self.name}' is built into its structure (value "
                    f"{self.parameters[k]:g}); build a new model for {k}={float(v):g}"
                )

    @property
    def n_dof(self) -> int:
        return len(self.dof_names)

    @property
    def param_names(self) -> tuple:
        return tuple(self.parameters)

    def parameter_vector(self, overrides: Mapping[str, float] | None = None) -> np.ndarray:
        """Parameter values as a float vector, with optional overrides by name."""
        p = np.array([float(v) for v in self.parameters.values()], dtype=float)
        for k, v in (overrides or {}).items():
            p[self.parameter_index(k)] = float(v)
        return p

    def parameter_index(self, name: str) -> int:
        try:
            return self.param_names.index(name)
        except ValueError:
            raise ValueError(
                f"unknown parameter '{name}' for model '{self.name}'{suggest(name, self.param_names)}; "
                f"expected one of {list(self.param_names)}"
            ) from None

    def dof_index(self, name: str) -> int:
        try:
            return self.dof_names.index(name)
        except ValueError:
            raise ValueError(
                f"unknown degree of freedom '{name}'{suggest(name, self.dof_names)}; expected one of {list(self.dof_names)}"
            ) from None

    def linear(self, p: np.ndarray):
        """``(M, C, K)``, each of shape (n, n)."""
        return self.mass.value(p), self.damping.value(p), self.stiffness.value(p)

    def linear_dp(self, p: np.ndarray, k: int):
        """Derivatives of ``(M, C, K)`` with respect to ``p[k]``."""
        return self.mass.derivative(p, k), self.damping.derivative(p, k), self.stiffness.derivative(p, k)

    @property
    def degree(self) -> int | None:
        """Highest polynomial degree of the forces (None if any is non-polynomial)."""
        d = 1
        for el in self.forces:
            if el.degree is None:
                return None
            d = max(d, el.degree)
        return d

    def describe(self) -> str:
        """A multi-line description of the terms in the equations of motion."""
        lines = [f"model '{self.name}': {self.n_dof} dof {list(self.dof_names)}"]
        lines += [f"  {t}" for t in self.terms]
        for el in self.forces:
            lines.append("  force: " + el.describe(self.dof_names, self.param_names))
        for el in self.excitations:
            lines.append("  excitation: " + el.describe(self.dof_names, self.param_names))
        return "\n".join(lines)
