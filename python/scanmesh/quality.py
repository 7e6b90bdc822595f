"""Quality criteria of a mesh: total absolute curvature (tac) norms and the max-min angle."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike

from scanmesh import _core
from scanmesh._checks import as_faces, as_points
from scanmesh.scan import PlanarScan

#: A triangle whose smallest 3-D angle is below this (degrees) counts as a sliver.
SLIVER_ANGLE_DEG: float = _core.SLIVER_ANGLE_DEG


@dataclass(frozen=True)
class Quality:
    """How good a triangulation is, measured in 3-D.

    tac (total absolute curvature) of an interior vertex is ``|2 pi - sum of its corner
    angles|`` in radians; smaller norms are smoother. The max-min angle criterion prefers a
    **larger** smallest angle.
    """

    #: sum of tac over interior vertices (radians)
    tac_1: float
    #: sqrt of the sum of tac squared (radians)
    tac_2: float
    #: largest tac (radians)
    tac_inf: float
    #: number of interior vertices (closed fans); boundary vertices have no tac
    n_interior: int
    #: smallest 3-D corner angle of any face (degrees); NaN for no faces
    min_angle_deg: float
    #: share of faces whose smallest angle is below SLIVER_ANGLE_DEG
    sliver_fraction: float
    #: (N,) float64 tac per vertex (radians), NaN on boundary and unused vertices
    tac: np.ndarray = field(repr=False)
    #: (M,) float64 smallest angle of each face (degrees)
    face_min_angle_deg: np.ndarray = field(repr=False)

    def tac_norm(self, p: float) -> float:
        """The tac p-norm for any p >= 1 (``math.inf`` for the maximum)."""
        return _core.tac_norm(self.tac, float(p))

    def better_than(self, other: Quality, p: float = 1.0) -> bool:
        """True when this mesh has the strictly smaller tac p-norm."""
        return self.tac_norm(p) < other.tac_norm(p)

    def as_dict(self) -> dict[str, float | int]:
        """The scalar figures, for reports and JSON."""
        return {
            "tac_1": self.tac_1,
            "tac_2": self.tac_2,
            "tac_inf": self.tac_inf,
            "n_interior": self.n_interior,
            "min_angle_deg": self.min_angle_deg,
            "sliver_fraction": self.sliver_fraction,
        }


def quality(vertices: ArrayLike | PlanarScan, faces: ArrayLike) -> Quality:
    """Measure a mesh: tac norms over interior vertices, smallest angle, sliver share.

    Parameters
    ----------
    vertices : (N, 3) float or PlanarScan
        Vertex positions (any real dtype), or the scan a mesh was built on (its points,
        already checked). Every figure is measured in 3-D: no plane is involved.
    faces : (M, 3) int
        Triangles as vertex indices; orientation does not matter.

    Returns
    -------
    Quality
    """
    pts = vertices.points if isinstance(vertices, PlanarScan) else as_points(vertices, "vertices")
    tri = as_faces(faces, len(pts))
    tac, min_angle = _core.mesh_quality(pts, tri)
    interior = ~np.isnan(tac)
    min_deg = np.degrees(min_angle)
    return Quality(
        tac_1=_core.tac_norm(tac, 1.0),
        tac_2=_core.tac_norm(tac, 2.0),
        tac_inf=_core.tac_norm(tac, math.inf),
        n_interior=int(interior.sum()),
        min_angle_deg=float(min_deg.min()) if len(min_deg) else math.nan,
        sliver_fraction=float((min_deg < SLIVER_ANGLE_DEG).mean()) if len(min_deg) else 0.0,
        tac=tac,
        face_min_angle_deg=min_deg,
    )
