"""Registered force and excitation elements, one file each.

Importing this package registers the built-in element kinds in
:data:`contin.model.base.FORCE_ELEMENTS` and :data:`contin.model.base.EXCITATION_ELEMENTS`.
Each file holds an element's law, its switching functions (for a law that
switches), its compiled time-domain form and its scene keys
(:mod:`contin.model.elements.registry`); a new element is one new file
(``docs/howto/contact-element.md``).
"""

from contin.model.elements.expression import ExpressionForce
from contin.model.elements.expression_excitation import ExpressionExcitation
from contin.model.elements.gap import GapForce
from contin.model.elements.harmonic import HarmonicExcitation
from contin.model.elements.point_polynomial import PointForce
from contin.model.elements.polynomial import PolynomialForce
from contin.model.elements.radial_gap import RadialGapForce
from contin.model.elements.string_stretching import StringStretchingForce

__all__ = ["PolynomialForce", "HarmonicExcitation", "GapForce", "RadialGapForce", "ExpressionForce",
           "ExpressionExcitation", "StringStretchingForce", "PointForce"]
