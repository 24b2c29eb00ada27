"""The projection classes of a tetrahedron (Shirley & Tuchman 1990; Monsalve 2016 ch. 3), from the
signs of the affine dependence of its four projected vertices.

Four points p_0..p_3 of the image plane always satisfy sum mu_i (p_i, 1) = 0 with
``mu_i = (-1)^i det(p_j, p_k, p_l)`` (j < k < l the other three; det of rows (x, y, 1), i.e. the
doubled signed area of their triangle). The signs of (mu_0..mu_3), each -, 0 or +, index a table
of 3^4 = 81 entries (``CLASS_TABLE``); mu sums to zero, so many entries cannot occur:

- class 1 (one sign against three): the odd vertex projects inside the triangle of the other three;
  it is the thick vertex and the silhouette is that triangle: three triangles fan from it.
- class 2 (two against two): the edge joining the two + vertices crosses the edge joining the two
  - vertices in the image; the thick point is the crossing and the silhouette the quadrilateral:
  four triangles fan from it.
- class 3 (one zero): a vertex projects onto the opposite edge (the limit of classes 1 and 2);
  class 4 (two zeros): two vertices project onto one point. A flat projection (all zero) shows
  nothing.

The same rule serves every class as a limit: split the vertices into the + group and the others;
the thick point is sum |mu_i| p_i / sum |mu_i| over either group (both give the same point); the
two points of the tetrahedron on the ray through it are those combinations of the 3D vertices
(perspective-correct, see shaders/tetrahedra/project.geom.glsl); the triangles are (thick point,
p_i, p_j) for the pairs i, j of the larger group when the groups are 1 + 3, and for the pairs
across the groups when they are 2 + 2. Degenerate triangles of the limit classes have no area.
The geometry shader applies this rule; this module is its CPU form (tests and documentation).
"""

from __future__ import annotations

import itertools

import numpy as np

DEGENERATE, CLASS_1, CLASS_2, CLASS_3, CLASS_4 = 0, 1, 2, 3, 4


def affine_dependence(points2d) -> np.ndarray:
    """mu (..., 4) with sum mu_i (p_i, 1) = 0 for points2d (..., 4, 2)."""
    p = np.asarray(points2d, dtype=np.float64)
    mu = np.empty(p.shape[:-1])
    for i in range(4):
        a, b, c = (p[..., j, :] for j in range(4) if j != i)
        det = (b[..., 0] - a[..., 0]) * (c[..., 1] - a[..., 1]) - (b[..., 1] - a[..., 1]) * (c[..., 0] - a[..., 0])
        mu[..., i] = det if i % 2 == 0 else -det
    return mu


def table_index(signs) -> int:
    """Index into CLASS_TABLE of four signs in {-1, 0, 1}."""
    return int(sum((int(s) + 1) * 3 ** i for i, s in enumerate(signs)))


def _entry(signs) -> tuple[int, tuple[int, ...]]:
    """(class, vertices): the thick vertex (class 1, 3), the two coinciding vertices (class 4),
    the + vertices, whose edge crosses the edge of the - vertices (class 2)."""
    plus = tuple(i for i, s in enumerate(signs) if s > 0)
    minus = tuple(i for i, s in enumerate(signs) if s < 0)
    zeros = 4 - len(plus) - len(minus)
    if not plus or not minus:
        return DEGENERATE, ()  # all zero (flat), or impossible since mu sums to zero
    if zeros == 0:
        if len(plus) == 2:
            return CLASS_2, plus
        return CLASS_1, plus if len(plus) == 1 else minus
    if zeros == 1 and len(plus) + len(minus) == 3:
        return CLASS_3, plus if len(plus) == 1 else minus
    if zeros == 2:
        return CLASS_4, plus + minus
    return DEGENERATE, ()


CLASS_TABLE: tuple[tuple[int, tuple[int, ...]], ...] = tuple(
    _entry(signs[::-1]) for signs in itertools.product((-1, 0, 1), repeat=4))
# itertools.product varies the last sign fastest; reversed, sign i has weight 3^i as in table_index.


def classify(points2d, eps: float = 0.0) -> tuple[int, tuple[int, ...]]:
    """(class, vertices) of one tetrahedron's projected vertices (4, 2); |mu| <= eps * max|mu|
    counts as zero."""
    mu = affine_dependence(points2d)
    scale = np.abs(mu).max()
    signs = np.where(np.abs(mu) <= eps * scale, 0, np.sign(mu)).astype(int)
    return CLASS_TABLE[table_index(signs)]
