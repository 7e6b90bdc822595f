"""Writing meshes to disk atomically: a temporary file in the target folder, then a rename."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np

from scanmesh.errors import ParameterError

#: File endings we write, mapped to trimesh's export type.
FORMATS = {".stl": "stl", ".ply": "ply", ".obj": "obj", ".off": "off"}


def save_mesh(path: str | os.PathLike, vertices: np.ndarray, faces: np.ndarray) -> Path:
    """Write a triangle mesh, choosing the format by the file ending (.stl binary, .ply, .obj, .off).

    The data goes to a temporary file beside ``path`` which is renamed over it only when
    complete, so a failure or an interruption never leaves a half-written file.
    """
    import trimesh

    target = Path(path)
    kind = FORMATS.get(target.suffix.lower())
    if kind is None:
        raise ParameterError(
            f"cannot write {target}: unknown ending {target.suffix!r}; use one of {sorted(FORMATS)}"
        )
    mesh = trimesh.Trimesh(vertices=vertices, faces=faces, process=False)
    data = mesh.export(file_type=kind)
    if isinstance(data, str):
        data = data.encode()
    folder = target.parent if str(target.parent) else Path(".")
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".part", dir=folder)
    try:
        with os.fdopen(fd, "wb") as handle:
            handle.write(data)
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(tmp, target)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return target
