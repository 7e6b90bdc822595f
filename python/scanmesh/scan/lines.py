"""Scan lines: detected from the order of the points, or given as a line id per point.

A scan line is an ordered list of point indices; a gap inside a line (a hole, a bore, a
missed region) splits it into segments, and strips never bridge gaps. All rules work on
the points projected onto the triangulation plane (see ``scanmesh_core::strips`` for the
exact rules); in short, with h the median step between consecutive points:

- a step that turns more than 45 degrees from the line's direction (a reversal of the
  scanning direction, a move onto the next line) or jumps sideways or backwards starts a
  new line;
- a step that keeps the line's direction but is longer than ``gap_factor`` x h is a gap:
  the line goes on in a new segment.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from scanmesh import _core
from scanmesh._checks import Option
from scanmesh._checks import as_line_ids as as_line_ids  # the rule's public home
from scanmesh.scan.planar import PlanarScan, as_scan
from scanmesh.scan.planar import ScanLines as ScanLines  # made and kept by the scan
from scanmesh.scan.projection import PlaneSpec

#: Default gap factor k: a step longer than k x the median step is a gap or a jump.
GAP_FACTOR: float = _core.DEFAULT_GAP_FACTOR


#: The gap factor as an option of the strip methods and of the functions here.
GAP_FACTOR_OPTION = Option(
    "gap_factor",
    "float",
    GAP_FACTOR,
    "a step longer than this many median steps splits a line (a hole)",
    low=0.0,
    low_open=True,
)


def detect_lines(
    points: ArrayLike | PlanarScan, *, plane: PlaneSpec = None, gap_factor: float = GAP_FACTOR
) -> np.ndarray:
    """Line id of every point, detected from the order of the points.

    Parameters
    ----------
    points : (N, 3) float or PlanarScan
        Scan points in scan order.
    plane : None, "best-fit", "x", "y", "z" or (3,) float
        Plane the lines are followed in (see :func:`scanmesh.project`).
    gap_factor : float
        k: a step longer than k x the median step starts a new line unless it keeps the
        line's direction (then it is a gap inside the line).

    Returns
    -------
    (N,) int64
        Line ids numbered 0..L-1 in scan order; non-decreasing. A PlanarScan detects them
        once per gap factor and keeps them (:meth:`PlanarScan.detected_line_ids`); this is a
        copy of those.
    """
    k = GAP_FACTOR_OPTION.check(gap_factor)
    return as_scan(points, plane=plane).detected_line_ids(k).copy()


def scan_lines(
    points: ArrayLike | PlanarScan,
    line_ids: ArrayLike | None = None,
    *,
    plane: PlaneSpec = None,
    gap_factor: float = GAP_FACTOR,
) -> ScanLines:
    """Ordered lines and their segments, from explicit line ids or detected.

    Points with the same id form a line, in input order; lines are ordered by ascending
    id. Within a line, a point that coincides in the plane with the previous one is
    dropped (listed in ``duplicates``), and steps longer than ``gap_factor`` x the median
    step split the line into segments. ``line_ids=None`` detects the lines first
    (:func:`detect_lines`).

    Parameters
    ----------
    points : (N, 3) float or PlanarScan
        Scan points.
    line_ids : (N,) int, optional
        A line id per point (a PlanarScan's own are used when it has them).
    plane : None, "best-fit", "x", "y", "z" or (3,) float
        Projection plane for detection and gaps.
    gap_factor : float
        k, as in :func:`detect_lines`.

    Returns
    -------
    ScanLines
        Kept with the scan, once per gap factor (:meth:`PlanarScan.lines`): its arrays are
        read-only.
    """
    k = GAP_FACTOR_OPTION.check(gap_factor)
    return as_scan(points, plane=plane, lines=line_ids).lines(k)
