"""Quality criteria of a mesh: total absolute curvature (tac) norms, the max-min angle, and
the curtains (faces a scanner looking along a line of sight cannot have seen)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
from numpy.typing import ArrayLike

from scanmesh import _core
from scanmesh._checks import as_faces, as_points
from scanmesh._interrupt import interruptible
from scanmesh.scan.planar import PlanarScan

#: A triangle whose smallest 3-D angle is below this (degrees) counts as a sliver.
SLIVER_ANGLE_DEG: float = _core.SLIVER_ANGLE_DEG


def _radians_from(limit_deg: float) -> float:
    """The smallest float r with ``np.degrees(r) >= limit_deg``: as ``np.degrees`` never
    decreases, ``a < r`` exactly when ``np.degrees(a) < limit_deg``, so a share of angles
    below a limit in degrees is counted on the radians, without converting them all."""
    r = math.radians(limit_deg)
    while np.degrees(r) >= limit_deg:
        r = float(np.nextafter(r, -math.inf))
    while np.degrees(r) < limit_deg:
        r = float(np.nextafter(r, math.inf))
    return r


#: A face whose plane comes within this angle (degrees) of the line of sight is a curtain:
#: the scanner's rays graze it, so no sample can lie inside it.
CURTAIN_ANGLE_DEG: float = 5.0

#: Curtains covering more than this share of a mesh's area are warned about.
CURTAIN_WARN_FRACTION: float = 0.005

#: Faces per block in :func:`curtains` (their corners take 4.7 MB).
_CURTAIN_BLOCK: int = 1 << 16

#: A face is a sliver when its smallest angle in radians is below this (SLIVER_ANGLE_DEG).
_SLIVER_RADIANS: float = _radians_from(SLIVER_ANGLE_DEG)


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
    #: (M,) float64 smallest angle of each face (radians, as measured)
    face_min_angle: np.ndarray = field(repr=False)

    @cached_property
    def face_min_angle_deg(self) -> np.ndarray:
        """(M,) float64 smallest angle of each face (degrees; converted on first use)."""
        return np.degrees(self.face_min_angle)

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
    # in a worker for a large mesh: Ctrl-C answers during the native call (2 s at 5M faces)
    tac, min_angle = interruptible(len(tri), _core.mesh_quality, pts, tri)
    # Scalars from the radians (the per-face degrees are converted only if asked for): at
    # 20M faces the conversion and the comparison on it take 0.5 s.
    smallest = float(np.degrees(min_angle.min())) if len(min_angle) else math.nan
    slivers = (
        np.count_nonzero(min_angle < _SLIVER_RADIANS) / len(min_angle) if len(min_angle) else 0.0
    )
    return Quality(
        tac_1=_core.tac_norm(tac, 1.0),
        tac_2=_core.tac_norm(tac, 2.0),
        tac_inf=_core.tac_norm(tac, math.inf),
        n_interior=len(tac) - int(np.count_nonzero(np.isnan(tac))),
        min_angle_deg=smallest,
        sliver_fraction=float(slivers),
        tac=tac,
        face_min_angle=min_angle,
    )


def unit_factors(largest: float) -> tuple[tuple[float, float], tuple[float, float]]:
    """Two powers of two whose product takes ``largest`` (>= 0) into [0.5, 1), and the two
    that take it back: one factor alone over- or underflows at the ends of the float range.
    Multiplying by powers of two is exact (bar subnormals)."""
    if not largest > 0 or not math.isfinite(largest):
        return (1.0, 1.0), (1.0, 1.0)
    e = math.frexp(largest)[1]
    half = e // 2
    return (math.ldexp(1.0, -half), math.ldexp(1.0, half - e)), (
        math.ldexp(1.0, half),
        math.ldexp(1.0, e - half),
    )


@dataclass(frozen=True)
class Curtains:
    """The faces of a mesh within CURTAIN_ANGLE_DEG of a line of sight (their normal within
    that angle of perpendicular to it): sheets a scanner's rays pass along, not surface."""

    #: number of curtain faces
    count: int
    #: their total area (model units squared)
    area: float
    #: their share of the mesh's area (0 for a mesh without area)
    fraction: float
    #: (K,) int64 the curtain faces, largest first
    faces: np.ndarray = field(repr=False)

    def as_dict(self) -> dict[str, float | int]:
        """The scalar figures, for reports and JSON."""
        return {"count": self.count, "area": self.area, "fraction": self.fraction}


def curtains(vertices: ArrayLike, faces: ArrayLike, sight: ArrayLike) -> Curtains:
    """The faces within CURTAIN_ANGLE_DEG of the (3,) line of sight ``sight`` (either sign).

    Parameters
    ----------
    vertices : (N, 3) float
    faces : (M, 3) int
    sight : (3,) float, non-zero

    Returns
    -------
    Curtains
        Zero-area faces are not counted. O(M). Measured in a box scaled by a power of two:
        the same faces at any magnitude (the area is ``inf`` past the float range).
    """
    pts = as_points(vertices, "vertices")
    tri = as_faces(faces, len(pts))
    s = np.asarray(sight, dtype=np.float64).reshape(3)
    s = s / np.linalg.norm(s)
    # in a box of side about 1 (a power of two: exact), so that coordinates from 1e-300 to
    # 1e300 neither overflow nor underflow in the cross products
    down, up = unit_factors(float(np.abs(pts).max()) if len(pts) else 0.0)
    limit = math.sin(math.radians(CURTAIN_ANGLE_DEG))
    # (M,) twice each face's area in the box, and whether its plane is within
    # CURTAIN_ANGLE_DEG of the sight line; computed in blocks of faces, so the corners and
    # normals never exist for the whole mesh at once (9 floats per face each), nor a
    # scaled copy of the points
    twice = np.empty(len(tri))
    graze = np.empty(len(tri), dtype=bool)
    for lo in range(0, len(tri), _CURTAIN_BLOCK):
        hi = min(lo + _CURTAIN_BLOCK, len(tri))
        corner = pts[tri[lo:hi]] * down[0] * down[1]
        normal = np.cross(corner[:, 1] - corner[:, 0], corner[:, 2] - corner[:, 0])
        twice[lo:hi] = np.linalg.norm(normal, axis=1)
        # |cos| of the angle between normal and sight below sin(5 deg): the plane is
        # within 5 deg of the sight line
        graze[lo:hi] = (np.abs(normal @ s) <= limit * twice[lo:hi]) & (twice[lo:hi] > 0)
    which = np.flatnonzero(graze)
    which = which[np.argsort(-twice[which], kind="stable")]
    area = 0.5 * float(twice[which].sum())
    total = 0.5 * float(twice.sum())
    return Curtains(
        count=len(which),
        area=area * up[0] * up[0] * up[1] * up[1],  # Python floats: inf past 1e308
        fraction=area / total if total > 0 else 0.0,
        faces=which.astype(np.int64),
    )
