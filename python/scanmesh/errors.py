"""Exception and warning classes: every input problem is a ``ScanmeshError`` (a ``ValueError``)."""

from scanmesh._core import (
    DegenerateInputError,
    InvalidMeshError,
    ParameterError,
    ScanmeshError,
)


class FileFormatError(ScanmeshError):
    """A file that cannot be read: unknown format, malformed content, truncated data.

    The message names the file and, for text formats, the line.
    """


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


__all__ = [
    "ScanmeshError",
    "DegenerateInputError",
    "ParameterError",
    "InvalidMeshError",
    "FileFormatError",
    "MissingExtraError",
    "ScanmeshWarning",
    "CoincidentPointsWarning",
    "NotAHeightFieldWarning",
]
