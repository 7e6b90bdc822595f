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
    _, inverse, counts = np.unique(_edge_keys(edges), return_inverse=True, return_counts=True)
    boundary = edges[counts[inverse] == 1]
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
    _, counts = np.unique(_edge_keys(f[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)), return_counts=True)
    return bool((counts == 2).all())


def euler_characteristic(faces: np.ndarray) -> int:
    """V - E + F over the vertices the faces use (2 - 2 genus for one closed orientable
    piece, summed over pieces). O(M log M)."""
    f = np.asarray(faces, dtype=np.int64)
    edges = _distinct(_edge_keys(f[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)))
    return int(len(_distinct(f)) - len(edges) + len(f))


def _edge_keys(edges: np.ndarray) -> np.ndarray:
    """(E,) uint64 one key per undirected edge of (E, 2) vertex indices (below 2³², more
    vertices than any mesh in memory has): the smaller end in the high half. Why: np.unique
    of the (E, 2) rows (``axis=0``) sorts them as opaque records, about 80 times slower than
    the keys (8 s for a fused dragon's 4.4 million edge uses under load, in one call that
    Ctrl-C cannot interrupt). O(E)."""
    a, b = edges[:, 0].astype(np.uint64), edges[:, 1].astype(np.uint64)
    return (np.minimum(a, b) << np.uint64(32)) | np.maximum(a, b)


def _distinct(values: np.ndarray) -> np.ndarray:
    """The distinct values of an integer array, sorted (``np.unique(values)``), by one sort.
    Why: numpy 2.3 and later find the distinct values of a plain ``np.unique`` by hashing,
    which took 5-14 s for 4.4 million integers here (most of them distinct) where the sort
    takes 0.1 s, in one call that Ctrl-C cannot interrupt. O(n log n)."""
    s = np.sort(values, axis=None)
    return s[np.concatenate(([True], s[1:] != s[:-1]))] if len(s) else s
