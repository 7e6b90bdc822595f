"""One scan, checked and projected once: the value every triangulation stage takes.

``planar_scan`` checks the points (``as_points``) and the line ids (``as_line_ids``) and
projects the points onto the plane, once; for ``plane=None`` it first chooses the plane by
the data (:mod:`scanmesh.scan.plane_choice`: few steep triangles and a holdout, among the
file's recorded ``up``, the axes, the least-squares plane and the principal axes), so every
stage works on the chosen plane. Delaunay, trimming, strips, LOP, annealing, the optimum
and the quality report all read the same planar coordinates from it, so the annealer tests
convexity on exactly the roundings the Delaunay triangulation and its trimming were judged
on, and ``Surface.frame`` is the frame every stage worked in.
"""

from __future__ import annotations

import dataclasses
import os
import time
from collections.abc import Callable, Hashable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypeVar

import numpy as np
from numpy.typing import ArrayLike

from scanmesh import _core
from scanmesh._checks import as_line_ids, as_points
from scanmesh._context import Context
from scanmesh._progress import Progress
from scanmesh.errors import ParameterError
from scanmesh.formats import ScanPoints, read
from scanmesh.formats._source import InputFile, input_file
from scanmesh.formats.georef import Georef
from scanmesh.scan.closed_part import scan_closed_part
from scanmesh.scan.plane_choice import PlaneChoice, choose_plane
from scanmesh.scan.projection import Frame, PlaneSpec, check_span, plane_args, project_checked

_T = TypeVar("_T")


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


@dataclass(frozen=True, eq=False)
class PlanarScan:
    """Scan points with their projection: made by :func:`planar_scan`, never changed.

    The arrays are the caller's when they already had the right type (no copy); ``uv`` is
    read-only. What is derived from the scan alone (its scan lines and segments per gap
    factor, its noise estimate) is computed on first request and kept with it
    (:meth:`once`), so every stage reads the same values and none computes them again.
    """

    #: (N, 3) float64 the points, checked (finite, at least 3)
    points: np.ndarray
    #: (N, 2) float64 planar coordinates in ``frame``, input units
    uv: np.ndarray
    #: the plane ``uv`` is measured in
    frame: Frame
    #: (N,) int64 scan line of each point (given or from the file), or None
    line_ids: np.ndarray | None
    #: the plane the points were projected on: ``plane=`` as given, or for ``plane=None``
    #: the one chosen ("best-fit", "x", "y", "z" or a normal), so ``project(points, plane)``
    #: gives ``uv`` again
    plane: PlaneSpec
    #: the file the points were read from, or None
    source: Path | None = None
    #: how ``plane=None`` was resolved (None when a plane was given); its
    #: ``as_dict(frame.normal)`` is ``Surface.options["plane_choice"]``
    choice: PlaneChoice | None = None
    #: seconds spent reading ("read", files only), choosing the plane ("plane", for
    #: ``plane=None``) and checking and projecting ("project")
    timings: dict[str, float] = field(default_factory=dict)
    #: ``source`` as it was when read (absolute path, device and inode): writers refuse it
    source_file: InputFile | None = None
    #: per-point values the file carried (``ScanPoints.point_data``: colours, intensity,
    #: ...), by name, each (N,); kept on the Surface and written to PLY
    point_data: dict[str, np.ndarray] = field(default_factory=dict)
    #: (L, K) int64 range grid of point indices (-1: no sample) when the scan came with one
    #: (``ScanPoints.grid``: a PLY ``range_grid``, a height grid, a simulated range scan)
    grid: np.ndarray | None = None
    #: (3,) float64 unit direction towards the scanner when recorded (``ScanPoints.up``)
    up: np.ndarray | None = None
    #: the coordinate reference system and units the file records (``ScanPoints.georef``)
    georef: Georef | None = None
    #: values derived from the scan, by key (:meth:`once`); not part of the scan's identity
    _derived: dict[Hashable, Any] = field(
        default_factory=dict, init=False, repr=False, compare=False
    )

    @property
    def sight(self) -> np.ndarray:
        """(3,) float64 unit line of sight: the recorded ``up``, else the normal of the
        projection plane (what the grid triangulation, the curtain report and the curtain
        rule of LOP and annealing judge faces against)."""
        if self.up is not None:
            return np.asarray(self.up, dtype=np.float64)
        return np.asarray(self.frame.normal, dtype=np.float64)

    def once(self, key: Hashable, compute: Callable[[], _T]) -> _T:
        """``compute()``, computed on the first request for ``key`` and kept with the scan:
        the scan never changes, so neither does anything derived from it alone. A
        ``compute`` that raises keeps nothing."""
        if key not in self._derived:
            self._derived[key] = compute()
        return self._derived[key]

    def detected_line_ids(self, gap_factor: float) -> np.ndarray:
        """(N,) int64 line id of every point, detected from the point order with the
        checked ``gap_factor`` (``_core.detect_lines``, see
        :func:`scanmesh.scan.lines.detect_lines`), once per gap factor. Read-only. O(N)."""
        return self.once(("line_ids", float(gap_factor)), lambda: _detect(self.uv, gap_factor))

    def line_ids_for(self, gap_factor: float) -> np.ndarray:
        """(N,) int64 line id of every point: ``line_ids`` when given, else
        :meth:`detected_line_ids`."""
        if self.line_ids is not None:
            return self.line_ids
        return self.detected_line_ids(gap_factor)

    def lines(self, gap_factor: float) -> ScanLines:
        """The scan lines of :meth:`line_ids_for` split into segments at gaps longer than
        the checked ``gap_factor`` x the median step (``_core.scan_segments``, see
        :func:`scanmesh.scan.lines.scan_lines`), once per gap factor. Its arrays are
        shared: read-only. O(N)."""
        return self.once(("lines", float(gap_factor)), lambda: self._segments(gap_factor))

    def _segments(self, gap_factor: float) -> ScanLines:
        ids = self.line_ids_for(gap_factor)
        s = _core.scan_segments(self.uv, ids, gap_factor)
        for line in s.lines:
            for segment in line:
                segment.flags.writeable = False
        s.duplicates.flags.writeable = False
        return ScanLines(
            lines=s.lines, median_step=s.median_step, gap=s.gap, duplicates=s.duplicates
        )

    def __repr__(self) -> str:
        lines = "" if self.line_ids is None else ", with line ids"
        origin = "" if self.source is None else f", from {str(self.source)!r}"
        return f"PlanarScan({len(self.points)} points, plane={self.plane!r}{lines}{origin})"


