"""The vertices of a mesh file (STL, OBJ, OFF) read as scan points, its faces ignored
(a closed mesh given to ``reconstruct`` is scanned instead: ``scan.closed_part``).

A mesh someone already has (a previous reconstruction, a patch of a surface) is a cloud of points
to mesh again. Read through trimesh as the file stores them; STL repeats each vertex in
every triangle that uses it, so exact repeats are dropped, the first kept, file order
otherwise unchanged. PLY meshes are read by :mod:`.ply` (vertex properties kept).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from scanmesh._interrupt import import_interruptibly
from scanmesh.errors import FileFormatError
from scanmesh.formats._source import check_finite, check_regular
from scanmesh.formats.points import ScanPoints


def read_mesh_points(path: str | os.PathLike) -> ScanPoints:
    """Read the distinct vertices of an STL (binary or ASCII), OBJ or OFF mesh.

    Returns
    -------
    ScanPoints
        ``points`` (N, 3) float64: each distinct vertex once, in the order the file first
        lists it; no line ids; ``extra["faces_ignored"]`` the file's face count and
        ``extra["repeats_dropped"]`` the vertex repeats left out. O(V log V).
    """
    trimesh = import_interruptibly("trimesh")
    path = Path(path)
    if check_regular(path) == 0:
        raise FileFormatError(f"{path}: the file is empty; expected a mesh")
    kind = path.suffix.lower().lstrip(".")
    try:
        mesh = trimesh.load_mesh(path, file_type=kind, process=False)
    except Exception as exc:  # trimesh raises many kinds for bad files
        raise FileFormatError(f"{path}: not a readable {kind.upper()} mesh: {exc}") from None
    if isinstance(mesh, trimesh.Scene):
        meshes = list(mesh.geometry.values())
        vertices = np.concatenate([np.asarray(m.vertices) for m in meshes]) if meshes else []
        n_faces = sum(len(getattr(m, "faces", ())) for m in meshes)
    else:
        vertices, n_faces = np.asarray(mesh.vertices), len(getattr(mesh, "faces", ()))
    vertices = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
    if not len(vertices):
        raise FileFormatError(f"{path}: the {kind.upper()} file holds no vertices")
    check_finite(path, vertices, "vertex")
    _, first = np.unique(vertices, axis=0, return_index=True)
    keep = np.sort(first)
    return ScanPoints(
        points=vertices[keep],
        line_ids=None,
        source=path,
        extra={
            "format": kind,
            "faces_ignored": int(n_faces),
            "repeats_dropped": int(len(vertices) - len(keep)),
            "line_ids_from": None,
        },
    )
