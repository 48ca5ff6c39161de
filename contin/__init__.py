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
======================  =====================================================

:mod:`contin.models` holds the built-in models (plug-ins of the catalogue).
"""

__version__ = "0.1.0"

