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

from __future__ import annotations

import importlib
import importlib.util
from typing import TYPE_CHECKING, Any

#: Where each public name lives. A name is imported at its first use (``scanmesh.merge``,
#: ``from scanmesh import merge``), not by ``import scanmesh``: the package itself imports
#: nothing, so that the ``scanmesh`` command handles Ctrl-C quietly from its first instant
#: (see :mod:`scanmesh._entry_point`), and a script pays only for what it uses (all of it:
#: 1.3-1.5 s, scipy's spatial module the most).
_HOMES: dict[str, str] = {
    "reconstruct": "scanmesh.reconstruction",
    "METHODS": "scanmesh.methods",
    "planar_scan": "scanmesh.scan.planar",
    "PlanarScan": "scanmesh.scan.planar",
    "delaunay": "scanmesh.stages.delaunay",
    "simulate_scan": "scanmesh.evaluate.digitizer",
    "simulate_range_scan": "scanmesh.evaluate.digitizer",
    "load_demo": "scanmesh.demo",
    "load_rod": "scanmesh.demo",
    "quality": "scanmesh.measures",
    "detect_lines": "scanmesh.scan.lines",
    "noise": "scanmesh.scan.noise",
    "optimal_surface": "scanmesh.stages.optimal",
    "brute_force_surface": "scanmesh.stages.brute_force",
    "read": "scanmesh.formats",
    "ScanPoints": "scanmesh.formats",
    "merge": "scanmesh.fusion",
    "read_conf": "scanmesh.fusion.views",
    "View": "scanmesh.fusion.views",
    "project": "scanmesh.scan.projection",
    "Surface": "scanmesh.surface",
    "Quality": "scanmesh.measures",
    "Frame": "scanmesh.scan.projection",
    "ScanmeshError": "scanmesh.errors",
    "DegenerateInputError": "scanmesh.errors",
    "ParameterError": "scanmesh.errors",
    "InvalidMeshError": "scanmesh.errors",
    "MemoryLimitError": "scanmesh.errors",
    "FileFormatError": "scanmesh.errors",
    "MissingFileError": "scanmesh.errors",
    "MissingExtraError": "scanmesh.errors",
    "ScanmeshWarning": "scanmesh.errors",
    "CoincidentPointsWarning": "scanmesh.errors",
    "NotAHeightFieldWarning": "scanmesh.errors",
    "CurtainsWarning": "scanmesh.errors",
    "ClosedPartWarning": "scanmesh.errors",
    "WireZoomWarning": "scanmesh.errors",
    "CrossingLinesWarning": "scanmesh.errors",
    "UnusedPointsWarning": "scanmesh.errors",
    "SliversWarning": "scanmesh.errors",
}

__all__ = list(_HOMES)


def __getattr__(name: str) -> Any:
    """The public name ``name`` (imported from its home the first time), ``__version__``
    (the one version, written in Cargo.toml's [workspace.package] and read back from the
    installed package metadata) or a submodule (``scanmesh.fusion``)."""
    if name in _HOMES:
        value = getattr(importlib.import_module(_HOMES[name]), name)
    elif name == "__version__":
        from importlib import metadata

        value = metadata.version("scanmesh")
    elif not name.startswith("__") and importlib.util.find_spec(f"{__name__}.{name}"):
        value = importlib.import_module(f"{__name__}.{name}")
    else:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    """The public names with what is already imported (for ``dir`` and completion)."""
    return sorted({*globals(), *_HOMES, "__version__"})


if TYPE_CHECKING:  # the same names, for type checkers and editors
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

    __version__: str
