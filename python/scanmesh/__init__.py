"""scanmesh: smooth, honest triangle meshes from digitized scan-line points.

The public API:

- :func:`delaunay` - planar Delaunay of projected points, trimmed to the outline;
- :func:`quality` - tac norms and the max-min angle of any mesh;
- :class:`Surface`, :class:`Quality`, :class:`Frame` - the results;
- :class:`ScanmeshError` - base of every input error (a ``ValueError``).
"""

from scanmesh.delaunay import delaunay
from scanmesh.errors import (
    CoincidentPointsWarning,
    DegenerateInputError,
    FileFormatError,
    InvalidMeshError,
    ParameterError,
    ScanmeshError,
    ScanmeshWarning,
)
from scanmesh.projection import Frame, project
from scanmesh.quality import Quality, quality
from scanmesh.surface import Surface

__version__ = "0.1.0"

__all__ = [
    "delaunay",
    "quality",
    "project",
    "Surface",
    "Quality",
    "Frame",
    "ScanmeshError",
    "DegenerateInputError",
    "ParameterError",
    "InvalidMeshError",
    "FileFormatError",
    "ScanmeshWarning",
    "CoincidentPointsWarning",
]
