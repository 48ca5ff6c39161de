"""Small helpers every layer may use: name hints, number tests, BLAS thread limits, lazy re-exports.

Imports nothing from contin outside util. Its public names (``__all__``) are
those of :data:`contin.util.lazy.UTIL_FACE`, imported on first use (PEP 562):
``import contin`` imports this package, so it holds no more code than that.
"""


def __getattr__(name):
    from contin.util.lazy import util_getattr  # deferred: ``import contin`` imports this package, not the table

    return util_getattr(name)
