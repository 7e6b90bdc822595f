"""The truth-free judge: withhold points, build a mesh of the others, measure each withheld
point's distance to it along the normal it is seen along, and sum them up as an RMS.

Three questions are answered this way: which plane a scan is a height field over
(``scan.plane_choice``, on a quick Delaunay triangulation of a sample), which method the
default builds (``stages.choice``, candidates built on a window of the scan) and how far a
method's mesh lies from points it never saw (``evaluate.holdout.holdout_error``). Each
builds its own meshes; the withholding, the measure and the sum are this module's, so the
three judge alike.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from scanmesh.scan.locate import normal_distances
from scanmesh.scan.projection import Frame


class Built(Protocol):
    """A mesh built in a projection frame (a :class:`scanmesh.Surface`; the plane choice
    below the surfaces cannot name that class)."""

    vertices: np.ndarray
    faces: np.ndarray
    frame: Frame


@dataclass(frozen=True)
class Seen:
    """A mesh as the judge sees it: its triangles' corners and the frame it is seen in."""

    #: (F, 3, 3) float64 corners of the triangles
    tri: np.ndarray
    #: (3,) float64 unit normal the withheld points are measured along
    normal: np.ndarray
    #: (3, 2) float64 orthonormal axes of the plane (u, v)
    axes: np.ndarray

    @classmethod
    def of(cls, surface: Built) -> Seen:
        """``surface`` seen in its own projection frame."""
        frame = surface.frame
        return cls(
            surface.vertices[surface.faces], frame.normal, np.column_stack([frame.u, frame.v])
        )


def withhold(n: int, count: int, rng: np.random.Generator) -> np.ndarray:
    """(n,) bool: ``count`` of ``n`` points withheld, drawn by ``rng`` without replacement.
    O(n)."""
    out = np.zeros(n, dtype=bool)
    out[rng.choice(n, size=count, replace=False)] = True
    return out


def distances(withheld: np.ndarray, seen: Seen) -> tuple[np.ndarray, np.ndarray]:
    """(K,) float64 distance along ``seen.normal`` from each ``withheld`` point (K, 3) to the
    mesh (nan where no triangle lies above or below it: beyond the outline or in a hole)
    and (K,) int64 the triangle measured (-1: none). O((F + K) log F)."""
    return normal_distances(withheld, seen.tri, seen.axes, seen.normal)


def rms(distance: np.ndarray) -> float:
    """Root mean square of the (K,) distances measured (nan for none)."""
    return float(np.sqrt(np.mean(distance * distance))) if len(distance) else float("nan")


__all__ = ["Seen", "withhold", "distances", "rms"]
