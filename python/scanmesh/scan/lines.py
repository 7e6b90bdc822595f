"""Scan lines: detected from the order of the points, or given as a line id per point.

A scan line is an ordered list of point indices; a gap inside a line (a hole, a bore, a
missed region) splits it into segments, and strips never bridge gaps. All rules work on
the points projected onto the triangulation plane (see ``scanmesh_core::lines`` for the
exact rules); in short, with h the median step between consecutive points:

- a step that turns more than 45 degrees from the line's direction (a reversal of the
  scanning direction, a move onto the next line) or jumps sideways or backwards starts a
  new line;
- a step that keeps the line's direction but is longer than ``gap_factor`` x h is a gap:
  the line goes on in a new segment.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from scanmesh import _core
from scanmesh._checks import Option
from scanmesh._checks import as_line_ids as as_line_ids  # the rule's public home
from scanmesh.scan.planar import PlanarScan, as_scan
from scanmesh.scan.projection import PlaneSpec

#: Default gap factor k: a step longer than k x the median step is a gap or a jump.
GAP_FACTOR: float = _core.DEFAULT_GAP_FACTOR


@dataclass(frozen=True)
class ScanLines:
    """Scan lines split into segments, in the caller's point indices."""

    #: lines in scan order; each a list of segments; each segment (K,) int64 point indices
    lines: list[list[np.ndarray]]
    #: median planar distance between consecutive points of a line (input units)
    median_step: float
    #: a longer step inside a line splits it (input units)
    gap: float
    #: (D, 2) int64 pairs (dropped point, the earlier point of its line it coincides with)
    duplicates: np.ndarray

    @property
    def n_lines(self) -> int:
        """Number of lines."""
        return len(self.lines)

    @property
    def n_segments(self) -> int:
        """Number of segments over all lines."""
        return sum(len(line) for line in self.lines)


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
        Line ids numbered 0..L-1 in scan order; non-decreasing.
    """
    k = GAP_FACTOR_OPTION.check(gap_factor)
    return _core.detect_lines(as_scan(points, plane=plane).uv, k)


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
    """
    k = GAP_FACTOR_OPTION.check(gap_factor)
    scan = as_scan(points, plane=plane, lines=line_ids)
    ids = _core.detect_lines(scan.uv, k) if scan.line_ids is None else scan.line_ids
    lines, median_step, gap, duplicates = _core.scan_segments(scan.uv, ids, k)
    return ScanLines(lines=lines, median_step=median_step, gap=gap, duplicates=duplicates)
