"""The connected pieces of a mesh: what came out of a fusion, and the specks taken off it.

A piece is a set of faces joined through shared vertices. Per piece: its faces, its area,
whether it is closed (every edge on two faces), its genus when it is (``(2 − χ) / 2``, χ the
Euler characteristic V − E + F) and its holes (boundary loops) when it is not.

A speck is a piece whose area is under :data:`SPECK_SHARE` of the largest piece's: on real
range scans they are the returns of noise no other view confirmed (outliers, the mixed
pixels of a silhouette) closed into tiny bodies; no piece of a real part is that small
beside the rest of it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from scanmesh import shape

#: Pieces with less than this share of the largest piece's area are specks (taken off by
#: :func:`scanmesh.merge`). Measured on the Stanford dragon from 15 views at a 1 mm voxel
#: (docs/benchmarks/merge.md): the specks were 4-600 faces, at most 0.2 % of the body's
#: area; 1 % leaves a margin of five.
SPECK_SHARE = 0.01


@dataclass(frozen=True)
class Piece:
    """One connected piece of a mesh."""

    #: faces in the piece
    faces: int
    #: area (model units squared)
    area: float
    #: every edge on exactly two faces
    closed: bool
    #: handles of a closed piece ((2 − χ) / 2), None when not closed
    genus: float | None
    #: boundary loops (holes) of an open piece, 0 when closed
    holes: int


def face_pieces(faces: np.ndarray, n_vertices: int) -> np.ndarray:
    """(M,) int64 the piece of each face, pieces numbered by falling face count. O(M)."""
    f = np.asarray(faces, dtype=np.int64)
    if len(f) == 0:
        return np.zeros(0, dtype=np.int64)
    rows = np.concatenate([f[:, 0], f[:, 1]])
    cols = np.concatenate([f[:, 1], f[:, 2]])
    graph = coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(n_vertices, n_vertices))
    _, of_vertex = connected_components(graph, directed=False)
    raw = of_vertex[f[:, 0]]
    _, inverse, counts = np.unique(raw, return_inverse=True, return_counts=True)
    rank = np.empty(len(counts), dtype=np.int64)
    rank[np.argsort(-counts, kind="stable")] = np.arange(len(counts))
    return rank[inverse]


def pieces(vertices: np.ndarray, faces: np.ndarray) -> list[Piece]:
    """The pieces of a mesh, largest (by faces) first. O(M log M)."""
    f = np.asarray(faces, dtype=np.int64)
    of = face_pieces(f, len(vertices))
    tri = np.asarray(vertices, dtype=np.float64)[f]
    each = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    out = []
    order = np.argsort(of, kind="stable")
    bounds = np.searchsorted(of[order], np.arange(of.max() + 2 if len(of) else 1))
    for k in range(len(bounds) - 1):
        mine = order[bounds[k] : bounds[k + 1]]
        sub = f[mine]
        closed = shape.is_watertight(sub)
        euler = shape.euler_characteristic(sub)
        out.append(
            Piece(
                faces=len(sub),
                area=float(each[mine].sum()),
                closed=closed,
                genus=(2 - euler) / 2 if closed else None,
                holes=0 if closed else len(shape.boundary_loops(sub)),
            )
        )
    return out


def drop_specks(
    vertices: np.ndarray, faces: np.ndarray, labels: np.ndarray | None, share: float = SPECK_SHARE
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, dict[str, float]]:
    """The mesh without its specks (pieces under ``share`` of the largest piece's area),
    its vertices compacted, and what was taken off: ``{"pieces", "faces", "area",
    "largest"}`` (the largest speck's faces). O(M log M)."""
    f = np.asarray(faces, dtype=np.int64)
    removed = {"pieces": 0, "faces": 0, "area": 0.0, "largest": 0}
    if len(f) == 0:
        return vertices, faces, labels, removed
    of = face_pieces(f, len(vertices))
    tri = np.asarray(vertices, dtype=np.float64)[f]
    each = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    area = np.bincount(of, weights=each)
    speck = area < share * area.max()
    if not speck.any():
        return vertices, faces, labels, removed
    gone = speck[of]
    sizes = np.bincount(of[gone])
    removed = {
        "pieces": int(speck.sum()),
        "faces": int(gone.sum()),
        "area": float(each[gone].sum()),
        "largest": int(sizes.max()),
    }
    keep = f[~gone]
    used = np.unique(keep)
    remap = np.full(len(vertices), -1, dtype=np.int64)
    remap[used] = np.arange(len(used))
    out_faces = remap[keep].astype(np.asarray(faces).dtype)
    return (
        np.asarray(vertices)[used],
        out_faces,
        None if labels is None else np.asarray(labels)[~gone],
        removed,
    )
