"""What the figures mark, as plain data: special-point markers and names, the kinds that change stability, the
branches that share a colour.

Kept apart from :mod:`contin.output.plotting` so that an analysis can name them
without importing matplotlib (a run that draws no figure never loads it).
"""

from __future__ import annotations

__all__ = ["CHANGES", "NOT_LOCATED", "SPECIAL", "start_group"]

#: special points drawn: marker, name in the table, short name (narrow figures)
SPECIAL = {"fold": ("o", "fold", "fold"), "pd": ("s", "period doubling", "PD"), "ns": ("D", "Neimark-Sacker", "NS"),
           "bp": ("^", "branch point", "BP"), "kink": ("v", "kink", "kink"),
           "stability": ("X", "stability change", "stab."), "grazing": ("*", "grazing", "grazing"),
           "locking": ("P", "locking", "lock"), "frequency_min": ("<", "frequency minimum", "min."), "frequency_max": (">", "frequency maximum", "max.")}
#: kinds at which the stability of a branch changes
CHANGES = ("fold", "pd", "ns", "bp", "stability")
#: said of a point whose location did not converge (its parameter is only bracketed)
NOT_LOCATED = "(not located)"


def start_group(nu: int, x0: float, values) -> tuple:
    """The ``group`` of a branch starting at parameter ``x0`` with the first row's ``values`` (its dofs'
    amplitudes): the two halves of a branch followed both ways start at one point and share it, whatever
    measure a panel draws (kept as text, so that NaN matches NaN)."""
    return ("start", int(nu), f"{float(x0):.10g}", tuple(f"{float(v):.8g}" for v in values))
