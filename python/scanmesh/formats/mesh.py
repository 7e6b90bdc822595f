"""Loading a triangle mesh (STL, PLY, OBJ, OFF, GLB, ... through trimesh) as a
``trimesh.Trimesh``: a CAD part to scan or to judge against, or a mesh to picture."""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from scanmesh._interrupt import import_interruptibly
from scanmesh.errors import FileFormatError, InvalidMeshError, MissingFileError, ParameterError
from scanmesh.formats import MESH_FORMATS, READERS

if TYPE_CHECKING:
    import trimesh


#: Endings of files that hold scan points only (no faces): refused as meshes by name.
POINT_ENDINGS = tuple(sorted(set(READERS) - set(MESH_FORMATS) - {".vtk"}))


def _not_a_mesh(path: Path, what: str) -> FileFormatError:
    return FileFormatError(
        f"{path} {what}: a mesh (.stl, .ply, .obj, .off, .glb) is expected here; make one"
        f" with: scanmesh reconstruct {path} -o mesh.stl"
    )


def load_mesh(mesh_or_path: trimesh.Trimesh | str | os.PathLike) -> trimesh.Trimesh:
    """Return a ``trimesh.Trimesh`` from a mesh object or a mesh file (STL, PLY, OBJ, OFF, ...).

    Raises FileFormatError for a missing, unreadable or empty file and InvalidMeshError for
    a mesh object without triangles.
    """
    trimesh = import_interruptibly("trimesh")

    if isinstance(mesh_or_path, (str, os.PathLike)):
        path = Path(mesh_or_path)
        if not path.exists():
            error = MissingFileError(f"mesh file {path} does not exist")
            error.filename = str(path)
            raise error
        if not path.is_file():
            raise FileFormatError(f"mesh file {path} is not a regular file")
        if path.stat().st_size == 0:
            raise FileFormatError(f"mesh file {path} is empty")
        if path.suffix.lower() in POINT_ENDINGS:
            raise _not_a_mesh(path, "is a file of points")
        try:
            mesh = trimesh.load_mesh(path)
        except Exception as exc:  # trimesh raises many kinds for bad files
            raise FileFormatError(f"cannot read mesh file {path}: {exc}") from None
        if isinstance(mesh, trimesh.Scene):
            mesh = _scene_mesh(mesh)
        if not len(getattr(mesh, "faces", ())) and path.suffix.lower() in READERS:
            raise _not_a_mesh(path, "holds points but no triangles")
        if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
            raise FileFormatError(f"mesh file {path} holds no triangles")
        return mesh
    if isinstance(mesh_or_path, trimesh.Scene):
        mesh_or_path = _scene_mesh(mesh_or_path)
    if not isinstance(mesh_or_path, trimesh.Trimesh):
        raise ParameterError(
            f"expected a trimesh.Trimesh or a mesh file path, got {type(mesh_or_path).__name__}"
        )
    if len(mesh_or_path.faces) == 0:
        raise InvalidMeshError("the mesh has no triangles")
    if not np.all(np.isfinite(mesh_or_path.vertices)):
        raise InvalidMeshError("the mesh has non-finite vertex coordinates")
    return mesh_or_path


def _scene_mesh(scene: trimesh.Scene) -> trimesh.Trimesh:
    """All geometry of a scene as one mesh (``to_mesh`` in trimesh 4.1+, ``dump`` before)."""
    trimesh = import_interruptibly("trimesh")

    if not scene.geometry:
        return trimesh.Trimesh()
    if hasattr(scene, "to_mesh"):
        return scene.to_mesh()
    return scene.dump(concatenate=True)
