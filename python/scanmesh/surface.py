"""The result type: a triangulated surface over the caller's points, with its quality."""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from scanmesh.projection import Frame
from scanmesh.quality import Quality, quality

if TYPE_CHECKING:
    import trimesh


@dataclass(eq=False)
class Surface:
    """A triangle mesh whose vertices are the input points, in input order.

    ``faces`` index the caller's own array, so per-point data lines up without remapping.
    Points that no face uses (coincident duplicates, trimmed outliers) stay in ``vertices``.
    """

    #: (N, 3) float64 the input points
    vertices: np.ndarray
    #: (M, 3) int64 triangles, counter-clockwise seen against the projection normal
    faces: np.ndarray
    #: name of the method that produced the faces
    method: str = "delaunay"
    #: the options the method ran with
    options: dict[str, Any] = field(default_factory=dict)
    #: the projection plane, for planar methods
    frame: Frame | None = None
    #: (K, 2) int64 pairs (unused point, the coincident point standing for it)
    duplicates: np.ndarray = field(default_factory=lambda: np.empty((0, 2), dtype=np.int64))
    #: seconds per stage
    timings: dict[str, float] = field(default_factory=dict)
    #: annealing trace, per sweep: "temperature", "energy", "best", "acceptance" (S,) arrays
    trace: dict[str, np.ndarray] | None = None
    #: (N,) int64 scan line of each point, when known
    line_ids: np.ndarray | None = None
    #: exact methods: True when optimality was proven, False when a limit stopped the search;
    #: None for heuristics
    certified: bool | None = None
    #: exact methods: remaining relative gap (objective - lower bound) / objective, 0 when
    #: proven; None for heuristics
    gap: float | None = None

    @cached_property
    def quality(self) -> Quality:
        """tac norms, smallest angle and sliver share of this mesh (computed once)."""
        return quality(self.vertices, self.faces)

    def to_trimesh(self) -> trimesh.Trimesh:
        """A ``trimesh.Trimesh`` sharing vertex indices (``process=False``)."""
        import trimesh

        return trimesh.Trimesh(vertices=self.vertices, faces=self.faces, process=False)

    def save(self, path: str | os.PathLike) -> Path:
        """Write the mesh by file ending (.stl binary, .ply, .obj, .off), atomically."""
        from scanmesh.writers import save_mesh

        return save_mesh(path, self.vertices, self.faces)

    def __repr__(self) -> str:
        return (
            f"Surface(method={self.method!r}, vertices={len(self.vertices)}, "
            f"faces={len(self.faces)})"
        )
