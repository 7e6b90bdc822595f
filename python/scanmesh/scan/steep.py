"""Steep triangles: the share of a mesh's faces nearly parallel to the projection normal,
the sign that the points are not a height field over the chosen plane."""

from __future__ import annotations

import math

import numpy as np

from scanmesh import _core

#: A triangle is steep when its normal is more than this many degrees from the projection
#: normal. Over a height field seen along a sensible normal, only walls and the rims of
#: rounded parts come close (the embedded rod along y: 1 % of its triangles); a surface folded
#: over the plane makes most triangles steep or upside down (the rod along x: 100 %).
STEEP_ANGLE_DEG: float = 75.0

#: ``reconstruct`` warns (``NotAHeightFieldWarning``) when more than this share of the
#: triangles is steep. A hemisphere seen from above is at 16 %, a cylinder seen from its
#: side at about 50 %, the rod along its best plane at 1 %.
STEEP_WARN_FRACTION: float = 0.10


def steep_fraction(vertices: np.ndarray, faces: np.ndarray, normal: np.ndarray) -> float:
    """Share of ``faces`` whose normal is more than ``STEEP_ANGLE_DEG`` from ``normal``.

    vertices : (N, 3) float64; faces : (M, 3) int64, counter-clockwise seen against
    ``normal`` ((3,) float64), so upside-down triangles (a fold) count as steep. Scale-free
    (edge vectors are divided by the half extent of the vertices first). 0.0 for no faces.
    O(M) time in native code on every core (``_core.steep_count``), no per-face temporaries.
    """
    if len(faces) == 0:
        return 0.0
    steep = _core.steep_count(
        np.ascontiguousarray(vertices, dtype=np.float64),
        np.ascontiguousarray(faces, dtype=np.int64),
        np.ascontiguousarray(normal, dtype=np.float64),
        math.radians(STEEP_ANGLE_DEG),
    )
    return steep / len(faces)
