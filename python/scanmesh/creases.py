"""Creases of a triangle mesh: its edges where the surface turns sharply, chained into lines.

A crease edge is an edge shared by exactly two faces whose normals differ by more than
``angle`` degrees (the dihedral angle's supplement: 0 on a flat surface). Crease edges are
chained into polylines through vertices where exactly two crease edges meet; a polyline
ends where one, three or more meet (a corner) and is closed when it comes back to its
start. O(M log M) for M faces.
"""

from __future__ import annotations

import numpy as np

from scanmesh import shape

#: Default threshold between face normals for a crease (degrees).
CREASE_ANGLE_DEG: float = 30.0


def crease_edges(
    vertices: np.ndarray, faces: np.ndarray, angle: float = CREASE_ANGLE_DEG
) -> np.ndarray:
    """(K, 2) int64 vertex pairs (smaller first) of the edges between two faces whose
    normals differ by more than ``angle`` degrees."""
    faces = np.asarray(faces, dtype=np.int64)
    if len(faces) == 0:
        return np.empty((0, 2), dtype=np.int64)
    normals = shape.face_normals(np.asarray(vertices, dtype=np.float64), faces)
    edges = np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    key = edges[:, 0] * (int(faces.max()) + 1) + edges[:, 1]
    order = np.argsort(key, kind="stable")
    edges, owner = edges[order], np.repeat(np.arange(len(faces)), 3)[order]
    _, start, count = np.unique(key[order], return_index=True, return_counts=True)
    two = start[count == 2]  # edges of exactly two faces: both owners side by side
    cos = np.einsum("ij,ij->i", normals[owner[two]], normals[owner[two + 1]])
    return edges[two[cos < np.cos(np.radians(angle))]]


def chain(edges: np.ndarray) -> list[np.ndarray]:
    """The polylines (vertex index arrays) the edges (K, 2) form; a closed one repeats its
    first vertex at the end."""
    if len(edges) == 0:
        return []
    nbrs: dict[int, list[int]] = {}
    for a, b in edges.tolist():
        nbrs.setdefault(a, []).append(b)
        nbrs.setdefault(b, []).append(a)
    used: set[tuple[int, int]] = set()

    def walk(start: int, nxt: int) -> list[int]:
        line = [start]
        prev, cur = start, nxt
        while True:
            used.add((min(prev, cur), max(prev, cur)))
            line.append(cur)
            if len(nbrs[cur]) != 2 or cur == start:
                return line
            step = nbrs[cur][0] if nbrs[cur][1] == prev else nbrs[cur][1]
            if (min(cur, step), max(cur, step)) in used:
                return line
            prev, cur = cur, step

    lines = []
    ends = [v for v, n in nbrs.items() if len(n) != 2]
    for v in ends + list(nbrs):  # open lines from their ends first, then closed loops
        for w in nbrs[v]:
            if (min(v, w), max(v, w)) not in used:
                lines.append(np.array(walk(v, w), dtype=np.int64))
    return lines


def creases(
    vertices: np.ndarray, faces: np.ndarray, angle: float = CREASE_ANGLE_DEG
) -> list[np.ndarray]:
    """The crease polylines of a mesh (see the module comment)."""
    return chain(crease_edges(vertices, faces, angle))
