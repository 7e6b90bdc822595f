"""Projection of 3-D points onto the plane in which triangulations are built."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from scanmesh import _core
from scanmesh._checks import as_points
from scanmesh.errors import DegenerateInputError, ParameterError

#: The named planes: the least-squares plane and the three axes.
PLANE_NAMES = ("best-fit", "x", "y", "z")

#: A plane choice: None or "best-fit" (least squares), an axis name, or a normal 3-vector.
PlaneSpec = None | str | ArrayLike


@dataclass(frozen=True)
class Frame:
    """An orthonormal right-handed frame (``u x v = normal``), all (3,) float64.

    Planar coordinates of p are ``((p - origin) . u, (p - origin) . v)``; triangles
    counter-clockwise in (u, v) have normals along ``normal``.
    """

    origin: np.ndarray
    u: np.ndarray
    v: np.ndarray
    normal: np.ndarray


def project(points: ArrayLike, plane: PlaneSpec = None) -> tuple[np.ndarray, Frame]:
    """Project (N, 3) points onto a plane.

    Parameters
    ----------
    points : (N, 3) float
        Scan points.
    plane : None, "best-fit", "x", "y", "z" or (3,) float
        None and "best-fit" use the least-squares plane (normal = smallest principal axis);
        an axis name looks along that axis; a vector looks along it. (Here None is the
        least-squares plane; :func:`scanmesh.planar_scan` and :func:`scanmesh.reconstruct`
        choose the plane by the data for None, see :mod:`scanmesh.scan.plane_choice`, and record
        it in ``PlanarScan.plane``.)

    Returns
    -------
    uv : (N, 2) float64
        Planar coordinates, in the input's units.
    frame : Frame
        The plane.
    """
    return project_checked(as_points(points), plane)


def project_checked(points: np.ndarray, plane: PlaneSpec) -> tuple[np.ndarray, Frame]:
    """:func:`project` of points already checked by ``as_points`` (no second check)."""
    name, normal = plane_args(plane)
    check_span(points)
    uv, frame = _core.project(points, name, normal)
    if not np.isfinite(uv).all():  # the plane's coordinates of far points can overflow
        raise DegenerateInputError(_TOO_LARGE)
    return uv, Frame(*frame)


_TOO_LARGE = (
    "the points' coordinates are too large for float64 arithmetic: their differences"
    " overflow (magnitudes near 1.7e308); rescale or shift the points"
)


def check_span(points: np.ndarray) -> None:
    """Refuse (DegenerateInputError) finite points whose differences overflow float64: the
    plane, the projection and every measure work on differences. O(N)."""
    if not len(points):
        return
    with np.errstate(over="ignore"):  # the overflow is what is looked for, not a fault
        span = points.max(axis=0) - points.min(axis=0)
    if not np.isfinite(span).all():
        raise DegenerateInputError(_TOO_LARGE)


def plane_args(plane: PlaneSpec) -> tuple[str | None, np.ndarray | None]:
    """A plane spec as the core takes it: (name, None) or (None, (3,) float64 normal).

    Raises ParameterError for anything else (bytes, a mapping, a normal that is not three
    finite real numbers, not all zero).
    """
    if plane is None or isinstance(plane, str):
        name = "best-fit" if plane is None else plane.lower()
        if name not in PLANE_NAMES:
            raise ParameterError(
                f"plane must be None, 'best-fit', 'x', 'y', 'z' or a 3-vector, got {plane!r}"
            )
        return name, None
    shown = repr(plane) if len(repr(plane)) < 80 else repr(plane)[:76] + " ..."
    if isinstance(plane, (bytes, bytearray, dict)) or not hasattr(plane, "__len__"):
        raise ParameterError(
            f"plane must be None, 'best-fit', 'x', 'y', 'z' or a 3-vector, got {shown}"
        )
    try:
        normal = np.asarray(plane)
    except (TypeError, ValueError):
        normal = np.asarray(None)
    if normal.dtype.kind not in "iuf" or normal.ndim != 1:
        raise ParameterError(f"plane normal must be three real numbers, got {shown}")
    if normal.shape != (3,):
        raise ParameterError(f"plane normal must have 3 components, got {normal.shape[0]}")
    normal = np.ascontiguousarray(normal, dtype=np.float64)
    if not np.all(np.isfinite(normal)) or not np.any(normal):
        raise ParameterError(f"plane normal must be finite and non-zero, got {shown}")
    big = float(np.abs(normal).max())
    if not 1e-100 <= big <= 1e100:
        # scaled by its largest component, so its length neither underflows to 0 (1e-200)
        # nor overflows; normals of ordinary size are passed as given (same frame)
        normal = normal / big
    return None, normal
