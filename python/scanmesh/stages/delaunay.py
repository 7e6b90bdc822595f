"""Planar Delaunay triangulation of scan points, trimmed to the scanned outline."""

from __future__ import annotations

import warnings

import numpy as np
from numpy.typing import ArrayLike

from scanmesh import _core
from scanmesh._interrupt import interruptible
from scanmesh._progress import Progress, Stage
from scanmesh.errors import CoincidentPointsWarning, DegenerateInputError
from scanmesh.formats import ScanPoints
from scanmesh.scan.planar import PlanarScan, as_scan
from scanmesh.scan.projection import PlaneSpec
from scanmesh.scan.slivers import columns_advice, line_id_axis
from scanmesh.scan.spacing import trim_length
from scanmesh.stages.options import JUMP_FACTOR, MAX_EDGE_OPTION
from scanmesh.surface import Surface


def resolve_max_edge(uv: np.ndarray, faces: np.ndarray, max_edge: float | None) -> float:
    """The trimming length: ``max_edge`` itself, or MAX_EDGE_FACTOR x median spacing for None."""
    if max_edge is None:
        return trim_length(uv, faces)
    return MAX_EDGE_OPTION.check(max_edge)


def delaunay(
    points: ArrayLike | PlanarScan | ScanPoints,
    *,
    plane: PlaneSpec = None,
    max_edge: float | None = None,
    progress: Progress = False,
) -> Surface:
    """Delaunay triangulation of the points projected onto a plane.

    Parameters
    ----------
    points : (N, 3) float, PlanarScan or ScanPoints
        Scan points; any real dtype and memory layout. A PlanarScan
        (:func:`scanmesh.planar_scan`) is triangulated in its own plane, not projected again;
        a ScanPoints (:func:`scanmesh.read`) as its file would be.
    plane : None, "best-fit", "x", "y", "z" or (3,) float
        Projection plane (see :func:`scanmesh.scan.projection.project`); with a PlanarScan,
        None or the scan's own.
    max_edge : float, optional
        Triangles with a longer planar edge (input units) are dropped, so holes and concave
        outlines stay open. Default: ``MAX_EDGE_FACTOR`` (5) x the median nearest-neighbour
        spacing. With a finite ``max_edge``, triangles that bridge a depth jump (a wall, a
        step, a bore: a steep longest 3-D edge above ``JUMP_FACTOR`` (3) x the local 3-D
        spacing), a gap (any longest 3-D edge above ``BRIDGE_FACTOR`` (5) x the spacing
        across lines) or a hole (a longest planar edge above ``HOLE_FACTOR`` (2.8) x the
        local edge length and a planar area above the core's ``HOLE_AREA_FACTOR`` (1.8) x
        the local triangle area) are dropped too. ``math.inf`` keeps the whole convex hull
        (less the zero-area slivers that close straight stretches of it).
    progress : bool or callable
        True shows progress bars; a callable taking ``stage=`` is called for the stages
        "delaunay" (points) and "trim" (faces): one native call does both, reported as
        "delaunay" while it runs (the share of its passes over the points done), then
        "trim" as done (see :func:`scanmesh.reconstruct`).

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
    scan = as_scan(points, plane=plane)
    if max_edge is not None:
        max_edge = MAX_EDGE_OPTION.check(max_edge)  # before the work, not after it
    pts, uv = scan.points, scan.uv
    # One native call triangulates and trims, so the triangulation's half-edge twins serve
    # the trimming and no face array crosses in between; "trim" is reported once it is done.
    # Trimmed at max_edge=inf too: trimming also peels the numerically collinear slivers
    # that close straight stretches of the hull.
    with Stage(progress, "delaunay", len(pts)) as stage:
        call = _core.delaunay_trimmed
        result = interruptible(
            len(pts), call, uv, pts, max_edge, JUMP_FACTOR, stage.counter, watch=stage.follow
        )
        faces, duplicate_of, trimmed = result.faces, result.duplicate_of, result.trimmed
        limit, (triangulate, trim) = result.max_edge, result.seconds
    with Stage(progress, "trim", len(faces), blocking=True):
        pass
    if len(faces) == 0:
        raise DegenerateInputError(_why_nothing_kept(scan, limit))
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
        options={"plane": scan.plane, "max_edge": limit, "trimmed": trimmed},
        scan=scan,
        duplicates=duplicates,
        timings={**scan.timings, "triangulate": triangulate, "trim": trim},
        line_ids=scan.line_ids,
    )


#: Points whose median nearest neighbour in the plane is closer than this share of the
#: one in 3-D fold onto themselves there: the projection stacks distinct samples.
FOLD_SHARE: float = 0.25


def _why_nothing_kept(scan: PlanarScan, limit: float) -> str:
    """The message of a trimming that left no triangle: a fold of the scan over its plane
    when the projection brings its points far closer together than they are (the
    least-squares plane of a scan with tall relief can stand across it: a block 10 high on
    a 12 x 10 slope, sampled every 0.5, has its least variance along y, and over that plane
    each column of samples lands within 0.02), else points too sparse for ``max_edge``."""
    from scipy.spatial import cKDTree  # scipy loads only on this error's path

    def spacing(coords: np.ndarray) -> float:
        distance = cKDTree(coords).query(coords, k=2)[0][:, 1]
        return float(np.median(distance[distance > 0])) if (distance > 0).any() else 0.0

    in_3d, in_plane = spacing(scan.points), spacing(scan.uv)
    if in_3d > 0 and in_plane < FOLD_SHARE * in_3d:
        normal = np.array2string(np.asarray(scan.frame.normal), precision=3)
        there = f"{in_plane:.3g} apart" if in_plane > 0 else "on top of each other"
        return (
            f"the scan folds onto itself over plane={scan.plane!r} (normal {normal}):"
            f" points a median {in_3d:.3g} apart in 3-D lie {there} in the plane, so"
            f" trimming at max_edge={limit:.6g} left no triangle; the surface is no height"
            " field over this plane: plane=None chooses one over which it is, or give another"
            " plane="
        )
    text = (
        f"trimming at max_edge={limit:.6g} left no triangle: the points are too sparse for"
        " it (give a larger max_edge=, or another plane=)"
    )
    if line_id_axis(scan.points):  # more likely than sparse points: say it
        text += "; " + columns_advice(scan.points, scan.plane)
    return text
