"""The spacings of a scan: which median of which distances each one is, in one place.

Three different quantities are called a scan's spacing, and each has one function:

- :func:`nearest_spacing`: the median over the points of the planar distance to the nearest
  neighbour, taken along Delaunay edges (the core's ``median_spacing``; the upper median,
  element n // 2 of the sorted distances). Trimming measures ``max_edge`` in it
  (:func:`trim_length`: Delaunay's default ``max_edge``, the quick triangulations of the
  plane choice, ``scanmesh info``'s reported spacing); the tiled Delaunay finds the same
  median over the tiles (``scanmesh.distributed._median.exact_median``).
- :func:`median_edge`: the median planar length of a triangulation's edges (numpy's
  median: the mean of the two middle values for an even count). Annealing's automatic tie
  tolerance measures the noise in it (``scanmesh.scan.noise.tie_tolerance``). Edges are
  longer than nearest distances: this is not :func:`nearest_spacing`.
- the median step along the scan lines (``ScanLines.median_step``, from the core's
  ``scan_segments``; the upper median of the non-zero steps between consecutive points of
  a line): the unit of the gap factor and of the strip weights. The strips on a cluster
  find the same median over the parts (``scanmesh.distributed._median.exact_median``).

The digitizer's spacing (``scanmesh.evaluate.digitizer``) is none of these: it is the
step of the simulated scanner's ray grid, chosen, not measured.
"""

from __future__ import annotations

import numpy as np

from scanmesh import _core

#: Default ``max_edge`` in multiples of :func:`nearest_spacing` (planar): Delaunay's
#: trimming and the plane choice's quick triangulations alike.
MAX_EDGE_FACTOR: float = _core.DEFAULT_MAX_EDGE_FACTOR

#: Faces per batch of :func:`median_edge` (bounds its temporaries).
EDGE_CHUNK: int = 1 << 20


def nearest_spacing(uv: np.ndarray, faces: np.ndarray) -> float:
    """Median planar nearest-neighbour distance of the points ``uv`` (N, 2) float64, along
    the edges of their Delaunay triangulation ``faces`` (M, 3) (the nearest-neighbour graph
    is a subgraph of it), near-duplicates skipped; the upper median (element n // 2 of the
    sorted distances), 0 when there is no face. O(M + N log N)."""
    return _core.median_spacing(uv, faces)


def trim_length(uv: np.ndarray, faces: np.ndarray) -> float:
    """The default trimming length: :data:`MAX_EDGE_FACTOR` x :func:`nearest_spacing`."""
    return MAX_EDGE_FACTOR * nearest_spacing(uv, faces)


def median_edge(uv: np.ndarray, faces: np.ndarray) -> float:
    """Median planar length of the triangles' edges (each interior edge counted twice;
    numpy's median, the mean of the two middle lengths for an even count).

    Faces are measured in batches of :data:`EDGE_CHUNK` into one array of 3F lengths,
    whose median is taken in place: the corner coordinates of all faces at once were
    three arrays of 48 bytes per face. O(F).
    """
    faces = np.asarray(faces)
    lengths = np.empty(3 * len(faces))
    for first in range(0, len(faces), EDGE_CHUNK):
        tri = uv[np.asarray(faces[first : first + EDGE_CHUNK], dtype=np.int64)]
        edges = np.linalg.norm(tri - np.roll(tri, 1, axis=1), axis=2)
        lengths[3 * first : 3 * first + edges.size] = edges.ravel()
    return float(np.median(lengths, overwrite_input=True)) if lengths.size else 0.0


__all__ = ["MAX_EDGE_FACTOR", "nearest_spacing", "trim_length", "median_edge"]
