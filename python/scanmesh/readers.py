"""Reading scan points from files: the readers of :mod:`scanmesh.formats`, under the names
callers have used (``scanmesh.readers.read``, ``read_vtk``, ...)."""

from scanmesh.formats import (
    READERS,
    ScanPoints,
    count_lines,
    read,
    read_csv,
    read_dem,
    read_las,
    read_npy,
    read_ply,
    read_vtk,
    read_xyz,
)

__all__ = [
    "ScanPoints",
    "count_lines",
    "read",
    "read_xyz",
    "read_csv",
    "read_ply",
    "read_npy",
    "read_vtk",
    "read_dem",
    "read_las",
    "READERS",
]