def planar_scan(
    source: ArrayLike | str | os.PathLike | PlanarScan | ScanPoints,
    *,
    plane: PlaneSpec = None,
    lines: ArrayLike | None = None,
    progress: Progress = False,
    read_options: Mapping[str, Any] | None = None,
) -> PlanarScan:
    """Check and project scan points once.

    Parameters
    ----------
    source : (N, 3) float array, path, ScanPoints or PlanarScan
        The points, or a scan file (:func:`scanmesh.read`; its line ids are used unless
        ``lines`` is given), or what :func:`scanmesh.read` returned (the same). A
        PlanarScan is returned as it is (``plane`` and ``lines`` must then be left out or
        agree with it).
    plane : None, "best-fit", "x", "y", "z" or (3,) float
        Projection plane (see :func:`scanmesh.project`), obeyed as given. None (default):
        chosen by the data (:func:`scanmesh.scan.plane_choice.choose_plane`): among the
        direction the file records (``ScanPoints.up``), the axes x, y, z, the least-squares
        plane and the principal axes, those with the fewest steep triangles on a quick
        Delaunay triangulation of at most 20,000 points (seeded), judged by a holdout on
        those points when several come close, the recorded ``up`` first
        on ties. ``PlanarScan.plane`` is then the chosen plane, ``PlanarScan.choice`` says
        what each candidate measured.
    lines : (N,) int, optional
        Scan line id of each point (see :func:`scanmesh.scan.lines.as_line_ids`: integers,
        never cast).
    progress : bool or callable
        Reading a file reports the stage "read" (see :func:`scanmesh.reconstruct`).
    read_options : mapping, optional
        Keywords of :func:`scanmesh.read` (``columns``, ``returns``, ``classes``, ``grid``,
        ``cell``, ...) for a path; refused for arrays.

    Raises
    ------
    ScanmeshError
        Bad points, line ids, plane or file.
    """
    if isinstance(source, (str, os.PathLike)):
        t0 = time.perf_counter()
        path = Path(source)
        recorded = input_file(path)  # before reading: no writer may replace what was read
        scan = read_scan_file(path, Context.of(progress), read_options or {})
        return dataclasses.replace(_of_read(scan, plane, lines, recorded, t0), source=path)
    if read_options:
        raise ParameterError(
            f"reader options {sorted(read_options)} apply to files only, not to arrays"
        )
    return as_scan(source, plane=plane, lines=lines)


