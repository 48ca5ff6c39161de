"""contin: continuation of periodic vibrations of nonlinear mechanical systems.

The package is laid out by layer; each imports only from the layers above it
in this list (``tests/test_layers.py`` enforces it):

======================  =====================================================
``contin.util``         name hints, number tests, BLAS threads
``contin.engine``       continuation of ``R(u, lambda) = 0``, Newton, events
``contin.model``        models, force elements, expressions, kernels, catalogue
``contin.hb``           harmonic balance: residual, derivatives, AFT, contact
``contin.stability``    Floquet multipliers (Hill, monodromy), saltation
``contin.timedomain``   time integration, shooting, Poincare sections
``contin.modal``        static equilibrium, modes, FRFs, absorber formulas
``contin.bifurcation``  starting points, branch switching, backbones, 2-par curves
``contin.output``       result files, checkpoint, figures
``contin.scene``        scene format, schema, analysis registry, scene models
``contin.analyses``     one module per ``analysis.type``
``contin.app``          command line, runner, sweeps, progress
``contin.api``          the Python interface: System, one call per analysis, Result
======================  =====================================================

The Python interface is importable from the top: ``contin.System``,
``contin.frequency_response``, ``contin.load``, ... (:mod:`contin.api`; imported on
first use, so that ``contin --help`` stays fast). Every warning contin issues is a
:class:`ContinWarning` (``contin.ContinWarning``, a ``UserWarning``): silence or
escalate them alone with ``warnings.filterwarnings("ignore", category=contin.ContinWarning)``.

:mod:`contin.models` holds the built-in models (plug-ins of the catalogue).
"""

from contin.scene.registry import ANALYSES
from contin.util.version import __version__
from contin.util.warning import ContinWarning


#: names of :mod:`contin.api` offered at the top level (one call per analysis of the table)
_API = ("System", "Result", "BranchResult", "LocatedPoint", "load", "run", *ANALYSES)
__all__ = ["__version__", "ContinWarning", *_API]


def __getattr__(name):
    if name in _API:
        import contin.api  # deferred: the API loads numba, scipy, matplotlib (1.4 s); ``import contin`` stays light

        return getattr(contin.api, name)
    raise AttributeError(f"module 'contin' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_API))
