"""contin: continuation of periodic vibrations of nonlinear mechanical systems.

The package is layered so that each idea lives in one module:

- :mod:`contin.continuation` follows ``R(u, lambda) = 0`` (knows nothing of vibrations);
- :mod:`contin.harmonic_balance` turns a model into ``R`` by AFT harmonic balance;
- :mod:`contin.model` and :mod:`contin.elements` describe models and force laws;
- :mod:`contin.models` holds the built-in models.
"""

__version__ = "0.1.0"


def _find_models_in_source_tree():
    # Installed, the built-in models are the subpackage contin/models. In a source
    # checkout they live in ../models (the project layout); make them importable as
    # contin.models there too, so `python -m contin` works from the repository root.
    import os

    here = os.path.dirname(os.path.abspath(__file__))
    root = os.path.dirname(here)
    if not os.path.isdir(os.path.join(here, "models")) and os.path.isfile(os.path.join(root, "models", "__init__.py")):
        if root not in __path__:
            __path__.append(root)


_find_models_in_source_tree()
