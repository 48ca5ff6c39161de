"""What an element gives besides its law: its scene keys and its compiled time-domain form.

A force or excitation element lives in one file that holds everything the
package needs of it, and the core looks it up by kind in the registries of
:mod:`contin.model.base` (:func:`~contin.model.base.register_force`,
:func:`~contin.model.base.register_excitation`), never by a branch on kinds:

- its law for the harmonic balance (``evaluate``, ``evaluate_dp``, and for a
  law that switches, ``switching_functions`` and ``switching_dp``);
- its **scene keys** (:class:`SceneKeys`, the class attribute
  ``scene_keys``) and the classmethod ``from_scene(item, key, scene)`` that
  checks a custom model's ``forces`` / ``excitation`` item and builds the
  element. ``scene`` is the custom model's builder (:class:`SceneContext`),
  which parses expressions and coefficients and names the key of any error;
- its **compiled form** (:class:`CompiledForm`, returned by the element's
  ``compiled_form()``): the lines the time simulation
  (:mod:`contin.timedomain.simulation`) compiles into its right-hand side and
  switching functions.

This module holds those shared types; it imports no layer above the model, so
no element imports the time domain or the scene.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Mapping

import numpy as np

from contin.model.base import EXCITATION_ELEMENTS, FORCE_ELEMENTS, ExcitationElement, ForceElement

__all__ = ["SceneKeys", "Joined", "SceneContext", "CompiledForm", "scene_forms", "kinds_with_compiled_form",
           "item_label", "shorten", "literal", "int_array", "float_array"]


# ---------------------------------------------------------------- scene keys
@dataclass(frozen=True)
class SceneKeys:
    """The keys of one form of a custom model's ``forces`` or ``excitation`` item.

    Parameters
    ----------
    keys : mapping of str to bool
        Every key the item may have, mapped to whether it is required (in the
        order they are listed in messages). A force item lists ``type``.
    example : str
        A YAML mapping of this form, shown when an item is not a mapping.
    marker : str, optional
        For an excitation: the key whose presence selects this form
        (``expr``, ``amplitude``, ...). Force items are selected by their
        ``type``, which is the element's registered kind.
    default : bool
        For a force: the form of an item without ``type`` (only one).
    """

    keys: Mapping[str, bool] = field(default_factory=dict)
    example: str = ""
    marker: str | None = None
    default: bool = False


@dataclass(frozen=True)
class Joined:
    """A part of a scene item built together with the other items' parts of ``cls`` into one element.

    ``from_scene`` returns it instead of an element when the items of a kind
    make one element (all expression forces compile into one kernel); the
    builder then calls ``cls.join(parts, section_key, scene)`` once and puts
    the element before the others.
    """

    cls: type
    part: Any


class SceneContext:
    """What a custom model's builder offers an element building itself from a scene item.

    Implemented by :mod:`contin.scene.custom_model`. Every method checks a
    value found at the dotted ``key`` (``model.forces[2].clearance``) and
    raises the scene's error naming that key (and its YAML line) when the
    value is wrong. Raise :meth:`error` for a check of the element's own.

    Attributes
    ----------
    dofs : tuple of str
        The dof names.
    param_names : tuple of str
        The model's parameter vector (its independent parameters).
    p0 : ndarray, shape (P,)
        The default parameter values.
    """

    dofs: tuple = ()
    param_names: tuple = ()
    p0: np.ndarray = np.zeros(0)

    def error(self, key: str, expected: str, found: Any = None, hint: str = "") -> Exception:
        """The error to raise: ``key: expected EXPECTED, found FOUND`` and the hint."""
        raise NotImplementedError

    def dof(self, value, key: str) -> int:
        """Index of the dof named ``value``."""
        raise NotImplementedError

    def expression(self, value, key: str, allow_state: bool = False, allow_tau: bool = False,
                   what: str = "an expression of parameters"):
        """The expression tree (:class:`contin.model.expressions.Node`), dependent parameters inlined.

        ``allow_state`` admits the dofs and their velocities ``NAME_dot``,
        ``allow_tau`` the excitation phase ``tau``.
        """
        raise NotImplementedError

    def coefficient(self, value, key: str, what: str = "a number or an expression of parameters"):
        """A coefficient ``c(p)`` (``value``, ``derivative``, ``depends_on``), finite at the defaults."""
        raise NotImplementedError

    def number(self, value, key: str, default: float, minimum: float | None = None) -> float:
        """A finite number (``default`` when absent), at least ``minimum``."""
        raise NotImplementedError

    def boolean(self, value, key: str, default: bool = False) -> bool:
        """``true`` or ``false`` (``default`` when absent)."""
        raise NotImplementedError


def scene_forms(section: str) -> dict:
    """The item forms of a custom model's section, from the registries.

    Parameters
    ----------
    section : {'forces', 'excitation'}

    Returns
    -------
    dict
        Form name (a force's ``type``, an excitation's marker key) to
        ``(element class, SceneKeys)``, in the order of registration.
    """
    registry = FORCE_ELEMENTS if section == "forces" else EXCITATION_ELEMENTS
    forms = {}
    for kind, cls in registry.items():
        for keys in cls.scene_keys:
            forms[kind if section == "forces" else keys.marker] = (cls, keys)
    return forms


def item_label(key: str) -> str:
    """The label of the element built from the item at ``key`` (``model.forces[2]`` -> ``forces[2]``)."""
    return key.removeprefix("model.")


def shorten(value: Any, limit: int = 80):
    """``value`` as found in a message: a string cut at ``limit`` characters, other values as they are if short."""
    if isinstance(value, str):
        return value if len(value) <= limit else value[: limit - 3] + "..."
    text = repr(value)
    return value if len(text) <= limit else text[: limit - 3] + "..."


# ---------------------------------------------------------------- compiled forms
class CompiledForm:
    """How one element appears in the generated simulation module.

    Subclasses fill in the parts; the code generator calls them with ``tag``
    (a unique identifier prefix for module globals), ``c`` (index of the
    element's first entry in the constants vector ``cst``) and ``m`` (index of
    its first switching function / mode flag).

    Inside the generated right-hand side the names are: ``X``, ``V`` (shape
    (1, n) displacement and velocity), ``tau`` (float), ``TAU`` (shape (1,)),
    ``F`` (shape (1, n), internal force, accumulated), ``R`` (shape (n,),
    external force, accumulated), ``DUM`` (shape (1, n, n) scratch), ``p``
    (parameter vector), ``cst`` (constants), ``mode`` (int64 flags, 1 where a
    switching function's law is active), ``np`` (numpy). In the switching
    function the output is ``S`` (shape (n_switch_total,)).

    The force lines apply the law of the frozen ``mode`` (law ``i`` where
    ``mode[m + i] != 0``), not of the state's own side of the surface: the
    integrator locates the crossings (:mod:`contin.timedomain.simulation`).
    Lines may call numba kernels imported by :attr:`imports`, or be plain
    numba-compilable statements (nested blocks indented by four spaces). An
    array passed to a kernel that is not inlined is reference-counted at each
    call: the Jacobian and gradient lines, which run at every RK4 stage of a
    linearisation, do best to pass numbers (docs/howto/custom-models.md).
    """

    #: number of switching functions of the element
    n_switch = 0
    #: ``from ... import ...`` lines the code needs
    imports: tuple = ()
    #: helper kernels whose source is fingerprinted into the module (cache invalidation)
    kernels: tuple = ()
    #: an excitation whose lines are linear in its constants: the same lines with ``dcst`` for ``cst`` give its
    #: derivative in a parameter (the sensitivity of :mod:`contin.timedomain.variational`; otherwise shooting
    #: takes ``dR/dlambda`` by differences of the flow)
    linear_in_constants = False

    def __init__(self, element):
        self.element = element

    def constants(self, p: np.ndarray) -> list:
        """Parameter-dependent numbers, in the order the code reads them from ``cst``."""
        return []

    def globals(self, tag: str) -> list:
        """Module-level lines (structure arrays, frozen into the compiled code)."""
        return []

    def force_lines(self, tag: str, c: int, m: int) -> list:
        """Statements accumulating the internal force into ``F``."""
        return []

    def excitation_lines(self, tag: str, c: int) -> list:
        """Statements accumulating the external force into ``R``."""
        return []

    def switch_lines(self, tag: str, c: int, m: int) -> list:
        """Statements writing the switching functions ``S[m:m+n_switch]``."""
        return []

    def jacobian_lines(self, tag: str, c: int, m: int):
        """Statements accumulating ``d f_nl / dx`` into ``DX`` and ``d f_nl / dx'`` into ``DXD`` (shape (1, n, n)).

        The Jacobian of the frozen mode's law (a contact in mode 0 adds
        nothing, in mode 1 its law's Jacobian even past the surface), for the
        variational equations (:mod:`contin.timedomain.variational`). ``F`` is
        scratch there: lines may add the force to it. None (the default) when
        the element has no such lines: a Jacobian of a model holding it is
        refused by name, never taken as zero. Excitations depend on ``tau``
        alone and need none.
        """
        return None

    def switch_gradient_lines(self, tag: str, c: int, m: int):
        """Statements writing the gradients of the switching functions into ``G[m + i, :]`` (shape (NS, 2n)).

        ``G[m + i, j]`` is ``d S[m + i] / d y_j`` for the state ``y = (x, x')``,
        the normal of the surface in the saltation matrix. None (the default)
        for an element with switching functions but no gradient lines; an
        element without switching functions needs none.
        """
        return None if self.n_switch else []

    def force_dtau_lines(self, tag: str, c: int, m: int):
        """Statements accumulating ``d f_nl / d tau`` into ``F`` (shape (1, n)) in the frozen mode.

        For the derivative of an RK4 step in its start and end times
        (:mod:`contin.timedomain.variational`). The default: nothing for an
        element whose force does not vary explicitly in time (empty
        ``tau_orders()``), None otherwise, so that a Jacobian of a model
        holding it is refused by name.
        """
        return None if getattr(self.element, "tau_orders", tuple)() else []

    def excitation_dtau_lines(self, tag: str, c: int):
        """Statements accumulating ``d f_ext / d tau`` into ``R`` (shape (n,)).

        None (the default) when the element has no such lines: a Jacobian of
        a model holding it is refused by name, never taken as zero.
        """
        return None

    def notes(self) -> list:
        """Caveats reported with the result (e.g. unlocated non-smooth terms)."""
        return []

    def contact_matrices(self, p: np.ndarray, n: int):
        """Stiffness and damping the element adds where its law is active, shape (n, n) each, or None.

        Used to check before a run that the fixed step keeps RK4 stable in contact.
        """
        return None


def kinds_with_compiled_form() -> list:
    """Registered kinds whose elements have a compiled form (for messages)."""
    out = []
    for registry, base in ((FORCE_ELEMENTS, ForceElement), (EXCITATION_ELEMENTS, ExcitationElement)):
        out += [kind for kind, cls in registry.items() if cls.compiled_form is not base.compiled_form]
    return sorted(set(out))


def literal(v) -> str:
    """A float as Python source."""
    return repr(float(v))


def int_array(a) -> str:
    """An int64 array as Python source (for :meth:`CompiledForm.globals`)."""
    return "np.array(" + repr(np.asarray(a, dtype=np.int64).tolist()) + ", dtype=np.int64)"


def float_array(a) -> str:
    """A float64 array as Python source, flattened (for :meth:`CompiledForm.globals`)."""
    return "np.array(" + repr([float(v) for v in np.asarray(a, dtype=float).ravel()]) + ", dtype=np.float64)"
