"""Registered force and excitation elements.

Importing this package registers the built-in element kinds in
:data:`contin.model.base.FORCE_ELEMENTS` and :data:`contin.model.base.EXCITATION_ELEMENTS`.
"""

from contin.model.elements.expression import ExpressionExcitation, ExpressionForce
from contin.model.elements.galerkin import PointForce, StringStretchingForce
from contin.model.elements.gap import GapForce, RadialGapForce
from contin.model.elements.harmonic import HarmonicExcitation
from contin.model.elements.polynomial import PolynomialForce

__all__ = ["PolynomialForce", "HarmonicExcitation", "GapForce", "RadialGapForce", "ExpressionForce",
           "ExpressionExcitation", "StringStretchingForce", "PointForce"]
