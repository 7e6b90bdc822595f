"""A closed mesh given where scan points are expected: scanned, not meshed vertex by vertex.

The vertices of a solid's surface (a CAD export: STL, OBJ, OFF or PLY whose faces close up)
are not samples of one height field: its top and bottom, walls and bores project onto the
same plane, and a flat face has vertices at its corners only, so meshing them gives 60 to
100 % steep triangles and a surface the part does not have. Such a file is scanned instead,
as ``scanmesh simulate`` would: by the virtual line digitizer
(:func:`scanmesh.evaluate.digitizer.simulate_range_scan`), from the axis direction that
sees the largest area of the part, at a spacing that gives about
:data:`CLOSED_PART_POINTS` points; a :class:`~scanmesh.errors.ClosedPartWarning` says so.
A mesh that does not close (a scan or a reconstruction saved with its faces) is read as its
vertices, as before.
"""

from __future__ import annotations

import warnings

import numpy as np

from scanmesh.errors import ClosedPartWarning
from scanmesh.evaluate.digitizer import simulate_range_scan, simulate_scan
from scanmesh.formats.mesh import load_mesh
from scanmesh.formats.points import ScanPoints
from scanmesh.scan.axes import parse_axis
from scanmesh.scan.projection import PlaneSpec

#: About this many points are scanned from a closed mesh (the digitizer's ``n_points``).
CLOSED_PART_POINTS = 20_000

#: Directions a closed part is scanned from when ``plane`` names none, in the order that
#: breaks ties (+z, the usual up, first).
SCAN_DIRECTIONS = ("z", "y", "x", "-z", "-y", "-x")

#: Rays across the part's largest extent when its silhouettes are compared.
SILHOUETTE_RAYS = 64


def scan_closed_part(points: ScanPoints, plane: PlaneSpec = None) -> ScanPoints | None:
    """A virtual scan of the part when ``points`` came from a file of a closed mesh; else None.

    Parameters
    ----------
    points : ScanPoints
        What :func:`scanmesh.read` returned (``extra["faces_ignored"]`` > 0 for a file with
        faces).
    plane : None, axis name or (3,) float
        The projection plane asked for: an axis or a normal is the scanning direction;
        otherwise (None, "best-fit") the axis with the largest silhouette (rays of one grid
        that hit the part; the first of x, y, z in :data:`SCAN_DIRECTIONS`' order within 1 %
        of the most), from the side with more faces turned to it.

    Returns
    -------
    ScanPoints or None
        The scan: (N, 3) points on the part, line ids, range grid and ``up``, ``source`` the
        file, ``extra["scanned_part"]`` the direction, spacing and count. None when the
        file has no faces or they do not enclose a volume. O(F log F) for F faces (rays
        against the part's bounding-volume tree), once per call.

    Warns
    -----
    ClosedPartWarning
        Whenever the part is scanned, naming the direction, the spacing and the command
        that scans it by choice.
    """
    if not points.extra.get("faces_ignored") or points.source is None:
        return None
    part = load_mesh(points.source)
    if part.is_watertight and part.is_winding_consistent and part.volume < 0:
        part.invert()  # every face turned inwards: the same solid, its faces the other way
    if not part.is_volume:
        return None
    up = _scan_direction(part, plane)
    scan = simulate_range_scan(part, up=up, along=_along(up), n_points=CLOSED_PART_POINTS)
    spacing = float(scan.extra["spacing"])
    named = _axis_name(up)
    warnings.warn(
        f"{points.source} is a closed mesh (the surface of a solid), not scan points: its"
        f" {len(points.points):,} vertices would mesh top, bottom and walls together, so it was"
        f" scanned along {named} at spacing {spacing:.4g} ({len(scan.points):,} points on"
        f" {int(scan.line_ids.max()) + 1:,} lines) and that scan meshed; choose the"
        f" direction, spacing and noise with: scanmesh simulate {points.source} -o scan.xyz"
        f" --up={named}",
        ClosedPartWarning,
        stacklevel=3,
    )
    return ScanPoints(
        points=scan.points,
        line_ids=scan.line_ids,
        source=points.source,
        extra={
            **points.extra,
            "scanned_part": {"up": named, "spacing": spacing, "points": len(scan.points)},
            "line_ids_from": "virtual scan lines",
        },
        grid=scan.grid,
        up=scan.up,
        georef=points.georef,
    )


def _scan_direction(part, plane: PlaneSpec) -> np.ndarray:
    """``plane`` as a direction when it names one, else the best of :data:`SCAN_DIRECTIONS`."""
    if plane is not None and not (isinstance(plane, str) and plane == "best-fit"):
        return parse_axis(plane, "plane")
    # The axis whose rays hit the part most often on one grid (the silhouette's area: a
    # connecting rod seen through its bores, a plate from above), the order breaking ties.
    step = float(max(part.extents)) / SILHOUETTE_RAYS
    axes = [parse_axis(name, "up") for name in SCAN_DIRECTIONS[:3]]
    hits = [len(simulate_scan(part, up=d, along=_along(d), spacing=step)[0]) for d in axes]
    axis = axes[next(k for k, n in enumerate(hits) if n >= 0.99 * max(hits))]
    # d and -d see the same silhouette: the side with more faces turned to it (a plate's
    # pocketed top before its flat bottom) is scanned, +d on a tie.
    normals = np.asarray(part.face_normals) @ axis
    return -axis if np.count_nonzero(normals < -1e-9) > np.count_nonzero(normals > 1e-9) else axis


def _along(up: np.ndarray) -> str:
    """The direction scan lines run for a scan along the axis ``up``: x, or y along x."""
    return "y" if abs(up[0]) > 0.5 else "x"


def _axis_name(direction: np.ndarray) -> str:
    """The name of an axis direction ("-y"), else the vector's components."""
    for name in SCAN_DIRECTIONS:
        if np.array_equal(parse_axis(name, "up"), direction):
            return name
    return ",".join(f"{c:.6g}" for c in direction)
