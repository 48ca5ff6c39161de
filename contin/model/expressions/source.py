"""Python source of expressions for numba kernels, with shared sub-expressions assigned to temporaries.

The source is compiled by :mod:`contin.model.codegen`; only text produced here
from checked expressions reaches it.
"""

from __future__ import annotations

from typing import Callable

from contin.model.expressions.nodes import Node, Num, Printer, Var

__all__ = ["to_source", "CodeWriter"]

def to_source(node: Node, name_of: Callable[[str], str]) -> str:
    """Python source of an expression for numba, names mapped by ``name_of`` (e.g. ``x -> "x[j, 0]"``)."""
    return Printer(name_of, True).text(node)


class CodeWriter:
    """Python statements for several expressions, shared sub-expressions computed once.

    Sub-expressions used more than once, or nested deeper than
    :attr:`INLINE_DEPTH` levels, are assigned to temporaries ``_t0, _t1, ...``
    so the generated code stays shallow (Python's parser limits nesting) and
    repeated work is done once.

    Parameters
    ----------
    name_of : callable
        Maps a name to its source text, e.g. ``"x" -> "x[j, 0]"``.
    prefix : str
        Prefix of temporary names.

    Examples
    --------
    >>> from contin.model.expressions import parse
    >>> w = CodeWriter(lambda s: s)
    >>> e = parse("sin(x)**2 + sin(x)")
    >>> w.count(e)
    >>> text = w.emit(e)
    >>> w.lines, text
    (['_t0 = np.sin(x)'], '_t0**2 + _t0')
    """

    INLINE_DEPTH = 6

    def __init__(self, name_of: Callable[[str], str], prefix: str = "_t"):
        self.prefix = prefix
        self.lines: list[str] = []
        self._temps: dict = {}
        self._uses: dict = {}
        self._depth: dict = {}
        self._printer = Printer(name_of, True, self._temps)

    def count(self, node: Node) -> None:
        """Register a use of ``node`` (call for every expression before :meth:`emit`)."""
        stack = [node]
        while stack:
            n = stack.pop()
            if isinstance(n, (Num, Var)):
                continue
            seen = self._uses.get(n, 0)
            self._uses[n] = seen + 1
            if seen == 0:
                stack.extend(n.children())

    def emit(self, node: Node) -> str:
        """Source text of ``node``; the temporaries it needs are appended to :attr:`lines`."""
        self._prepare(node)
        return self._printer.text(node)

    def assign(self, node: Node) -> str:
        """Name of a temporary holding ``node`` (created, with its statement, if needed)."""
        text = self.emit(node)
        if node not in self._temps:
            t = f"{self.prefix}{len(self._temps)}"
            self.lines.append(f"{t} = {text}")
            self._temps[node] = t
        return self._temps[node]

    def bind(self, node: Node, text: str) -> None:
        """Use ``text`` for ``node`` (a value computed elsewhere, e.g. before a loop)."""
        self._temps[node] = text

    def _prepare(self, n: Node) -> int:
        # post-order: decide temporaries bottom-up; returns the inline nesting depth of n
        if n in self._temps or isinstance(n, (Num, Var)):
            return 0
        if n in self._depth:
            return self._depth[n]
        d = 1 + max((self._prepare(c) for c in n.children()), default=0)
        if self._uses.get(n, 0) > 1 or d > self.INLINE_DEPTH:
            t = f"{self.prefix}{len(self._temps)}"
            self.lines.append(f"{t} = {self._printer.text(n)}")
            self._temps[n] = t
            d = 0
        self._depth[n] = d
        return d
