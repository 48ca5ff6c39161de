"""contin: continuation of periodic vibrations of nonlinear mechanical systems.

The package is layered so that each idea lives in one module:

- :mod:`contin.continuation` follows ``R(u, lambda) = 0`` (knows nothing of vibrations);
- :mod:`contin.harmonic_balance` turns a model into ``R`` by AFT harmonic balance;
- :mod:`contin.model` and :mod:`contin.elements` describe models and force laws;
- :mod:`contin.models` holds the built-in models.
"""

__version__ = "0.1.0"
