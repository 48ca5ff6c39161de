"""Built-in models of contin, installed as the package ``contin.models``.

Importing it registers every model in :data:`contin.model.catalog.MODELS`.
"""

from contin.models import bearing_rotor, duffing, linear_chain, mathieu, polynomial, timing_belt  # noqa: F401

__all__ = ["bearing_rotor", "duffing", "linear_chain", "mathieu", "polynomial", "timing_belt"]