def read_scan_file(path: Path, context: Context, options: Mapping[str, Any]) -> ScanPoints:
    """The one place a scan file is read for triangulation, with the reader's options
    (such as the columns to use)."""
    return read(path, progress=context.progress, **options)


def _of_read(
    scan: ScanPoints,
    plane: PlaneSpec,
    lines: ArrayLike | None,
    recorded: InputFile | None = None,
    t0: float | None = None,
) -> PlanarScan:
    """What :func:`scanmesh.read` returned, checked and projected: its points, its line ids
    (unless ``lines`` is given), its recorded ``up``, range grid, georeference and
    ``point_data``, its file as the scan's source (``recorded``: as recorded before
    reading; else recorded now, by absolute path and inode, so that no writer replaces
    it); ``t0``: when the reading started (``timings["read"]``)."""
    if lines is None:  # a closed mesh's vertices are no scan: scan the part instead
        scan = scan_closed_part(scan, plane) or scan
    read_seconds = {} if t0 is None else {"read": time.perf_counter() - t0}
    ids = scan.line_ids if lines is None else lines
    made = as_scan(scan.points, plane=plane, lines=ids, up=scan.up)
    return dataclasses.replace(
        made,
        source=scan.source,
        source_file=input_file(scan.source) if recorded is None else recorded,
        timings={**read_seconds, **made.timings},
        point_data=scan.point_data,
        grid=scan.grid,
        georef=scan.georef,
    )


def as_scan(
    points: ArrayLike | PlanarScan | ScanPoints,
    *,
    plane: PlaneSpec = None,
    lines: ArrayLike | None = None,
    up: np.ndarray | None = None,
) -> PlanarScan:
    """``points`` as a PlanarScan: projected now from an array (a path is refused as points)
    on ``plane``, or for None on the plane chosen by the data (``up``: the direction the
    file records, a candidate, kept as ``PlanarScan.up``); or a PlanarScan checked to agree
    with ``plane`` and ``lines``; or what :func:`scanmesh.read` returned (a
    :class:`ScanPoints`: its line ids, recorded ``up``, range grid, georeference, file and
    ``point_data`` kept, as :func:`planar_scan` keeps them for its file)."""
    if isinstance(points, ScanPoints):
        return _of_read(points, plane, lines)
    if isinstance(points, PlanarScan):
        if plane is not None and not same_plane(plane, points.plane):
            raise ParameterError(
                f"plane={plane!r} differs from the plane the scan was projected on"
                f" ({points.plane!r}): make a new planar_scan for another plane"
            )
        if lines is not None and not (
            points.line_ids is not None and np.array_equal(np.asarray(lines), points.line_ids)
        ):
            raise ParameterError(
                "lines= differs from the scan's line ids: give them to planar_scan instead"
            )
        return points
    t0 = time.perf_counter()
    pts = as_points(points)
    ids = None if lines is None else as_line_ids(lines, len(pts))
    choice = None
    timings = {}
    if plane is None:
        check_span(pts)  # before the plane is fitted to the points' differences
        choice = choose_plane(pts, up)
        plane = choice.spec
        timings["plane"] = time.perf_counter() - t0
    t1 = time.perf_counter()
    uv, frame = project_checked(pts, plane)
    uv.flags.writeable = False
    return PlanarScan(
        points=pts,
        uv=uv,
        frame=frame,
        line_ids=ids,
        plane=plane,
        choice=choice,
        timings={**timings, "project": time.perf_counter() - t1},
        up=None if up is None else np.asarray(up, dtype=np.float64),
    )


def _detect(uv: np.ndarray, gap_factor: float) -> np.ndarray:
    """Line ids detected from the order of the points at ``uv``, read-only."""
    ids = _core.detect_lines(uv, gap_factor)
    ids.flags.writeable = False
    return ids


def same_plane(a: PlaneSpec, b: PlaneSpec) -> bool:
    """True when two plane specs name the same plane (None and "best-fit" alike)."""
    name_a, normal_a = plane_args(a)
    name_b, normal_b = plane_args(b)
    if name_a is not None or name_b is not None:
        return name_a == name_b
    return bool(np.array_equal(normal_a, normal_b))


__all__ = ["PlanarScan", "ScanLines", "planar_scan", "as_scan"]
