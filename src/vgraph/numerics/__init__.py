"""CPU reference numerics: B-spline prefilter and tricubic evaluation, Kindlmann curvature,
trilinear sampling and finite differences. Conventions are in each module's docstring."""

from vgraph.numerics.bspline import SplineSample, evaluate, prefilter
from vgraph.numerics.curvature import Curvature, kindlmann
from vgraph.numerics.finite_differences import (
    gradient_at,
    grid_gradient,
    grid_hessian,
    hessian_at,
    trilinear,
)

__all__ = [
    "Curvature", "SplineSample", "evaluate", "gradient_at", "grid_gradient", "grid_hessian",
    "hessian_at", "kindlmann", "prefilter", "trilinear",
]
