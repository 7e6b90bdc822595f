"""Exception and warning classes: every input problem is a ``ScanmeshError`` (a ``ValueError``)."""

from scanmesh._core import (
    DegenerateInputError,
    InvalidMeshError,
    MemoryLimitError,
    ParameterError,
    ScanmeshError,
)


class FileFormatError(ScanmeshError):
    """A file that cannot be read: unknown format, malformed content, truncated data.

    The message names the file and, for text formats, the line.
    """


class MissingFileError(FileFormatError, FileNotFoundError):
    """An input file that does not exist: a :class:`FileFormatError` like every file that
    cannot be read, and a ``FileNotFoundError`` (an ``OSError``), so ``except OSError``
    catches it; ``filename`` is the path."""

    def __str__(self) -> str:
        return str(self.args[0]) if self.args else ""  # the message, not OSError's form


class MissingExtraError(ScanmeshError, ImportError):
    """A feature needs a package that is installed only with one of scanmesh's extras; the
    message names the feature, the package and the ``pip install "scanmesh[extra]"`` line.
    Also an ``ImportError``, so ``except ImportError`` catches it."""


class ScanmeshWarning(UserWarning):
    """Base of scanmesh's warnings: the result is honest but the input deserves a look."""


class CoincidentPointsWarning(ScanmeshWarning):
    """Points that coincide in the projection plane; all but one of each group are unused."""


class NotAHeightFieldWarning(ScanmeshWarning):
    """Many triangles are steep over the projection plane (see ``Surface.steep_fraction``):
    the surface is probably not a height field there; another ``plane=`` may fit it better."""


class SliversWarning(ScanmeshWarning):
    """Most of a mesh's triangles are slivers (``scan.slivers.SLIVER_WARN_FRACTION``): the
    points are probably not what the file's columns were read as, or the plane sees them in
    far-apart rows; the message names the likely cause. Not warned where
    :class:`NotAHeightFieldWarning` is (the plane is then the cause)."""


class CurtainsWarning(ScanmeshWarning):
    """Faces within ``measures.CURTAIN_ANGLE_DEG`` of the line of sight cover more than
    ``measures.CURTAIN_WARN_FRACTION`` of the mesh's area (``options["curtains"]``): sheets
    the scanner's rays pass along, hung across depth jumps, not surface it saw."""


class ClosedPartWarning(ScanmeshWarning):
    """A closed mesh (a solid's surface, such as a CAD export) was given as scan points: its
    vertices are not one height field's samples, so it was scanned by the virtual digitizer
    (``scan.closed_part``) and that scan meshed; the message says how."""


class WireZoomWarning(ScanmeshWarning):
    """A wireframe picture shows the middle of the mesh, zoomed so that its triangles'
    edges stay apart (``present.render.WIRE_PIXELS``); the message says by how much."""


class CrossingLinesWarning(ScanmeshWarning):
    """Scan lines cross or fold in the plane, so some strips overlapped there.

    The overlapping triangles were dropped (``options["dropped_overlaps"]`` counts them),
    so the mesh returned is still a manifold, valid triangulation in the plane.
    """


class UnusedPointsWarning(ScanmeshWarning):
    """Some points are in no strip: isolated points outside every strip, or line ends that
    overhang both neighbouring lines by more than half a gap."""


# Raised and shown as scanmesh.ScanmeshError, ...: the public names, not the modules that
# define them (the core's classes would otherwise read _core.ScanmeshError in tracebacks).
for _cls in (
    ScanmeshError,
    DegenerateInputError,
    ParameterError,
    InvalidMeshError,
    MemoryLimitError,
    FileFormatError,
    MissingFileError,
    MissingExtraError,
    ScanmeshWarning,
    CoincidentPointsWarning,
    NotAHeightFieldWarning,
    CurtainsWarning,
    ClosedPartWarning,
    WireZoomWarning,
    CrossingLinesWarning,
    UnusedPointsWarning,
    SliversWarning,
):
    _cls.__module__ = "scanmesh"
del _cls

__all__ = [
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
