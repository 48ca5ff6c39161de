"""One way to make a harmonic-balance problem: the full one or the one condensed onto the nonlinear dofs.

:func:`harmonic_balance` takes a model and the choices of a problem (the
continuation parameter, the discretisation, parameter values, the excitation
frequency) and whether to condense it, and returns
:class:`~contin.hb.problem.HarmonicBalance` or
:class:`~contin.hb.condensation.CondensedHarmonicBalance`. Code above
``contin.hb`` builds its problems here, so the defaults (the continuation
parameter is the frequency unless named) and the condensation rule
(:func:`~contin.hb.condensation.condense`) are decided in one place.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from contin.hb.condensation import CondensedHarmonicBalance, condense as condense_problem
from contin.hb.problem import HarmonicBalance, HBOptions
from contin.model.base import Model

__all__ = ["harmonic_balance", "CONDENSE"]

#: the named values of :func:`harmonic_balance`'s ``condense`` (besides a sequence of dofs)
CONDENSE = (False, "auto", True)


def harmonic_balance(model: Model, parameter: str | None = None, options: HBOptions | Mapping | None = None,
                     params: Mapping | None = None, frequency: str | None = None, *,
                     condense=False) -> HarmonicBalance | CondensedHarmonicBalance:
    """The harmonic-balance problem of ``model``, full or condensed.

    Parameters
    ----------
    model : Model
    parameter : str, optional
        The continuation parameter ``lambda``; default the problem's
        excitation frequency (``frequency``, else the model's declared one).
    options : HBOptions or mapping, optional
        The discretisation; a mapping is read by :meth:`HBOptions.from_dict`
        (its keys are HBOptions' fields). Default ``HBOptions()``.
    params : mapping, optional
        Values overriding the model's parameters.
    frequency : str, optional
        The excitation-frequency parameter ``w``; default the model's declared
        frequency (the model is not changed).
    condense : {False, 'auto', True} or sequence of int
        ``False``: the full problem. ``'auto'``: condensed onto the dofs that
        carry nonlinear forces when the eliminated blocks are regular at every
        frequency, else the full problem. ``True``: condensed whenever a dof
        can be eliminated, a ValueError saying why when none can
        (:func:`contin.hb.condensation.condense`). A sequence: condensed onto
        exactly those dofs (they must include every nonlinear dof).

    Returns
    -------
    HarmonicBalance or CondensedHarmonicBalance

    Raises
    ------
    ValueError
        For an unknown parameter, options the model cannot use, a ``condense``
        that is none of the above, or a condensation that is impossible; the
        message names the argument.

    Examples
    --------
    >>> from contin.model.catalog import build_model
    >>> hb = harmonic_balance(build_model("duffing"), options={"harmonics": 3})
    >>> hb.parameter == hb.frequency, hb.size
    (True, 7)
    """
    if not isinstance(model, Model):
        raise ValueError(f"harmonic_balance: model must be a Model, got {type(model).__name__}")
    how = _condense_choice(condense)
    if options is None:
        options = HBOptions()
    elif isinstance(options, Mapping):
        options = HBOptions.from_dict(dict(options))
    elif not isinstance(options, HBOptions):
        raise ValueError(f"harmonic_balance: options must be HBOptions or a mapping of its fields, "
                         f"got {type(options).__name__}")
    w = model.frequency if frequency is None else frequency
    hb = HarmonicBalance(model, w if parameter is None else parameter, options,
                         None if params is None else dict(params), frequency)
    if how is False:
        return hb
    if isinstance(how, tuple):
        try:
            return CondensedHarmonicBalance(hb, how)
        except ValueError as exc:  # say which argument was refused
            raise ValueError(f"harmonic_balance: condense={list(how)}: {exc}") from None
    return condense_problem(hb, require=how is True)


def _condense_choice(condense):
    """``condense`` checked: False, True, 'auto' or a tuple of dof indices."""
    if isinstance(condense, (bool, np.bool_)):
        return bool(condense)
    if isinstance(condense, str) and condense == "auto":
        return condense
    wrong = ValueError(f"harmonic_balance: condense must be False, 'auto', True or a sequence of dof indices, "
                       f"got {condense!r}")
    if isinstance(condense, (str, bytes, Mapping)) or not hasattr(condense, "__iter__"):
        raise wrong
    dofs = tuple(condense)
    if not all(isinstance(d, (int, np.integer)) and not isinstance(d, (bool, np.bool_)) for d in dofs):
        raise wrong
    return tuple(int(d) for d in dofs)
