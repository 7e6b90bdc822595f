"""scanmesh: smooth, honest triangle meshes from digitized scan-line points.

The public API:

- :func:`reconstruct` - every method behind one call (the table: ``scanmesh.methods``);
- :func:`planar_scan` - points checked and projected once, reusable by every method;
- :func:`delaunay` - planar Delaunay of projected points, trimmed to the outline;
- :func:`quality` - tac norms and the max-min angle of any mesh;
- :func:`detect_lines` - scan lines from the order of the points;
- :func:`noise` - the scan noise along the projection normal (robust, from the scan lines);
- :func:`optimal_surface`, :func:`brute_force_surface` - the certified tac optimum (small inputs);
- :func:`simulate_scan` - a virtual line digitizer (rays from above onto a mesh);
  :func:`simulate_range_scan` the same with its grid of rays and line of sight;
- :func:`merge` - one closed, labelled mesh from aligned range views (:func:`read_conf`
  reads a Stanford ``.conf``; :class:`View` is one view);
- :func:`read` - scan points from a file (XYZ, CSV, PLY, NPY/NPZ, VTK, USGS DEM, LAS/LAZ,
  PTS, PCD, E57, ESRI ASCII grids; the vertices of STL, OBJ and OFF meshes);
- :func:`load_demo` - the demo scan ``scanmesh demo`` reconstructs (the creased fandisk, noisy;
  its part: ``demo.demo_part``); :func:`load_rod` the embedded connecting-rod scan (flat
  where scanned; its part: ``demo.rod_truth``);
- :class:`Surface`, :class:`Quality`, :class:`Frame`, :class:`PlanarScan` - the results;
- :class:`ScanmeshError` - base of every input error (a ``ValueError``).
"""

from importlib import metadata as _metadata

from scanmesh.demo import load_demo, load_rod
from scanmesh.errors import (
    ClosedPartWarning,
    CoincidentPointsWarning,
    CrossingLinesWarning,
    CurtainsWarning,
    DegenerateInputError,
    FileFormatError,
    InvalidMeshError,
    MemoryLimitError,
    MissingExtraError,
    MissingFileError,
    NotAHeightFieldWarning,
    ParameterError,
    ScanmeshError,
    ScanmeshWarning,
    SliversWarning,
    UnusedPointsWarning,
    WireZoomWarning,
)
from scanmesh.evaluate.digitizer import simulate_range_scan, simulate_scan
from scanmesh.formats import ScanPoints, read
from scanmesh.fusion import merge
from scanmesh.fusion.views import View, read_conf
from scanmesh.measures import Quality, quality
from scanmesh.methods import METHODS
from scanmesh.reconstruction import reconstruct
from scanmesh.scan.lines import detect_lines
from scanmesh.scan.noise import noise
from scanmesh.scan.planar import PlanarScan, planar_scan
from scanmesh.scan.projection import Frame, project
from scanmesh.stages.brute_force import brute_force_surface
from scanmesh.stages.delaunay import delaunay
from scanmesh.stages.optimal import optimal_surface
from scanmesh.surface import Surface

#: The one version, written in Cargo.toml ([workspace.package]) and read back from the
#: installed package metadata.
__version__ = _metadata.version("scanmesh")

__all__ = [
    "reconstruct",
    "METHODS",
    "planar_scan",
    "PlanarScan",
    "delaunay",
    "simulate_scan",
    "simulate_range_scan",
    "load_demo",
    "load_rod",
    "quality",
    "detect_lines",
    "noise",
    "optimal_surface",
    "brute_force_surface",
    "read",
    "ScanPoints",
    "merge",
    "read_conf",
    "View",
    "project",
    "Surface",
    "Quality",
    "Frame",
    "ScanmeshError",
    "DegenerateInputError",
    "ParameterError",
    "InvalidMeshError",
    "MemoryLimitError",
    "FileFormatError",
    "MissingFileError",
    "MissingExtraError",
    "ScanmeshWarning",
    "CoincidentPointsWarning",
    "NotAHeightFieldWarning",
    "CurtainsWarning",
    "ClosedPartWarning",
    "WireZoomWarning",
    "CrossingLinesWarning",
    "UnusedPointsWarning",
    "SliversWarning",
]
