"""What the stages take as a source: points, a PlanarScan, or what ``scanmesh.read`` returns."""

from __future__ import annotations

import dataclasses

from numpy.typing import ArrayLike

from scanmesh.formats import ScanPoints
from scanmesh.formats._source import input_file
from scanmesh.scan.closed_part import scan_closed_part
from scanmesh.scan.planar import PlanarScan, as_scan
from scanmesh.scan.projection import PlaneSpec


def scan_of(
    source: ArrayLike | PlanarScan | ScanPoints,
    *,
    plane: PlaneSpec = None,
    lines: ArrayLike | None = None,
) -> PlanarScan:
    """``source`` checked and projected (:func:`scanmesh.scan.planar.as_scan`); a
    :class:`ScanPoints` gives its points, its line ids (unless ``lines`` is given), its
    recorded ``up``, range grid and georeference as reading its file would, its file as
    the scan's source (recorded now, by absolute path and inode, so that no writer replaces
    it) and its ``point_data``."""
    if isinstance(source, ScanPoints):
        if lines is None:  # a closed mesh's vertices are no scan: scan the part instead
            source = scan_closed_part(source, plane) or source
        ids = source.line_ids if lines is None else lines
        made = as_scan(source.points, plane=plane, lines=ids, up=source.up)
        return dataclasses.replace(
            made,
            source=source.source,
            source_file=input_file(source.source),
            point_data=source.point_data,
            grid=source.grid,
            georef=source.georef,
        )
    return as_scan(source, plane=plane, lines=lines)
