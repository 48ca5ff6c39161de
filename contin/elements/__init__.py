"""Registered force and excitation elements.

Importing this package registers the built-in element kinds in
:data:`contin.model.FORCE_ELEMENTS` and :data:`contin.model.EXCITATION_ELEMENTS`.
"""

from contin.elements.expression import ExpressionExcitation, ExpressionForce
from contin.elements.galerkin import PointForce, StringStretchingForce
from contin.elements.gap import GapForce, RadialGapForce
from contin.elements.harmonic import HarmonicExcitation
from contin.elements.polynomial import PolynomialForce

__all__ = ["PolynomialForce", "HarmonicExcitation", "GapForce", "RadialGapForce", "ExpressionForce",
           "ExpressionExcitation", "StringStretchingForce", "PointForce"]
