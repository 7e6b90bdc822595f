"""Planar Delaunay triangulation of scan points, trimmed to the scanned outline."""

from __future__ import annotations

import math
import time
import warnings

import numpy as np
from numpy.typing import ArrayLike

from scanmesh import _core
from scanmesh._checks import as_points
from scanmesh._interrupt import interruptible
from scanmesh._progress import Progress, Stage
from scanmesh.errors import CoincidentPointsWarning, DegenerateInputError, ParameterError
from scanmesh.projection import PlaneSpec, project
from scanmesh.surface import Surface

#: Default ``max_edge`` in multiples of the median nearest-neighbour spacing (planar).
MAX_EDGE_FACTOR: float = _core.DEFAULT_MAX_EDGE_FACTOR

#: A triangle whose longest 3-D edge exceeds this multiple of the local 3-D spacing (the
#: median edge length at its best-sampled corner) bridges a depth jump and is dropped
#: whenever ``max_edge`` is finite.
JUMP_FACTOR: float = _core.DEFAULT_JUMP_FACTOR


def resolve_max_edge(uv: np.ndarray, faces: np.ndarray, max_edge: float | None) -> float:
    """The trimming length: ``max_edge`` itself, or MAX_EDGE_FACTOR x median spacing for None."""
    if max_edge is None:
        return MAX_EDGE_FACTOR * _core.median_spacing(uv, faces)
    value = float(max_edge)
    if math.isnan(value) or value <= 0:
        raise ParameterError(f"max_edge must be positive (or math.inf), got {max_edge!r}")
    return value


def delaunay(
    points: ArrayLike,
    *,
    plane: PlaneSpec = None,
    max_edge: float | None = None,
    progress: Progress = False,
) -> Surface:
    """Delaunay triangulation of the points projected onto a plane.

    Parameters
    ----------
    points : (N, 3) float
        Scan points; any real dtype and memory layout.
    plane : None, "best-fit", "x", "y", "z" or (3,) float
        Projection plane (see :func:`scanmesh.projection.project`).
    max_edge : float, optional
        Triangles with a longer planar edge (input units) are dropped, so holes and concave
        outlines stay open. Default: ``MAX_EDGE_FACTOR`` (5) x the median nearest-neighbour
        spacing. With a finite ``max_edge``, triangles that bridge a depth jump (a wall, a
        step, a bore: longest 3-D edge above ``JUMP_FACTOR`` (3) x the local 3-D spacing)
        are dropped too. ``math.inf`` keeps the whole convex hull (less the zero-area
        slivers that close straight stretches of it).
    progress : bool or callable
        True shows progress bars; a callable taking ``stage=`` is called for the stages
        "delaunay" (points) and "trim" (faces), each one native call reported at its start
        and its end (see :func:`scanmesh.reconstruct`).

    Returns
    -------
    Surface
        Faces over the input points. Points that coincide in the plane with an earlier point
        are not used; ``Surface.duplicates`` lists them and a ``CoincidentPointsWarning`` says
        how many. ``options["trimmed"]`` ((K,) int64) lists the points whose every triangle
        was trimmed away: each input point is in a face, a duplicate or trimmed.

    Raises
    ------
    ScanmeshError
        Wrong shape, non-finite values, fewer than 3 distinct points, collinear points, or
        a trimming length that leaves no triangle.
    """
    t0 = time.perf_counter()
    pts = as_points(points)
    uv, frame = project(pts, plane)
    t1 = time.perf_counter()
    with Stage(progress, "delaunay", len(pts), blocking=True):
        faces, duplicate_of = interruptible(len(pts), _core.delaunay, uv)
    t2 = time.perf_counter()
    limit = resolve_max_edge(uv, faces, max_edge)
    # Trimmed at max_edge=inf too: trimming also peels the numerically collinear slivers
    # that close straight stretches of the hull.
    untrimmed = faces
    with Stage(progress, "trim", len(untrimmed), blocking=True):
        jumps = JUMP_FACTOR if math.isfinite(limit) else math.inf
        faces = interruptible(len(pts), _core.trim_long_edges, uv, faces, limit, pts, jumps)
        # (K,) int64 points that lost every triangle to trimming (outliers, stray points);
        # flags, not np.setdiff1d, whose sorts of the 6M-entry face arrays took 2 s at 1M points
        was_used = np.zeros(len(pts), dtype=bool)
        was_used[untrimmed.ravel()] = True
        was_used[faces.ravel()] = False
        trimmed = np.flatnonzero(was_used).astype(np.int64)
    if len(faces) == 0:
        raise DegenerateInputError(
            f"trimming at max_edge={limit:.6g} left no triangle: the points are too sparse"
            " for it, or fold onto themselves in the projection plane (try another plane=,"
            " or a larger max_edge)"
        )
    t3 = time.perf_counter()
    dropped = np.flatnonzero(duplicate_of >= 0)
    duplicates = np.column_stack([dropped, duplicate_of[dropped]]).astype(np.int64)
    if len(dropped):
        shown = ", ".join(f"{a}->{b}" for a, b in duplicates[:5])
        warnings.warn(
            f"{len(dropped)} point(s) coincide in the projection plane with an earlier point and"
            f" are left out (first: {shown}); see Surface.duplicates",
            CoincidentPointsWarning,
            stacklevel=2,
        )
    return Surface(
        vertices=pts,
        faces=faces,
        method="delaunay",
        options={"plane": plane, "max_edge": limit, "trimmed": trimmed},
        frame=frame,
        duplicates=duplicates,
        timings={"project": t1 - t0, "triangulate": t2 - t1, "trim": t3 - t2},
    )
