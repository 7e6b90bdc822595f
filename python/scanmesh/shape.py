"""Plain geometry of a triangle mesh: face and vertex normals, area, boundary loops."""

from __future__ import annotations

import numpy as np


def face_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(M, 3) float64 unit normals of the faces, by their winding (zero for a face of no
    area). O(M)."""
    tri = np.asarray(vertices, dtype=np.float64)[np.asarray(faces, dtype=np.int64)]
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    length = np.linalg.norm(cross, axis=1)
    return np.divide(cross, length[:, None], out=np.zeros_like(cross), where=length[:, None] > 0)


def vertex_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(N, 3) float64 unit normals of the vertices: the area-weighted mean of their faces'
    normals (zero for a vertex no face uses). O(N + M)."""
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    tri = v[f]
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])  # 2 x area x normal
    summed = np.zeros_like(v)
    for k in range(3):
        np.add.at(summed, f[:, k], cross)
    length = np.linalg.norm(summed, axis=1)
    return np.divide(summed, length[:, None], out=np.zeros_like(v), where=length[:, None] > 0)


def area(vertices: np.ndarray, faces: np.ndarray) -> float:
    """Total area of the faces (model units squared). O(M)."""
    tri = np.asarray(vertices, dtype=np.float64)[np.asarray(faces, dtype=np.int64)]
    return float(
        0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1).sum()
    )


def boundary_loops(faces: np.ndarray) -> list[np.ndarray]:
    """The mesh's boundary as closed loops of vertex indices, each in the faces' winding
    (an edge on one face only is a boundary edge); the outline and every hole is a loop.
    A vertex where the boundary touches itself is visited once per passage. O(M log M)."""
    f = np.asarray(faces, dtype=np.int64)
    if len(f) == 0:
        return []
    edges = f[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    _, inverse, counts = np.unique(
        np.sort(edges, axis=1), axis=0, return_inverse=True, return_counts=True
    )
    boundary = edges[counts[inverse.ravel()] == 1]
    following: dict[int, list[int]] = {}
    for a, b in boundary.tolist():
        following.setdefault(a, []).append(b)
    loops = []
    for start in [int(a) for a in boundary[:, 0]]:
        if not following.get(start):
            continue
        loop, here = [start], following[start].pop()
        while here != start and following.get(here):
            loop.append(here)
            here = following[here].pop()
        loops.append(np.array(loop, dtype=np.int64))
    return loops


def is_watertight(faces: np.ndarray) -> bool:
    """True when every edge lies on exactly two faces (trimesh's definition: closed and
    edge-manifold; winding is not judged); False for no faces. O(M log M)."""
    f = np.asarray(faces, dtype=np.int64)
    if len(f) == 0:
        return False
    edges = np.sort(f[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    return bool((counts == 2).all())


def euler_characteristic(faces: np.ndarray) -> int:
    """V - E + F over the vertices the faces use (2 - 2 genus for one closed orientable
    piece, summed over pieces). O(M log M)."""
    f = np.asarray(faces, dtype=np.int64)
    edges = np.unique(np.sort(f[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1), axis=0)
    return int(len(np.unique(f)) - len(edges) + len(f))
