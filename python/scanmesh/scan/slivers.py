"""A mesh mostly of slivers: the sign that the points are not what the file's columns say,
or are seen along a plane over which they stand in far-apart rows.

A scan's columns read in the wrong order (``line z x y`` read as ``x y z``) put the line
ids on an axis: whole numbers a unit apart while the samples along a line are a few
hundredths apart, so every triangle between two lines is a sliver (100 % of them on the
demo rod so read, where every method on the real scans of the tests stays under 7 %).
"""

from __future__ import annotations

import numpy as np

from scanmesh import _core

#: ``reconstruct`` warns (``SliversWarning``) when more than this share of the faces are
#: slivers (smallest angle below ``measures.SLIVER_ANGLE_DEG``). The real scans of the tests
#: stay under 7 % with every method (LOP on the Autzen ground: 6.9 %), random points with
#: near-duplicates come to 57 %, the demo rod read with its columns swapped to 100 %.
SLIVER_WARN_FRACTION: float = 0.75

#: Faces measured, at most: every k-th face when there are more (a share needs no more).
SAMPLE: int = 100_000

#: An axis whose values are whole numbers, at most this share of them distinct, looks like
#: a column of scan line ids.
LINE_ID_SHARE: float = 0.25

_AXES = "xyz"


def sliver_share(vertices: np.ndarray, faces: np.ndarray) -> float:
    """Share of ``faces`` ((M, 3) int64 into ``vertices``, (N, 3) float64) whose smallest 3-D
    angle is below ``measures.SLIVER_ANGLE_DEG``, measured on every k-th face when there are
    more than ``SAMPLE``; 0.0 for no faces. O(min(M, SAMPLE))."""
    if len(faces) == 0:
        return 0.0
    sample = np.ascontiguousarray(faces[:: max(1, len(faces) // SAMPLE)], dtype=np.int64)
    _, min_angle = _core.mesh_quality(vertices, sample)
    return float(np.count_nonzero(np.degrees(min_angle) < _core.SLIVER_ANGLE_DEG) / len(sample))


def line_id_axis(points: np.ndarray) -> str:
    """A phrase naming the axis of ``points`` ((N, 3) float64) whose values are whole
    numbers with few distinct values, as a scan line id column's are (``"x: 116 whole
    numbers from 0 to 115"``), or "" when none is."""
    for k in range(3):
        values = points[:, k]
        if not np.all(np.isfinite(values)) or not np.all(values == np.round(values)):
            continue
        distinct = np.unique(values)
        if 1 < len(distinct) <= LINE_ID_SHARE * len(values):
            return (
                f"{_AXES[k]}: {len(distinct):,} whole numbers from {distinct[0]:g} to"
                f" {distinct[-1]:g}"
            )
    return ""


def columns_advice(points: np.ndarray, plane: object) -> str:
    """What the message of a mesh of slivers (or of none) says of the likely causes: the
    columns (naming an axis that looks like line ids, see :func:`line_id_axis`) and the
    plane ``plane``, with what to try."""
    axis = line_id_axis(points)
    seen = f"the values of {axis}, as scan line ids are; " if axis else ""
    return (
        f"the columns may be in another order than x, y, z ({seen}name them in the file's"
        " order with columns=, e.g. columns='line,z,x,y'), or the points stand in far-apart rows"
        f" over the projection plane ({plane!r}; try another plane=)"
    )


__all__ = [
    "sliver_share",
    "line_id_axis",
    "columns_advice",
    "SLIVER_WARN_FRACTION",
    "SAMPLE",
    "LINE_ID_SHARE",
]
