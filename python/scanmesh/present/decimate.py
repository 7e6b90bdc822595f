"""Fewer faces for display: vertex clustering on a grid of cubes.

A mesh too large to send to a browser page (a notebook cell) is shown as a coarser copy:
the vertices in each cube of a regular grid merge into their mean, faces whose corners
merge vanish, repeated faces are kept once, and the cube size grows until at most
``max_faces`` remain (Rossignac and Borrel's clustering: O(N + M) per try, a few tries).
Winding is kept, so the display is lit as the mesh is. For display only: the coarse copy
is no reconstruction and is never measured.
"""

from __future__ import annotations

import math

import numpy as np

from scanmesh import shape

#: Most grid refinements :func:`cluster` tries before it takes what it has.
MAX_TRIES: int = 12


def _merge(vertices: np.ndarray, faces: np.ndarray, cell: float):
    """Vertices merged per cube of side ``cell``: (K, 3) means and the surviving faces."""
    used = np.unique(faces)
    lo = vertices[used].min(axis=0)
    keys = np.floor((vertices[used] - lo) / cell).astype(np.int64)
    span = keys.max(axis=0) + 1
    flat = keys[:, 0] + span[0] * (keys[:, 1] + span[1] * keys[:, 2])
    _, group = np.unique(flat, return_inverse=True)
    group = group.ravel()
    count = np.bincount(group)
    means = np.column_stack(
        [np.bincount(group, weights=vertices[used, k]) / count for k in range(3)]
    )
    to_group = np.full(len(vertices), -1, dtype=np.int64)
    to_group[used] = group
    merged = to_group[faces]
    keep = (
        (merged[:, 0] != merged[:, 1])
        & (merged[:, 1] != merged[:, 2])
        & (merged[:, 0] != merged[:, 2])
    )
    merged = merged[keep]
    _, first = np.unique(np.sort(merged, axis=1), axis=0, return_index=True)
    return means, merged[np.sort(first)]


def cluster(
    vertices: np.ndarray, faces: np.ndarray, max_faces: int
) -> tuple[np.ndarray, np.ndarray]:
    """At most ``max_faces`` faces showing the mesh (``vertices`` (N, 3), ``faces`` (M, 3)
    int): the mesh itself when it has no more, else its vertex clustering with the
    smallest cube size tried that is coarse enough. Returns ((K, 3) float64, (L, 3) int64)."""
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    if len(f) <= max_faces:
        return v, f
    # a surface of area A over cubes of side c touches about A / c^2 cubes, and a
    # triangulation has about two faces per vertex
    cell = math.sqrt(2.0 * max(shape.area(v, f), 1e-300) / max_faces)
    for _ in range(MAX_TRIES):
        means, merged = _merge(v, f, cell)
        if len(merged) <= max_faces:
            return means, merged
        cell *= 1.1 * math.sqrt(len(merged) / max_faces)
    return means, merged[:max_faces]
