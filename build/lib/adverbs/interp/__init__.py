"""Pure numerics of the method: uniform cubic B-splines (§3.1), keytime warping (§3.2), and linear plus
radial interpolation over adverb space with cardinal weights (§4)."""

from . import bspline, timewarp
from .rbf import AdverbInterpolator

__all__ = ["AdverbInterpolator", "bspline", "timewarp"]
