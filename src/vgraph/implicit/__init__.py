"""Implicit test functions for the FunctionSelector: volumes with no file, and the exact truth
(value, gradient, Hessian, curvature) to measure reconstructions against.

Conventions (docs/reference/general/functions.md says the same for users):
- World points are arrays of shape (N, 3) in (x, y, z) order, evaluated in float64.
- CT sign: the object's interior has HIGHER values than its exterior; the surface of interest is
  f = 0, and a sphere of radius r has curvatures k1 = k2 = +1/r (1/world unit).
- Each function is distance-like near its surface (|grad f| of order 1 on f = 0, values of the order
  of world units), so that even an 8-bit sampling spends many levels on the interior. Where a form is
  not smooth everywhere (|p| at the origin, a torus's axis and core circle) the singular set lies off
  the surface and the derivatives there are returned as 0 instead of inf/NaN.
- Derivatives are exact: each formula is written once on second-order jets (jets.py) and
  differentiated by the chain and product rules, never by finite differences.
- ``sample`` puts ``resolution`` voxel centres per axis exactly on the function's world box and maps
  f so that the surface sits at normalised intensity 0.5 in every data type (sampling.py).

Modules: jets.py (forward-mode second-order differentiation), functions.py (the functions and the
FUNCTIONS registry), sampling.py (exact_curvature, sample, level mapping).
"""

from vgraph.implicit.functions import (FUNCTIONS, UNIT_BOX, Box, Cylinder, Ellipsoid, Genus2,
                                       Hyperboloid, ImplicitFunction, MarschnerLobb, Plane, Range,
                                       RoundedCube, Saddle, Sphere, StiffShell, Torus, make_function)
from vgraph.implicit.sampling import (DATA_TYPES, RESOLUTION_RANGE, SampledVolume,
                                      exact_curvature, level_to_value, sample, value_to_level)

__all__ = [
    "FUNCTIONS", "UNIT_BOX", "Box", "Cylinder", "Ellipsoid", "Genus2", "Hyperboloid",
    "ImplicitFunction", "MarschnerLobb", "Plane", "Range", "RoundedCube", "Saddle", "Sphere",
    "StiffShell", "Torus", "make_function", "DATA_TYPES", "RESOLUTION_RANGE",
    "SampledVolume", "exact_curvature", "level_to_value", "sample", "value_to_level",
]
