"""The category of every warning contin issues: :class:`ContinWarning`.

One category lets a caller silence or escalate contin's warnings alone
(``warnings.filterwarnings("ignore", category=contin.ContinWarning)``) and
lets the command line print them as one line each.
"""

from __future__ import annotations

__all__ = ["ContinWarning"]


class ContinWarning(UserWarning):
    """A result that holds with a caveat: a verdict replaced, a point without one, a cache not used.

    Examples
    --------
    >>> import warnings
    >>> import contin
    >>> warnings.filterwarnings("error", category=contin.ContinWarning)  # doctest: +SKIP
    """
