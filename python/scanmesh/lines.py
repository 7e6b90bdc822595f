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
from scanmesh._checks import as_points
from scanmesh.errors import ParameterError, ScanmeshError
from scanmesh.projection import PlaneSpec, project

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


def _gap_factor(gap_factor: float) -> float:
    value = float(gap_factor)
    if not (np.isfinite(value) and value > 0):
        raise ParameterError(f"gap_factor must be a positive number, got {gap_factor!r}")
    return value


def as_line_ids(line_ids: ArrayLike, n_points: int) -> np.ndarray:
    """Return ``line_ids`` as a C-contiguous (N,) int64 array, or raise naming the problem.

    Integral floats are accepted; NaN, fractions and other shapes are not.
    """
    arr = np.asarray(line_ids)
    if arr.shape != (n_points,):
        raise ScanmeshError(f"lines must be one id per point, shape ({n_points},), got {arr.shape}")
    if not np.issubdtype(arr.dtype, np.integer):
        if not np.issubdtype(arr.dtype, np.floating):
            raise ScanmeshError(f"lines must hold integer line ids, got dtype {arr.dtype}")
        if not np.all(np.isfinite(arr)) or not np.all(arr == np.round(arr)):
            raise ScanmeshError("lines must hold integer line ids, got non-integral values")
    return np.ascontiguousarray(arr, dtype=np.int64)


def detect_lines(
    points: ArrayLike, *, plane: PlaneSpec = None, gap_factor: float = GAP_FACTOR
) -> np.ndarray:
    """Line id of every point, detected from the order of the points.

    Parameters
    ----------
    points : (N, 3) float
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
    pts = as_points(points)
    uv, _ = project(pts, plane)
    return _core.detect_lines(uv, _gap_factor(gap_factor))


def scan_lines(
    points: ArrayLike,
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
    points : (N, 3) float
        Scan points.
    line_ids : (N,) int, optional
        A line id per point.
    plane : None, "best-fit", "x", "y", "z" or (3,) float
        Projection plane for detection and gaps.
    gap_factor : float
        k, as in :func:`detect_lines`.

    Returns
    -------
    ScanLines
    """
    pts = as_points(points)
    uv, _ = project(pts, plane)
    k = _gap_factor(gap_factor)
    ids = _core.detect_lines(uv, k) if line_ids is None else as_line_ids(line_ids, len(pts))
    lines, median_step, gap, duplicates = _core.scan_segments(uv, ids, k)
    return ScanLines(lines=lines, median_step=median_step, gap=gap, duplicates=duplicates)
