"""Projection of 3-D points onto the plane in which triangulations are built."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from scanmesh import _core
from scanmesh._checks import as_points
from scanmesh.errors import ParameterError

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
        an axis name looks along that axis; a vector looks along it.

    Returns
    -------
    uv : (N, 2) float64
        Planar coordinates, in the input's units.
    frame : Frame
        The plane.
    """
    pts = as_points(points)
    if plane is None or isinstance(plane, str):
        name = "best-fit" if plane is None else plane.lower()
        if name not in ("best-fit", "x", "y", "z"):
            raise ParameterError(
                f"plane must be None, 'best-fit', 'x', 'y', 'z' or a 3-vector, got {plane!r}"
            )
        uv, frame = _core.project(pts, name)
    else:
        normal = np.asarray(plane, dtype=np.float64).ravel()
        if normal.shape != (3,):
            raise ParameterError(f"plane normal must have 3 components, got {normal.shape[0]}")
        uv, frame = _core.project(pts, None, np.ascontiguousarray(normal))
    return uv, Frame(*frame)
